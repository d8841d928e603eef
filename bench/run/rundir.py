"""The run directory: its name, its files, the per-sample row, and the lock that keeps two runs
of one configuration apart.

A run directory is ``<output_root>/<dataset>-<protocol>/<method>/seed<S>-<tag>-<hash>``: ``tag``
spells the command-line overrides (readable), ``hash`` is a digest of the resolved method,
dataset, protocol and seed (so two configurations never share a directory). It holds

- ``samples.jsonl``: one :class:`SampleRow` per finished sample, appended and fsynced as soon as
  it is done (a truncated last line from a kill is dropped on resume);
- ``config.yaml`` (resolved), ``overrides.txt``, ``git_rev.txt``, ``run.json`` (counts and the
  environment, :mod:`catpose.bench.run.environment`), ``run.lock``;
- ``samples.csv``, ``summary.csv`` / ``.md``, written by :mod:`catpose.bench.run.evaluate` from the
  files alone.

Every per-sample row in catpose is made here (:class:`SampleRow` and :func:`failed_row` /
:func:`scored_row`): the runner, external predictions and the relative protocol all write the
same schema.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator

import numpy as np

from catpose.bench.scoring.metrics import FAILED_ERROR_DEG
from catpose.errors import RunAborted


@dataclass
class SampleRow:
    """One line of ``samples.jsonl``: which problem, what the method answered, and its errors.

    Frames and units: ``T_est`` and ``T_gt`` are ``T_template_camera`` (16 floats, row-major),
    translations in the dataset's unit (object-normalised for the built-in sets); errors in
    degrees (``rot_err_deg``, ``axis_err_deg``, ``err_deg`` the one the statistics use) and in that
    unit (``trans_err``); ``runtime_s`` in seconds. ``status`` is ``ok`` or ``failed`` (then
    ``error`` says why, ``stage`` where, and ``err_deg`` is 180).
    """

    method: str
    dataset: str
    protocol: str
    seed: int
    sample_id: str
    group_id: str = ""
    obs_id: str = ""
    category: str | None = None
    instance_id: str | None = None
    template_id: str | None = None
    status: str = "failed"
    error: str = ""
    stage: str = "load"
    rot_err_deg: float | None = None
    axis_err_deg: float | None = None
    trans_err: float | None = None
    err_deg: float = FAILED_ERROR_DEG
    symmetric: bool | None = None
    score: float | None = None
    runtime_s: float | None = None
    T_est: Any = None
    T_gt: Any = None
    symmetry_axis: Any = None
    symmetries: Any = None
    info: dict = field(default_factory=dict)
    extras: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The row as written to ``samples.jsonl``."""
        return dataclasses.asdict(self)


def new_row(base: dict, sample_id: str, **fields: Any) -> dict:
    """A fresh row (status failed at stage load until told otherwise) for ``sample_id``;
    ``base`` holds method, dataset, protocol and seed."""
    row = SampleRow(method=str(base["method"]), dataset=str(base["dataset"]), protocol=str(base["protocol"]),
                    seed=int(base["seed"]), sample_id=sample_id, group_id=sample_id,
                    obs_id=sample_id.split("|")[0]).as_dict()
    row.update(fields)
    return row


def failed_row(row: dict, error: str, stage: str | None = None, **fields: Any) -> dict:
    """``row`` marked failed with ``error`` (one line): no estimate, counted as 180 degrees."""
    out = dict(row, status="failed", error=error, T_est=None, err_deg=FAILED_ERROR_DEG, rot_err_deg=None,
               axis_err_deg=None, trans_err=None)
    if stage is not None:
        out["stage"] = stage
    out.update(fields)
    return out


def scored_row(row: dict, T_est: np.ndarray, errors: dict, **fields: Any) -> dict:
    """``row`` with the estimate ``T_est`` (4, 4) and its ``errors`` (see
    :func:`catpose.bench.scoring.metrics.sample_errors`)."""
    out = dict(row, status="ok", error="", stage="", T_est=np.asarray(T_est, float).reshape(-1).tolist())
    out.update(errors)
    out.update(fields)
    return out


SAMPLES_FILE = "samples.jsonl"


LOCK_FILE = "run.lock"


_RUN_KEYS_EXCLUDED_FROM_TAG = {"method", "dataset", "protocol", "seed", "limit", "sample_ids", "output_root",
                               "progress", "threads", "batch", "retry_failed", "print_summary", "lock_timeout",
                               # shards of one run share its directory; an experiment's rows name themselves
                               "shard", "shards", "label", "experiment"}


def run_dir_for(cfg: Any, overrides: Iterable[str] = ()) -> Path:
    """The output directory of a configuration (see the module docstring)."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import target_before_move

    identity = {k: OmegaConf.to_container(cfg[k], resolve=True) for k in ("method", "dataset", "protocol")}
    for node in identity.values():  # a class that moved keeps its configurations' directories
        if isinstance(node, dict) and "_target_" in node:
            node["_target_"] = target_before_move(str(node["_target_"]))
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


def git_revision() -> str:
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


def jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
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


class SampleWriter:
    """Appends one JSON line per sample and makes it durable before the next sample starts."""

    def __init__(self, path: Path) -> None:
        self.path = path
        if path.exists():  # drop a partial last line left by a kill, keep every complete one
            data = path.read_bytes()
            if data and not data.endswith(b"\n"):
                path.write_bytes(data[: data.rfind(b"\n") + 1])
        self._f = open(path, "a", encoding="utf-8")

    def write(self, row: dict) -> None:
        self._f.write(json.dumps(jsonable(row), sort_keys=False) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


def output_error(path: Path, e: OSError) -> RunAborted:
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
def writing(path: Path) -> Iterator[None]:
    """Turn an ``OSError`` while writing the run directory ``path`` into :func:`output_error`."""
    try:
        yield
    except OSError as e:
        raise output_error(path, e) from None


class RunLock:
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


def latest_rows(path: Path) -> list[dict]:
    """The rows of a ``samples.jsonl``, one per sample (a retried sample: its last row)."""
    latest: dict[str, dict] = {}
    for r in read_samples(path):
        latest.pop(r["sample_id"], None)
        latest[r["sample_id"]] = r
    return list(latest.values())


def write_run_files(out: Path, cfg: Any, overrides: Iterable[str]) -> None:
    """``config.yaml`` (resolved), ``git_rev.txt`` and ``overrides.txt`` of a run."""
    from omegaconf import OmegaConf

    with writing(out):
        OmegaConf.save(cfg, out / "config.yaml", resolve=True)
        (out / "git_rev.txt").write_text(git_revision() + "\n")
        (out / "overrides.txt").write_text("\n".join(overrides) + "\n")


def write_run_json(out: Path, meta: dict) -> None:
    """``run.json``: ``meta`` (counts) and the environment the numbers came from (library
    versions, CPU, BLAS kernels; :func:`catpose.bench.run.environment.environment`)."""
    from catpose.bench.run.environment import environment

    with writing(out):
        (out / "run.json").write_text(json.dumps(dict(meta, environment=environment()), indent=2) + "\n")
