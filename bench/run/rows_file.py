"""Reading a ``samples.jsonl`` without skipping anything in silence.

The runner appends and fsyncs one line per finished sample, so the only damage a kill can do is
a cut-off LAST line: it is skipped with a warning and its sample re-run on resume. Anything else
(a line edited by hand, a disk error, two files joined) is a :class:`~catpose.errors.DatasetError`
naming the file and the line, so a table is never made from a run with rows silently missing.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

from catpose.errors import DatasetError


class CutOffLineWarning(UserWarning):
    """A ``samples.jsonl`` whose last line was cut off (a killed run); its sample is re-run on resume."""


def _damaged(path: Path, line: int, why: str) -> DatasetError:
    return DatasetError(
        f"{path}:{line}: {why}; the file is damaged: restore it from a copy, or delete that line "
        "and re-run the same command (the sample is run again)"
    )


def _row(text: str, path: Path, line: int) -> dict:
    """One line as a row, or the one-line error naming it."""
    try:
        row = json.loads(text)
    except json.JSONDecodeError as e:
        raise _damaged(path, line, f"not a JSON row ({e.msg} at column {e.colno})") from None
    if not isinstance(row, dict) or not isinstance(row.get("sample_id"), str):
        raise _damaged(path, line, "not a sample row (a JSON object with a 'sample_id')")
    if not row["sample_id"].strip():
        raise _damaged(path, line, "its sample_id is empty")
    if row.get("status", "ok") not in ("ok", "failed"):
        raise _damaged(path, line, f"status {row['status']!r} is neither 'ok' nor 'failed'")
    for key, n in POSE_FIELDS.items():
        why = _numbers_problem(row.get(key), n)
        if why:
            raise _damaged(path, line, f"{key} {why}")
    nulls = [k for k in ("T_est", "T_gt") if k in row and row[k] is None]
    if row.get("status") == "ok" and nulls:  # a run writes both poses on every ok row
        raise _damaged(path, line, f"status 'ok' but {' and '.join(nulls)} null (an ok row holds both poses)")
    return row


POSE_FIELDS = {"T_est": 16, "T_gt": 16, "symmetry_axis": 3}
"""Fields of a row that hold numbers, and how many: a (4, 4) pose row-major, an axis (3,)."""


def _numbers_problem(value, n: int) -> str | None:
    """Why ``value`` (a row's field) is not ``n`` numbers, None when it is or when it is absent (null)."""
    if value is None:
        return None
    if not isinstance(value, list):
        return f"is not a list of {n} numbers (a {type(value).__name__})"
    if len(value) != n or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return f"is not {n} numbers ({len(value)} values)"
    return None


def _cut_off(text: str) -> bool:
    """Whether a last line is what a kill leaves: the start of a JSON object cut before its end (a
    row is a JSON object: cut anywhere, it does not parse). Anything else is a whole row or damage
    a kill cannot make (``[1, 2]``, ``nan``, an object without ``sample_id``)."""
    if not text.lstrip().startswith("{"):
        return False
    try:
        json.loads(text)
    except json.JSONDecodeError:
        return True
    return False


def _last_line_start(data: bytes) -> int:
    """Offset of the last non-empty line of ``data`` (0 when it is the first)."""
    end = len(data.rstrip(b"\r\n\t "))
    return data.rfind(b"\n", 0, end) + 1


def parse_rows(path: Path) -> list[dict]:
    """Every row of ``path`` in file order (see the module docstring); [] when it does not exist.

    Raises :class:`DatasetError` naming the file and line of a damaged line; warns
    (:class:`CutOffLineWarning`) about a cut-off last line, which is skipped.
    """
    path = Path(path)
    if not path.is_file():
        return []
    data = path.read_bytes()
    cut = _last_line_start(data)
    head, tail = data[:cut], data[cut:].strip()
    rows = []
    lines = head.split(b"\n")[:-1] if head else []
    for k, raw in enumerate(lines, 1):
        try:
            text = raw.decode("utf-8").strip()
        except UnicodeDecodeError:
            raise _damaged(path, k, "not UTF-8 text") from None
        if text:
            rows.append(_row(text, path, k))
    if tail:
        text = tail.decode("utf-8", errors="replace")
        if not _cut_off(text):  # a whole row, or damage no kill makes: read, or refused
            rows.append(_row(text, path, len(lines) + 1))
        else:
            warnings.warn(
                f"{path}: its last line ({len(lines) + 1}) is cut off, as a killed run leaves it; skipped 1 "
                "sample row (a resumed run does that sample again)",
                CutOffLineWarning,
                stacklevel=2,
            )
    return rows


def repair_last_line(path: Path) -> None:
    """Before appending to ``path`` (read by :func:`parse_rows` first): drop a cut-off last line (its
    sample is re-run), or end a whole last row that lacks its newline, so that the next row starts
    on a line of its own."""
    data = path.read_bytes()
    cut = _last_line_start(data)
    tail = data[cut:].strip()
    if not tail:
        return
    if _cut_off(tail.decode("utf-8", errors="replace")):
        with open(path, "r+b") as f:
            f.truncate(cut)
    elif not data.endswith(b"\n"):
        with open(path, "ab") as f:
            f.write(b"\n")
