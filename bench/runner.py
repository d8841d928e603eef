"""The runner: every sample of a dataset + protocol through one method, into one run directory.

Stages with files between them (run -> estimates and errors -> tables):

- ``samples.jsonl``: one JSON object per finished sample, appended and flushed as soon as it is
  done, so a run killed midway loses nothing already written and a re-run skips finished
  samples (resume). A truncated last line from a kill is ignored and rewritten.
- ``config.yaml`` (the resolved config), ``git_rev.txt``, ``run.json`` (counts and the environment:
  library versions, CPU, BLAS kernels).
- ``samples.csv``, ``summary.csv``, ``summary.md``: made from ``samples.jsonl`` by
  :func:`summarize_run`, never from in-memory state.

A sample whose data fails to load, whose method raises, or whose estimate is not a finite rigid
transform is recorded with ``status="failed"`` and its message; the run goes on. What is not the
sample's own fault aborts the run in one line and records nothing for the sample in progress, so
a re-run redoes it: Ctrl-C (at any moment: the heavy libraries are imported before the first
sample), an import error, ``MemoryError``, an ``OSError`` writing the run directory. A run holds
a lock on its directory (``run.lock``); a second run of the same configuration waits for it.

The run directory is ``<output_root>/<dataset>-<protocol>/<method>/<tag>-<hash>``: ``tag`` spells
the command-line overrides (readable), ``hash`` is a digest of the resolved method, dataset,
protocol and seed (so two different configurations never share a directory).
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import hashlib
import importlib
import inspect
import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Iterable, Iterator

import numpy as np

from catpose.bench.merge import parse_shard, shard_ids, shard_lock_file, shard_samples_file, write_shard_meta
from catpose.errors import CatposeError, ConfigError
from catpose.geometry import stable_seed

SAMPLES_FILE = "samples.jsonl"
LOCK_FILE = "run.lock"
_RUN_KEYS_EXCLUDED_FROM_TAG = {"method", "dataset", "protocol", "seed", "limit", "sample_ids", "output_root",
                               "progress", "threads", "retry_failed", "print_summary", "lock_timeout",
                               # shards of one run share its directory; an experiment's rows name themselves
                               "shard", "shards", "label", "experiment"}


class RunAborted(CatposeError):
    """The run itself cannot go on (not one sample's fault): a broken installation, no memory,
    an unwritable output directory, a run directory held by another run. Nothing is recorded for
    the sample in progress, so a re-run redoes it."""


# ---------------------------------------------------------------------------------------------
# building the pieces from config


def build_from_config(node: Any, what: str) -> tuple[str, Any]:
    """Pop ``name`` from a config group node and build its ``_target_`` with the rest.

    Every user mistake becomes a one-line :class:`ConfigError` naming the key: a missing
    mandatory value, an option the target does not take, a value of the wrong type for a
    constructor argument annotated ``float``/``int``/``bool``/``str`` (see
    :func:`check_constructor_args`), and any other ``TypeError``/``ValueError`` of the constructor.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    from omegaconf.errors import MissingMandatoryValue

    check_missing(node, what)
    try:
        d = OmegaConf.to_container(node, resolve=True) if not isinstance(node, dict) else dict(node)
    except MissingMandatoryValue as e:
        raise ConfigError(f"{what}: a required value is missing ({e}); set it on the command line") from None
    name = str(d.pop("name", what))
    if "_target_" not in d:
        raise ConfigError(f"config group '{what}' ({name}) has no _target_; add one to configs/{what}/{name}.yaml")
    check_constructor_args(d, what, name)
    try:
        return name, instantiate(d, _convert_="all")
    except CatposeError:
        raise
    except Exception as e:  # Hydra wraps constructor errors; surface the user-facing one
        cause = e
        while cause.__cause__ is not None:
            cause = cause.__cause__
        if isinstance(cause, CatposeError):
            raise cause from None
        named = [k for k in d if not k.startswith("_") and re.search(rf"\b{re.escape(k)}\b", str(cause))]
        keys = ", ".join(f"{what}.{k}={d[k]!r}" for k in named) or f"the {what}.* values"
        raise ConfigError(f"cannot build {what} '{name}' ({d['_target_']}): {_one_line(cause)}; "
                          f"check {keys} (bench run --cfg job shows them)") from None


def check_missing(node: Any, what: str) -> None:
    """A one-line :class:`ConfigError` naming the mandatory (``???``) keys of a group left unset."""
    from omegaconf import OmegaConf

    if isinstance(node, dict):
        return
    # missing_keys of a child node gives full paths ("dataset.root"); keep them relative
    missing = sorted(k.removeprefix(f"{what}.") for k in OmegaConf.missing_keys(node))
    if missing:
        raise ConfigError(f"{what} needs {', '.join(f'{what}.{k}' for k in missing)}: "
                          f"set it on the command line, e.g. {what}.{missing[0]}=<value>")


# annotation (as written, `from __future__ import annotations` keeps it a string) -> what it accepts
_SCALAR_HINTS = {"float": "<number>", "int": "<integer>", "bool": "<true|false>", "str": "<text>"}


def _scalar_annotation(annotation: Any) -> set[str] | None:
    """The scalar types an annotation allows (``"float | None"`` -> {"float", "None"}), or None
    when it is anything else (containers, classes, unannotated): those are not checked."""
    if annotation is inspect.Parameter.empty:
        return None
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    text = str(text).replace("typing.", "")
    optional = text.startswith("Optional[")
    if optional:
        text = text.removeprefix("Optional[").removesuffix("]")
    parts = {"None" if p.strip() in ("None", "NoneType") else p.strip() for p in text.split("|")}
    if optional:
        parts.add("None")
    return parts if parts <= {*_SCALAR_HINTS, "None"} and parts - {"None"} else None


def _accepts(kinds: set[str], value: Any) -> bool:
    """Whether ``value`` (as Hydra parsed it) fits one of the scalar ``kinds``."""
    if value is None:
        return "None" in kinds
    if isinstance(value, bool):
        return "bool" in kinds
    if isinstance(value, int):
        return bool(kinds & {"int", "float", "str"}) or ("bool" in kinds and value in (0, 1))
    if isinstance(value, float):
        return "float" in kinds or "str" in kinds or ("int" in kinds and value.is_integer())
    if isinstance(value, str):
        return "str" in kinds
    return False


def check_constructor_args(d: dict, what: str, name: str) -> None:
    """Check a group's options against its ``_target_``'s constructor before building it.

    Raises a one-line :class:`ConfigError` for an option the constructor does not take (unless
    it has ``**kwargs``) and for a value that does not fit a parameter annotated with scalar
    types only (``float``, ``int``, ``bool``, ``str``, optionally ``| None``), e.g.
    ``method.lr='abc' is not a float; set method.lr=<number>``. Anything the check cannot read
    (an unimportable target, container annotations) is left to the constructor.
    """
    try:
        module_name, _, attr = str(d["_target_"]).rpartition(".")
        target = getattr(importlib.import_module(module_name), attr)
        params = inspect.signature(target).parameters
    except (ImportError, AttributeError, ValueError, TypeError):
        return  # Hydra reports an unknown target itself
    takes_kwargs = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    for key, value in d.items():
        if key.startswith("_"):
            continue
        if isinstance(value, dict) and "_target_" in value:  # a nested settings object: its own keys
            check_constructor_args(value, f"{what}.{key}", name)
        if key not in params:
            if not takes_kwargs:
                options = ", ".join(k for k, p in params.items() if p.kind is not inspect.Parameter.VAR_POSITIONAL)
                raise ConfigError(f"{what}.{key} is not an option of {what} '{name}' ({d['_target_']}); "
                                  f"options: {options}")
            continue
        kinds = _scalar_annotation(params[key].annotation)
        if kinds is not None and not _accepts(kinds, value):
            main = next(k for k in ("float", "int", "bool", "str") if k in kinds)
            article = "an" if main == "int" else "a"
            or_null = " or null" if "None" in kinds else ""
            raise ConfigError(f"{what}.{key}={value!r} is not {article} {main}{or_null}; "
                              f"set {what}.{key}={_SCALAR_HINTS[main]}")


def run_dir_for(cfg: Any, overrides: Iterable[str] = ()) -> Path:
    """The output directory of a configuration (see the module docstring)."""
    from omegaconf import OmegaConf

    identity = {k: OmegaConf.to_container(cfg[k], resolve=True) for k in ("method", "dataset", "protocol")}
    identity["seed"] = int(cfg.seed)
    digest = hashlib.sha1(json.dumps(identity, sort_keys=True, default=str).encode()).hexdigest()[:8]
    parts = []
    for o in overrides:
        key = o.split("=", 1)[0].lstrip("+~")
        if key.split(".")[0] in _RUN_KEYS_EXCLUDED_FROM_TAG and "." not in key:
            continue
        if key.startswith("hydra.") or key == "output_root":
            continue
        parts.append(re.sub(r"[^A-Za-z0-9_.=,+-]+", "_", o.replace("/", "_")))
    tag = ",".join(sorted(parts))[:80] or "default"
    name = f"seed{int(cfg.seed)}-{tag}-{digest}"
    return Path(str(cfg.output_root)) / f"{cfg.dataset.name}-{cfg.protocol.name}" / str(cfg.method.name) / name


def _git_revision() -> str:
    here = Path(__file__).resolve().parent
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=10)
        if rev.returncode != 0:
            return "unknown (not a git checkout)"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return rev.stdout.strip() + (" (with uncommitted changes)" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown (git not available)"


# ---------------------------------------------------------------------------------------------
# the per-sample table


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        f = float(x)
        return f if math.isfinite(f) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if isinstance(x, (str, int, bool)) or x is None:
        return x
    return str(x)


def read_samples(path: Path) -> list[dict]:
    """Rows of a ``samples.jsonl``; a truncated last line (a killed run) is skipped."""
    rows = []
    if not path.exists():
        return rows
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue
    return rows


class _SampleWriter:
    """Appends one JSON line per sample and makes it durable before the next sample starts."""

    def __init__(self, path: Path) -> None:
        self.path = path
        if path.exists():  # drop a partial last line left by a kill, keep every complete one
            data = path.read_bytes()
            if data and not data.endswith(b"\n"):
                path.write_bytes(data[: data.rfind(b"\n") + 1])
        self._f = open(path, "a", encoding="utf-8")

    def write(self, row: dict) -> None:
        self._f.write(json.dumps(_jsonable(row), sort_keys=False) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


def seed_everything(seed: int) -> None:
    """Seed Python, NumPy, and (when loaded) torch and Open3D, for one sample."""
    seed32 = seed % (2**32)
    random.seed(seed32)
    np.random.seed(seed32)
    if "torch" in sys.modules:
        sys.modules["torch"].manual_seed(seed32)
    if "open3d" in sys.modules:
        from catpose.o3d import o3d

        o3d.utility.random.seed(seed32 % (2**31))


# raised inside a sample but not its fault: the run aborts (see run()); KeyboardInterrupt and
# other BaseExceptions pass through `except Exception` anyway
_NOT_THE_SAMPLES_FAULT = (ImportError, MemoryError)


def _run_one(method: Any, protocol: Any, dataset: Any, sample_id: str, base: dict, seed: int) -> dict:
    from catpose.bench.metrics import FAILED_ERROR_DEG, sample_errors

    try:
        category = dataset.category_of(sample_id.split("|")[0])
    except Exception:  # an id the dataset cannot parse still gets its failed row below
        category = None
    row = dict(base, sample_id=sample_id, group_id=sample_id, obs_id=sample_id.split("|")[0],
               category=category, instance_id=None, template_id=None,
               status="failed", error="", stage="load", rot_err_deg=None, axis_err_deg=None, trans_err=None,
               err_deg=FAILED_ERROR_DEG, symmetric=None, score=None, runtime_s=None, T_est=None, T_gt=None,
               symmetry_axis=None, symmetries=None, info={}, extras={})
    try:
        sample = protocol.load(dataset, sample_id)
    except _NOT_THE_SAMPLES_FAULT:
        raise
    except Exception as e:  # a bad sample is recorded, the run goes on
        row["error"] = _one_line(e)
        return row
    info = dict(sample.info)
    row.update(group_id=sample.group_id or sample_id, category=sample.problem.category,
               instance_id=info.get("instance_id"), template_id=sample.problem.template.template_id,
               T_gt=np.asarray(sample.gt.T_template_camera, float).reshape(-1), symmetric=sample.gt.symmetry_axis is not None,
               symmetry_axis=sample.gt.symmetry_axis,
               symmetries=[np.asarray(S, float).reshape(-1) for S in sample.gt.symmetries] or None,
               info=info, stage="register")
    seed_everything(stable_seed(seed, sample_id))
    t0 = time.perf_counter()
    try:
        result = method.register(sample.problem)
    except _NOT_THE_SAMPLES_FAULT:
        raise
    except Exception as e:
        row["runtime_s"] = time.perf_counter() - t0
        row["error"] = _one_line(e)
        return row
    runtime = time.perf_counter() - t0
    result = dataclasses.replace(result, runtime_s=runtime)
    T = np.asarray(result.T_target_source, dtype=float)
    row.update(runtime_s=runtime, score=result.score, extras=dict(result.extras))
    if T.shape != (4, 4) or not np.isfinite(T).all():
        row["error"] = f"method returned a non-finite or malformed pose (shape {T.shape})"
        return row
    R = T[:3, :3]
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        row["error"] = "method returned a matrix whose rotation part is not a rotation"
        return row
    row.update(status="ok", stage="", T_est=T.reshape(-1),
               **sample_errors(T, sample.gt.T_template_camera, sample.gt.symmetry_axis, sample.gt.symmetries))
    return row


def _one_line(e: BaseException) -> str:
    msg = " ".join(str(e).split()) or "(no message)"
    if isinstance(e, CatposeError):
        return msg
    tb = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
    return f"{type(e).__name__}: {msg}{where}"


# ---------------------------------------------------------------------------------------------
# what aborts a run (never a sample failure)

# heavy libraries, imported before the first sample so that a Ctrl-C during their import
# (seconds) stops the run instead of turning into an ImportError of every sample. trimesh wraps
# its optional imports (scipy, networkx, PIL, its own submodules) in `except BaseException`, so
# it and what it looks for are imported first, before the builders need them: once loaded, no
# window is left where a Ctrl-C would be swallowed for long. torch and Open3D come after the
# builds, so that a config mistake is reported without waiting for them.
_EARLY_MODULES = ("numpy", "scipy.spatial", "scipy.sparse", "scipy.optimize", "scipy.ndimage", "PIL.Image",
                  "trimesh")
_LATE_MODULES = ("torch", "catpose.o3d")
_OPTIONAL_MODULES = ("networkx",)  # trimesh uses it when present


class _Interrupts:
    """Ctrl-C that no library can swallow or turn into another exception.

    While active (main thread only, and only when SIGINT has Python's default handler), SIGINT
    raises ``KeyboardInterrupt`` as usual and also sets :attr:`seen`; :meth:`check` re-raises it
    after code that may have caught it (trimesh's imports catch ``BaseException``; a C extension
    may report it as an ``ImportError`` or ``RuntimeError``).
    """

    def __init__(self) -> None:
        self.seen = False
        self._previous: Any = None

    def _handler(self, signum: int, frame: Any) -> None:
        self.seen = True
        raise KeyboardInterrupt

    def __enter__(self) -> "_Interrupts":
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` if a Ctrl-C arrived, whatever became of its exception."""
        if self.seen:
            raise KeyboardInterrupt


def import_heavy_libraries(interrupts: _Interrupts | None = None,
                           modules: tuple[str, ...] = _EARLY_MODULES + _LATE_MODULES) -> None:
    """Import ``modules`` now (default: SciPy, trimesh, torch, Open3D; see :data:`_EARLY_MODULES`).

    A missing or broken library raises :class:`RunAborted` in one line; a Ctrl-C during an
    import raises ``KeyboardInterrupt`` even when the library swallowed it.
    """
    if "trimesh" in modules:
        for name in _OPTIONAL_MODULES:
            with contextlib.suppress(ImportError):
                importlib.import_module(name)
            if interrupts is not None:
                interrupts.check()
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception as e:  # noqa: BLE001 - a swallowed Ctrl-C can surface as anything (trimesh: TypeError)
            if interrupts is not None:
                interrupts.check()
            raise RunAborted(f"cannot import {name} ({_one_line(e)}); the installation is broken: "
                             "reinstall with `make install` (or pip install -e .)") from None
        if interrupts is not None:
            interrupts.check()


def _abort_message(e: BaseException, sample_id: str) -> str:
    """One line for an exception that stops the run while ``sample_id`` was in progress."""
    redo = f"sample {sample_id} was not recorded; re-run the same command to resume"
    if isinstance(e, MemoryError):
        return f"out of memory on sample {sample_id}; free memory or lower dataset.max_points, then re-run ({redo})"
    name = getattr(e, "name", None) or "a module"
    return (f"cannot import {name} on sample {sample_id} ({_one_line(e)}); the installation is broken: "
            f"reinstall with `make install`, then re-run ({redo})")


def _output_error(path: Path, e: OSError) -> RunAborted:
    """A one-line error for an ``OSError`` while writing the run directory."""
    if e.errno == errno.ENOSPC:
        why = "the disk is full"
    elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        why = "it is not writable"
    elif e.errno in (errno.ENOTDIR, errno.EEXIST) or isinstance(e, (NotADirectoryError, FileExistsError)):
        why = "a file is in the way of a folder on its path"
    else:
        why = e.strerror or type(e).__name__
    filename = getattr(e, "filename", None)
    where = f" ({filename})" if filename and Path(str(filename)) != path else ""
    return RunAborted(f"cannot write the run directory {path}{where}: {why}; set output_root=<a writable "
                      "folder with free space> (finished samples are kept, a re-run resumes)")


@contextlib.contextmanager
def _writing(path: Path) -> Iterator[None]:
    """Turn an ``OSError`` while writing the run directory ``path`` into :func:`_output_error`."""
    try:
        yield
    except OSError as e:
        raise _output_error(path, e) from None


class _RunLock:
    """An exclusive lock on a run directory (``fcntl.flock`` on ``run.lock``), held while a run
    writes it, so that two runs of one configuration never do the same samples.

    A second run waits for the first (saying which pid holds the lock) and then resumes from
    its samples; with ``timeout`` (seconds) it gives up with :class:`RunAborted` instead.
    The lock file holds the pid of the holder; the kernel drops the lock when the holder exits.
    """

    def __init__(self, run_dir: Path, timeout: float | None = None, poll_s: float = 0.2,
                 name: str = LOCK_FILE) -> None:
        self.path = run_dir / name
        self.timeout = timeout
        self.poll_s = poll_s
        self._fd: int | None = None

    def holder(self) -> str:
        """The pid written by the holder ("unknown" if none yet)."""
        try:
            return self.path.read_text().strip() or "unknown"
        except OSError:
            return "unknown"

    def acquire(self) -> None:
        import fcntl

        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                self._wait(fd)
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd

    def _wait(self, fd: int) -> None:
        import fcntl

        holder = self.holder()
        if self.timeout is not None and self.timeout <= 0:
            raise RunAborted(f"run directory {self.path.parent} is in use by pid {holder}; wait for that run "
                             "to finish or stop it")
        print(f"bench run: waiting for pid {holder}, which is running into {self.path.parent} "
              "(it finishes the same samples; Ctrl-C to stop)", file=sys.stderr, flush=True)
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except BlockingIOError:
                if deadline is not None and time.monotonic() > deadline:
                    raise RunAborted(f"run directory {self.path.parent} is still in use by pid {self.holder()} "
                                     f"after {self.timeout:g} s; wait for that run to finish or stop it, or "
                                     "raise lock_timeout") from None
                time.sleep(self.poll_s)

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the last descriptor drops the flock
            self._fd = None


def _run_option(cfg: Any, key: str, kind: str, minimum: int | float | None = None) -> Any:
    """``cfg[key]`` validated as ``kind`` ("int" or "float", None allowed), at least ``minimum``;
    a one-line :class:`ConfigError` naming the key and the fix otherwise (``limit=-1``,
    ``limit=abc`` and ``seed=1.5`` must not become something else silently)."""
    value = cfg.get(key)
    if value is None:
        return None
    ok = not isinstance(value, bool) and (isinstance(value, int) or (kind == "float" and isinstance(value, float)))
    if not ok or (minimum is not None and value < minimum):
        need = "an integer" if kind == "int" else "a number"
        bound = f" >= {minimum}" if minimum is not None else ""
        raise ConfigError(f"{key}={value!r} is not {need}{bound}; set {key}=<{'integer' if kind == 'int' else 'number'}"
                          f"{bound}> (or drop it)")
    return value


def validate_run_options(cfg: Any) -> None:
    """Check the run-level keys (``seed``, ``limit``, ``threads``, ``lock_timeout``) and that no
    mandatory group key (``dataset.root``) is unset, before any work."""
    if cfg.get("seed") is None:
        raise ConfigError("seed is not set; set seed=<integer>, e.g. seed=0")
    _run_option(cfg, "seed", "int")
    _run_option(cfg, "limit", "int", 1)
    _run_option(cfg, "threads", "int", 1)
    _run_option(cfg, "lock_timeout", "float", 0)
    for group in ("method", "dataset", "protocol"):
        if group in cfg:
            check_missing(cfg[group], group)


# ---------------------------------------------------------------------------------------------
# run and summarise


def run(cfg: Any, overrides: Iterable[str] = ()) -> Path:
    """Run ``cfg.method`` on every sample of ``cfg.dataset`` under ``cfg.protocol``.

    Returns the run directory. Finished samples already in its ``samples.jsonl`` are skipped.
    Only a sample's own fault is recorded as its failure; Ctrl-C, a failed import, no memory
    and an unwritable output directory abort the run (``KeyboardInterrupt`` or
    :class:`RunAborted`) and record nothing for the sample in progress.
    """
    validate_run_options(cfg)
    with _Interrupts() as interrupts:
        try:
            return _run(cfg, list(overrides), interrupts)
        except CatposeError:
            interrupts.check()  # a Ctrl-C that a library turned into a build or load error
            raise


def _run(cfg: Any, overrides: list[str], interrupts: _Interrupts) -> Path:
    """Build the pieces, list the samples, lock the run directory and run (see :func:`run`)."""
    import_heavy_libraries(interrupts, _EARLY_MODULES)
    if cfg.get("threads"):
        import torch

        torch.set_num_threads(int(cfg.threads))
    method_name, method = build_from_config(cfg.method, "method")
    dataset_name, dataset = build_from_config(cfg.dataset, "dataset")
    dataset.name = dataset_name
    _, protocol = build_from_config(cfg.protocol, "protocol")
    interrupts.check()
    # after the builds (so that a config mistake is reported without waiting for torch) and
    # before the first sample (so that a Ctrl-C during an import stops the run)
    import_heavy_libraries(interrupts, _LATE_MODULES)

    ids = protocol.sample_ids(dataset)
    if cfg.get("sample_ids"):
        wanted = list(cfg.sample_ids)
        unknown = sorted(set(wanted) - set(ids))
        if unknown:
            raise ConfigError(f"sample_ids not in {dataset_name}/{cfg.protocol.name}: {unknown[:3]}; "
                              f"valid ids look like {ids[:2]}")
        ids = wanted
    if cfg.get("limit") is not None:
        ids = ids[: int(cfg.limit)]
    sharding = parse_shard(cfg.get("shard"), cfg.get("shards", 1))
    if sharding:  # this job's part of the run: its own files in the run directory (bench/merge.py)
        ids = shard_ids(ids, *sharding)

    out = run_dir_for(cfg, overrides)
    with _writing(out):
        out.mkdir(parents=True, exist_ok=True)
    # a shard locks its own files only, so the shards of one run go on side by side
    lock = _RunLock(out, cfg.get("lock_timeout"), name=shard_lock_file(*sharding) if sharding else LOCK_FILE)
    with _writing(out):
        lock.acquire()
    try:
        return _run_locked(cfg, overrides, interrupts, out, ids, method_name, method, dataset_name, dataset,
                           protocol, sharding)
    finally:
        lock.release()


def _run_locked(cfg: Any, overrides: list[str], interrupts: _Interrupts, out: Path, ids: list[str],
                method_name: str, method: Any, dataset_name: str, dataset: Any, protocol: Any,
                sharding: tuple[int, int] | None = None) -> Path:
    """The part of a run that writes ``out``, under its lock (samples read after locking, so a
    run that waited for another skips what that one finished)."""
    from omegaconf import OmegaConf

    with _writing(out):
        OmegaConf.save(cfg, out / "config.yaml", resolve=True)
        (out / "git_rev.txt").write_text(_git_revision() + "\n")
        (out / "overrides.txt").write_text("\n".join(overrides) + "\n")

    samples_path = out / (shard_samples_file(*sharding) if sharding else SAMPLES_FILE)
    retry = bool(cfg.get("retry_failed", False))
    existing = read_samples(samples_path)
    if sharding:  # samples already in the run's merged (or serial) file are done too
        existing = read_samples(out / SAMPLES_FILE) + existing
        write_shard_meta(out, *sharding, ids, finished=False)
    done = {r["sample_id"] for r in existing if r.get("status") == "ok" or not retry}
    todo = [s for s in ids if s not in done]
    base = {"method": method_name, "dataset": dataset_name, "protocol": str(cfg.protocol.name),
            "seed": int(cfg.seed)}

    with _writing(out):
        writer = _SampleWriter(samples_path)
    from tqdm import tqdm

    bar = tqdm(total=len(ids), initial=len(ids) - len(todo), unit="sample", dynamic_ncols=True,
               desc=f"{method_name} on {dataset_name}", disable=not cfg.get("progress", True), file=sys.stderr)
    try:
        for sample_id in todo:
            try:
                row = _run_one(method, protocol, dataset, sample_id, base, int(cfg.seed))
            except (ImportError, MemoryError) as e:
                interrupts.check()
                raise RunAborted(_abort_message(e, sample_id)) from None
            interrupts.check()  # a Ctrl-C caught inside the sample is not the sample's failure
            with _writing(out):
                writer.write(row)
            bar.update(1)
            if row["status"] != "ok":
                bar.write(f"[failed] {sample_id}: {row['error']}", file=sys.stderr)
    finally:
        bar.close()
        with contextlib.suppress(OSError):
            writer.close()

    if sharding:
        write_shard_meta(out, *sharding, ids, finished=True)
        return _finish_shard(out, sharding, cfg, base, len(ids), len(todo))
    from catpose.bench.environment import environment

    # the versions, CPU and BLAS kernels the numbers came from (see catpose.bench.environment)
    meta = dict(base, n_samples=len(ids), n_run_now=len(todo), output_dir=str(out), environment=environment())
    with _writing(out):
        (out / "run.json").write_text(json.dumps(meta, indent=2) + "\n")
        summary = summarize_run(out, ids)
    if cfg.get("print_summary", True):
        print(f"\n{method_name} on {dataset_name} ({cfg.protocol.name}), seed {int(cfg.seed)}: {out}")
        print(format_summary(summary))
    return out


def _finish_shard(out: Path, sharding: tuple[int, int], cfg: Any, base: dict, n_ids: int, n_run_now: int) -> Path:
    """After a shard: merge the run when every shard is done (the last shard to finish does it)."""
    from catpose.bench.merge import merge_run

    i, n = sharding
    head = f"\n{base['method']} on {base['dataset']} ({base['protocol']}), seed {base['seed']}, shard {i} of {n}"
    try:
        summary = merge_run(out)
    except CatposeError as e:  # other shards still running: the last one (or bench merge) merges
        if cfg.get("print_summary", True):
            print(f"{head}: {n_ids} samples ({n_run_now} run now) in {out}; the last shard to finish merges (or: bench merge {out})")
        return out
    if cfg.get("print_summary", True):
        print(f"{head}: all {n} shards done, merged into {out}")
        print(format_summary(summary))
    return out


def load_protocol(run_dir: Path) -> Any:
    """Rebuild the protocol of a run from its ``config.yaml`` (for scoring from files)."""
    from omegaconf import OmegaConf

    cfg = OmegaConf.load(run_dir / "config.yaml")
    return build_from_config(cfg.protocol, "protocol")[1]


def recompute_errors(row: dict) -> dict:
    """A per-sample row with its errors recomputed from ``T_est``, ``T_gt``, ``symmetry_axis``
    and ``symmetries`` (the current metric definitions); a row without an estimate gets
    :data:`~catpose.bench.metrics.FAILED_ERROR_DEG`. Every table is scored through this."""
    from catpose.bench.metrics import FAILED_ERROR_DEG, sample_errors

    row = dict(row)
    T_est, T_gt = row.get("T_est"), row.get("T_gt")
    if row.get("status") == "ok" and isinstance(T_est, (list, np.ndarray)) and isinstance(T_gt, (list, np.ndarray)):
        axis = row.get("symmetry_axis")
        symmetries = row.get("symmetries")
        row.update(sample_errors(np.reshape(T_est, (4, 4)), np.reshape(T_gt, (4, 4)),
                                 np.asarray(axis, float) if isinstance(axis, (list, np.ndarray)) else None,
                                 symmetries if isinstance(symmetries, (list, tuple)) else ()))
    else:
        row["err_deg"] = FAILED_ERROR_DEG
    return row


def latest_rows(path: Path) -> list[dict]:
    """The rows of a ``samples.jsonl``, one per sample (a retried sample: its last row)."""
    latest: dict[str, dict] = {}
    for r in read_samples(path):
        latest.pop(r["sample_id"], None)
        latest[r["sample_id"]] = r
    return list(latest.values())


def summarize_run(run_dir: Path, sample_ids: Iterable[str] | None = None):
    """Per-category summary of a run from its files.

    Writes ``samples.csv`` and ``summary.csv``/``.md`` over every finished sample of the
    directory, so they always agree with ``samples.jsonl``. Returns that summary, or, when
    ``sample_ids`` is given (a ``limit``-ed run of a larger directory), the summary of those
    samples only (not written). Errors are recomputed from the stored estimates and ground
    truth, so the statistics never depend on in-memory state.
    """
    import pandas as pd

    run_dir = Path(run_dir)
    df = pd.DataFrame([recompute_errors(r) for r in latest_rows(run_dir / SAMPLES_FILE)])
    protocol = load_protocol(run_dir)
    if len(df):
        flat = df.drop(columns=[c for c in ("info", "extras", "symmetries") if c in df.columns]).copy()
        for c in ("T_est", "T_gt", "symmetry_axis"):
            if c in flat.columns:
                flat[c] = flat[c].map(lambda v: " ".join(f"{x:.9g}" for x in np.ravel(v)) if isinstance(v, list) else "")
        flat.to_csv(run_dir / "samples.csv", index=False)
    summary = _summary(df, protocol)
    summary.to_csv(run_dir / "summary.csv", index=False)
    (run_dir / "summary.md").write_text(format_summary(summary) + "\n")
    if sample_ids is None or len(df) == 0:
        return summary
    wanted = set(sample_ids)
    return _summary(df[df["sample_id"].isin(wanted)].reset_index(drop=True), protocol)


def _summary(df, protocol):
    """Per-category statistics of per-sample rows scored by ``protocol``, oracle columns added
    for protocols that report one."""
    import pandas as pd

    from catpose.bench.metrics import summarize

    units = protocol.score_units(df) if len(df) else df
    if len(units) == 0:
        return summarize(pd.DataFrame(columns=["category", "status", "err_deg", "trans_err", "runtime_s"]))
    summary = summarize(units)
    if "oracle_err_deg" in units.columns:
        oracle = summarize(units.assign(err_deg=units["oracle_err_deg"], status="ok"))
        summary["oracle_mean_err_deg"] = oracle["mean_err_deg"].to_numpy()
        summary["oracle_median_err_deg"] = oracle["median_err_deg"].to_numpy()
    return summary


def format_summary(summary) -> str:
    """The summary as a Markdown table (angles in degrees, translation in object-normalised units)."""
    if len(summary) == 0:
        return "(no scored samples: none finished, or none has the ground truth this protocol scores)"
    return summary.to_markdown(index=False, floatfmt=".3f")
