"""Whether a dataset file is whole, from its header and size, without decoding it: what ``bench
data check`` asks of every depth image, mask and model of a dataset root (in seconds, where
loading each would take minutes).

- **PNG** (the PNG specification, ISO/IEC 15948): the 8-byte signature, an ``IHDR`` chunk first
  (width, height, bit depth, colour type), then chunks of ``length, type, data, CRC-32`` up to
  ``IEND``; a file cut off or damaged fails a chunk's length or CRC, or ends before ``IEND``.
  :func:`png_problem` also checks what a depth image must be (16-bit, one channel) and its size.
- **PLY** (Turk's format, as trimesh and Open3D read it): an ASCII header up to ``end_header``
  with ``element`` counts and ``property`` types; a binary body must be as long as those counts
  say (each face's index list read where the faces are not all triangles), an ASCII body must have
  a line per element. :func:`ply_problem`.

Each function returns ``None`` for a good file and otherwise one line saying what is wrong and
the fix; none raises for any content (a property test feeds them random and cut-off bytes).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_COLOURS = {0: "grey", 2: "RGB", 3: "palette", 4: "grey + alpha", 6: "RGBA"}
_REFETCH = "download or unzip it again"


def png_header(data: bytes) -> tuple[int, int, int, int] | None:
    """``(width, height, bit_depth, colour_type)`` of a PNG's ``IHDR``, None when ``data`` does not
    start with a PNG signature and an ``IHDR`` chunk."""
    if len(data) < 33 or data[:8] != PNG_SIGNATURE or data[12:16] != b"IHDR":
        return None
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    return width, height, depth, colour


def png_chunks_problem(data: bytes) -> str | None:
    """Why the chunks of a PNG's bytes are not whole (a chunk running past the end, a CRC that does
    not match, no ``IEND``), None when every chunk is whole up to ``IEND``."""
    pos = 8
    while True:
        if pos + 12 > len(data):
            return f"it ends at byte {len(data)} before the IEND chunk (cut off)"
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        end = pos + 12 + length
        if end > len(data):
            return f"its {kind.decode('latin-1')!r} chunk at byte {pos} runs past the end of the file (cut off)"
        (crc,) = struct.unpack(">I", data[end - 4 : end])
        if zlib.crc32(data[pos + 4 : end - 4]) & 0xFFFFFFFF != crc:
            return f"its {kind.decode('latin-1')!r} chunk at byte {pos} fails its CRC (damaged)"
        if kind == b"IEND":
            return None
        pos = end


def png_problem(path: Path, size: tuple[int, int] | None = None, depth16: bool = False) -> str | None:
    """Why the PNG at ``path`` is not a whole PNG (or, with ``depth16``, not a 16-bit single-channel
    depth image; with ``size``, not ``(width, height)``); None when it is."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        return f"{path} cannot be read ({e.strerror or type(e).__name__})"
    header = png_header(data)
    if header is None:
        return f"{path} is not a PNG ({'an empty file' if not data else 'no PNG signature and IHDR'}); {_REFETCH}"
    width, height, bit_depth, colour = header
    why = png_chunks_problem(data)
    if why:
        return f"{path} is not a whole PNG: {why}; {_REFETCH}"
    if depth16 and (bit_depth != 16 or colour != 0):
        kind = f"{bit_depth}-bit {_PNG_COLOURS.get(colour, f'colour type {colour}')}"
        return f"{path} is a {kind} PNG; a depth image is a 16-bit single-channel PNG"
    if size is not None and (width, height) != tuple(size):
        return f"{path} is {width}x{height}, not {size[0]}x{size[1]} as the other images of the dataset"
    return None


def png_size(path: Path) -> tuple[int, int] | None:
    """``(width, height)`` from a PNG's header, None when it has none."""
    try:
        with open(path, "rb") as fh:
            header = png_header(fh.read(33))
    except OSError:
        return None
    return None if header is None else header[:2]


_PLY_TYPES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8,
}  # fmt: skip
_PLY_STRUCT = {1: "B", 2: "H", 4: "I", 8: "Q"}


