"""Arrays kept on disk between processes: what is built once per template (its partial-view
dictionary, the dictionary's keypoints and descriptors, its resting directions).

Where: ``$CATPOSE_CACHE_DIR`` or ``~/.cache/catpose`` (:func:`cache_dir`), one folder per kind,
one uncompressed ``<key>.npz`` per entry (no pickles). Keys hash the caller's content key with
:func:`fingerprint`: the source of the modules that compute the entry, the numerical libraries'
versions, the environment variables that choose their code paths (:data:`NUMERIC_ENV`) and the
CPU model, so another code path never reads bits this one computed. The full key text is stored
and compared on reading. Entries are written atomically (:mod:`catpose.atomic`); one that cannot
be read or fails the caller's check is rebuilt, and a folder that cannot be written costs only
the rebuild.

:func:`pack` / :func:`unpack`: nested tuples, lists, numbers, strings, None, arrays and allowed
dataclasses as arrays plus a JSON outline; a mostly-zero array is stored sparse and comes back
with the same dtype, shape, memory order and bits.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import os
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["cache_dir", "cached", "fingerprint", "load", "pack", "store", "unpack"]

log = logging.getLogger(__name__)

#: the numerical libraries whose versions every key includes
LIBRARIES = ("numpy", "scipy", "open3d-cpu", "open3d", "trimesh", "numba", "torch")
#: environment variables that choose a numerical library's code path (``bench run`` records those
#: set with every run, :mod:`catpose.bench.run.environment`)
NUMERIC_ENV = (
    "OPENBLAS_CORETYPE",
    "NPY_DISABLE_CPU_FEATURES",
    "NPY_ENABLE_CPU_FEATURES",
    "ATEN_CPU_CAPABILITY",
    "NUMBA_CPU_NAME",
    "NUMBA_CPU_FEATURES",
    "MKL_ENABLE_INSTRUCTIONS",
    "MKL_CBWR",
)
#: arrays at least this large with under a quarter non-zero values are stored sparse
SPARSE_MIN_SIZE = 4096


def cache_dir() -> Path:
    """``$CATPOSE_CACHE_DIR`` or ``~/.cache/catpose``."""
    env = os.environ.get("CATPOSE_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "catpose"


@functools.cache
def _environment() -> str:
    from importlib import metadata

    versions = []
    for dist in LIBRARIES:
        try:
            versions.append(f"{dist}={metadata.version(dist)}")
        except metadata.PackageNotFoundError:
            continue
    env = [f"{k}={os.environ.get(k)}" for k in NUMERIC_ENV]
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), "")
    except OSError:
        pass
    return "\n".join([*versions, *env, f"cpu={cpu}"])


@functools.cache
def fingerprint(*modules: str) -> str:
    """A hash of the source of ``modules`` (dotted names), the numerical libraries' versions, the
    environment variables that choose their code paths and the CPU model (see the module docstring)."""
    from importlib.util import find_spec

    h = hashlib.blake2b(digest_size=10)
    for name in modules:
        spec = find_spec(name)
        origin = spec.origin if spec is not None else None
        h.update(name.encode())
        if origin and os.path.isfile(origin):
            h.update(Path(origin).read_bytes())
    h.update(_environment().encode())
    return h.hexdigest()


def _path(kind: str, key: str, label: str) -> tuple[Path, str]:
    digest = hashlib.blake2b(key.encode(), digest_size=16).hexdigest()
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", label)[-80:]
    return cache_dir() / kind / (f"{safe}-{digest}.npz" if safe else f"{digest}.npz"), key


def load(kind: str, key: str, label: str = "") -> dict[str, np.ndarray] | None:
    """The arrays of entry ``key`` of ``kind``, or None: absent, unreadable, or not this key's
    (``label``: a readable start of the file name, e.g. the template id)."""
    path, text = _path(kind, key, label)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
        if str(arrays.pop("__key__")) != text:
            return None
        return arrays
    except Exception as e:  # noqa: BLE001 - any unreadable entry is a miss, rebuilt and overwritten
        log.debug("disk cache: %s unreadable (%s: %s); rebuilding it", path, type(e).__name__, e)
        return None


def store(kind: str, key: str, arrays: Mapping[str, np.ndarray], label: str = "") -> bool:
    """Write entry ``key`` of ``kind`` whole or not at all; False when the folder is not writable."""
    from catpose import atomic

    path, text = _path(kind, key, label)
    try:
        with atomic.atomic_path(path) as tmp:
            np.savez(tmp, __key__=np.array(text), **arrays)
        return True
    except OSError as e:
        log.debug("disk cache: cannot write %s (%s)", path, e)
        return False


def cached(
    kind: str,
    key: str,
    build: Callable[[], Any],
    to_arrays: Callable[[Any], Mapping[str, np.ndarray]],
    from_arrays: Callable[[Mapping[str, np.ndarray]], Any],
    label: str = "",
) -> Any:
    """The entry ``key`` of ``kind`` read back with ``from_arrays``, or ``build()`` stored with
    ``to_arrays``; ``from_arrays`` raising (a malformed entry) counts as a miss."""
    arrays = load(kind, key, label)
    if arrays is not None:
        try:
            return from_arrays(arrays)
        except Exception as e:  # noqa: BLE001 - a malformed entry is rebuilt
            log.debug("disk cache: entry of %s malformed (%s); rebuilding it", kind, e)
    value = build()
    store(kind, key, to_arrays(value), label)
    return value


# ---------------------------------------------------------------------------------- structures
def pack(obj: Any) -> dict[str, np.ndarray]:
    """``obj`` (nested tuples, lists, dicts with string keys, numbers, strings, None, arrays,
    dataclasses) as arrays and a JSON outline (``__outline__``)."""
    arrays: dict[str, np.ndarray] = {}

    def walk(x: Any) -> Any:
        if isinstance(x, np.ndarray):
            name = f"a{len(arrays)}"
            order = "F" if x.flags.f_contiguous and not x.flags.c_contiguous else "C"
            if x.size >= SPARSE_MIN_SIZE and np.count_nonzero(x) < x.size // 4:
                flat = x.ravel(order=order)
                where = np.flatnonzero(flat)
                arrays[name + "i"] = where.astype(np.int32 if x.size < np.iinfo(np.int32).max else np.int64)
                arrays[name + "v"] = flat[where]
                return {"sparse": name, "shape": list(x.shape), "dtype": x.dtype.str, "order": order}
            arrays[name] = x
            return {"array": name}
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            cls = type(x)
            fields = {f.name: walk(getattr(x, f.name)) for f in dataclasses.fields(x) if f.init}
            return {"dataclass": f"{cls.__module__}:{cls.__qualname__}", "fields": fields}
        if isinstance(x, (list, tuple)):
            return {"list" if isinstance(x, list) else "tuple": [walk(v) for v in x]}
        if isinstance(x, dict):
            return {"dict": {str(k): walk(v) for k, v in x.items()}}
        if isinstance(x, (np.integer, np.floating, np.bool_)):
            x = x.item()
        if x is None or isinstance(x, (bool, int, float, str)):
            return {"value": x}
        raise TypeError(f"disk cache cannot store a {type(x).__name__}")

    outline = walk(obj)
    arrays["__outline__"] = np.array(json.dumps(outline))
    return arrays


def unpack(arrays: Mapping[str, np.ndarray], types: Mapping[str, type] = {}) -> Any:  # noqa: B006 - read only
    """The structure :func:`pack` stored; dataclasses only of ``types`` (``"module:QualName"`` ->
    class), any other raises ``KeyError``."""

    def walk(o: Any) -> Any:
        if "array" in o:
            return arrays[o["array"]]
        if "sparse" in o:
            name = o["sparse"]
            out = np.zeros(tuple(o["shape"]), dtype=np.dtype(o["dtype"]), order=o["order"])
            flat = out.reshape(-1, order=o["order"])
            if not np.shares_memory(flat, out):
                raise ValueError("sparse entry: not a view")
            flat[arrays[name + "i"]] = arrays[name + "v"]
            return out
        if "dataclass" in o:
            return types[o["dataclass"]](**{k: walk(v) for k, v in o["fields"].items()})
        if "list" in o:
            return [walk(v) for v in o["list"]]
        if "tuple" in o:
            return tuple(walk(v) for v in o["tuple"])
        if "dict" in o:
            return {k: walk(v) for k, v in o["dict"].items()}
        return o["value"]

    return walk(json.loads(str(arrays["__outline__"])))