def _ply_header(data: bytes) -> tuple[str, list[tuple[str, int, list]], int] | str:
    """``(format, [(element, count, properties)], body offset)`` of a PLY, or why it has no header.
    A property is ``(size,)`` or, for a list, ``("list", count size, item size)``."""
    if not data.startswith(b"ply"):
        return "no 'ply' header" if data else "an empty file"
    end = data.find(b"end_header")
    if end < 0:
        return "its header has no end_header (cut off)"
    body = data.find(b"\n", end) + 1 or len(data)
    fmt, elements = None, []
    for raw in data[:end].decode("latin-1").splitlines()[1:]:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) >= 3:
            if words[1] == "list" and len(words) == 5 and words[2] in _PLY_TYPES and words[3] in _PLY_TYPES:
                elements[-1][2].append(("list", _PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
            elif words[1] in _PLY_TYPES and len(words) == 3:
                elements[-1][2].append((_PLY_TYPES[words[1]],))
            else:
                return f"its header line {raw.strip()[:40]!r} is not a PLY property"
        else:
            return f"its header line {raw.strip()[:40]!r} is not PLY"
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        return f"its header gives no PLY format (format {fmt!r})"
    return fmt, elements, body


def _binary_length(data: bytes, pos: int, elements: list, big: bool) -> int | str:
    """Where a binary PLY body that starts at ``pos`` ends, by its elements, or why it cannot be read."""
    order = ">" if big else "<"
    for name, count, props in elements:
        if all(len(p) == 1 for p in props):
            pos += count * sum(p[0] for p in props)
            continue
        lists = [p for p in props if len(p) == 3]
        if len(lists) == 1 and len(props) == 1:  # the usual faces: try all of one length first (fast)
            _, csize, isize = lists[0]
            if pos + csize <= len(data):
                (n,) = struct.unpack(order + _PLY_STRUCT[csize], data[pos : pos + csize])
                if pos + count * (csize + n * isize) == len(data):
                    return len(data)
        for _ in range(count):  # walk the element's rows
            for p in props:
                if len(p) == 1:
                    pos += p[0]
                    continue
                if pos + p[1] > len(data):
                    return f"its {name} data ends at byte {len(data)} (cut off)"
                (n,) = struct.unpack(order + _PLY_STRUCT[p[1]], data[pos : pos + p[1]])
                pos += p[1] + n * p[2]
    return pos


def _ascii_problem(rows: list[list[bytes]], elements: list) -> str | None:
    """Why the data lines of an ASCII PLY do not hold its elements (a line per element, each with
    its properties' values: a list's count and as many items), None when they do."""
    want = sum(n for _, n, _ in elements)
    if len(rows) < want:
        return f"{len(rows)} data lines where its header promises {want}"
    k = 0
    for name, count, props in elements:
        for _ in range(count):
            tokens, need, pos = rows[k], 0, 0
            for p in props:
                if len(p) == 1:
                    need, pos = need + 1, pos + 1
                    continue
                n = int(tokens[pos]) if pos < len(tokens) and tokens[pos].isdigit() else -1
                if n < 0:
                    return f"its {name} line {k + 1} of the data has no list count"
                need, pos = need + 1 + n, pos + 1 + n
            if len(tokens) < need:
                return f"its {name} line {k + 1} of the data has {len(tokens)} values, not {need}"
            k += 1
    return None


def ply_problem(path: Path) -> str | None:
    """Why the PLY at ``path`` is not whole (no header, a body shorter or longer than its element
    counts say), None when it is whole."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        return f"{path} cannot be read ({e.strerror or type(e).__name__})"
    header = _ply_header(data)
    if isinstance(header, str):
        return f"{path} is not a PLY model: {header}; {_REFETCH}"
    fmt, elements, body = header
    counts = ", ".join(f"element {name} {n}" for name, n, _ in elements)
    if fmt == "ascii":
        why = _ascii_problem([ln.split() for ln in data[body:].splitlines() if ln.strip()], elements)
        return None if why is None else f"{path}: {why} ({counts}): cut off; {_REFETCH}"
    end = _binary_length(data, body, elements, fmt == "binary_big_endian")
    if isinstance(end, str):
        return f"{path} is not a whole PLY model: {end} ({counts}); {_REFETCH}"
    if end > len(data):
        return f"{path} has {len(data) - body} bytes of data where its header ({counts}) needs {end - body}: cut off; {_REFETCH}"
    return None
