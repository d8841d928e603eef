"""The run directory: its name and its files.

``<output_root>/<dataset>-<protocol>/<method>/seed<S>-<tag>-<hash>``: ``tag`` spells the
command-line overrides, ``hash`` digests the resolved method, dataset, protocol, the template choice
(protocols that keep one), seed and the subset of samples when one is taken (``limit``,
``sample_ids``), so two configurations never share a directory. It holds ``samples.jsonl`` (one
:class:`~catpose.bench.scoring.rows.SampleRow` per finished sample, appended and fsynced),
``config.yaml`` (resolved), ``overrides.txt``, ``git_rev.txt``, ``run.json`` (counts, environment),
``run.lock``, and ``samples.csv`` and ``summary.{csv,md}`` written by
:mod:`catpose.bench.run.evaluate` from the files alone. Two runs of one configuration are kept apart
by an exclusive ``fcntl.flock`` on ``run.lock`` (:class:`RunLock`). :func:`write_run_into` writes a
whole run directory from rows made elsewhere (``bench score``)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import math
import os
import re
import subprocess
import time
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from catpose.bench.run.rows_file import parse_rows as read_rows  # every row, nothing skipped in silence
from catpose.bench.run.rows_file import repair_last_line
from catpose.errors import RunAborted

SAMPLES_FILE = "samples.jsonl"
LOCK_FILE = "run.lock"

log = logging.getLogger(__name__)


#: run-level keys that take a subset of the samples (the run's directory name and hash spell them)
SUBSET_KEYS = ("limit", "sample_ids")

#: run-level keys that do not change what a run directory holds (its name and the report's labels
#: leave them out; the subset keys do change it)
RUN_LEVEL_KEYS = (
    "output_root",
    "progress",
    "print_summary",
    "threads",
    "batch",
    "retry_failed",
    "lock_timeout",
    "log_level",
)
# an experiment's rows name themselves (label, experiment)
_RUN_KEYS_EXCLUDED_FROM_TAG = {"method", "dataset", "protocol", "seed", *RUN_LEVEL_KEYS, "label", "experiment"}


def run_dir_for(cfg: Any, overrides: Iterable[str] = ()) -> Path:
    """The output directory of a configuration (see the module docstring)."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import takes_choice

    identity = {k: OmegaConf.to_container(cfg[k], resolve=True) for k in ("method", "dataset", "protocol")}
    if cfg.get("choice") is not None and takes_choice(identity["protocol"]):  # the protocols that keep a choice
        identity["choice"] = OmegaConf.to_container(cfg.choice, resolve=True)
    identity["seed"] = int(cfg.seed)
    subset = {k: OmegaConf.to_object(OmegaConf.create({k: cfg.get(k)}))[k] for k in SUBSET_KEYS if cfg.get(k)}
    if subset:  # a subset of the samples is another sample set: its own directory (a full run's hash is unchanged)
        identity["subset"] = subset
    digest = hashlib.sha1(json.dumps(identity, sort_keys=True, default=str).encode()).hexdigest()[:8]
    parts = []
    for o in overrides:
        key = o.split("=", 1)[0].lstrip("+~")
        if key.split(".")[0] in _RUN_KEYS_EXCLUDED_FROM_TAG and "." not in key:
            continue
        if key.startswith("hydra.") or key == "output_root":
            continue
        if key in SUBSET_KEYS and o.split("=", 1)[-1] in ("null", ""):  # no subset: the full run's name
            continue
        parts.append(re.sub(r"[^A-Za-z0-9_.=,+-]+", "_", o.replace("/", "_")))
    tag = ",".join(sorted(parts))[:80] or "default"
    name = f"seed{int(cfg.seed)}-{tag}-{digest}"
    return Path(str(cfg.output_root)) / f"{cfg.dataset.name}-{cfg.protocol.name}" / str(cfg.method.name) / name


def git_revision() -> str:
    here = Path(__file__).resolve().parent

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", *args], cwd=here, capture_output=True, text=True, timeout=10)

    try:
        rev = git("rev-parse", "HEAD")
        if rev.returncode != 0:
            return "unknown (not a git checkout)"
        dirty = git("status", "--porcelain", "--untracked-files=no").stdout.strip()
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


class SampleWriter:
    """Appends one JSON line per sample and makes it durable before the next sample starts."""

    def __init__(self, path: Path) -> None:
        self.path = path
        if path.exists():  # drop a partial last line left by a kill, keep every complete one
            repair_last_line(path)
        self._f = open(path, "a", encoding="utf-8")

    def write(self, row: dict) -> None:
        self._f.write(json.dumps(jsonable(row), sort_keys=False) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


@contextlib.contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an ``OSError`` while writing the run directory ``path`` into one :class:`RunAborted` line."""
    from catpose.bench.run.overwrite import oserror_reason

    try:
        yield
    except OSError as e:
        filename = getattr(e, "filename", None)
        where = f" ({filename})" if filename and Path(str(filename)) != path else ""
        raise RunAborted(
            f"cannot write the run directory {path}{where}: {oserror_reason(e)}; set output_root=<a writable "
            "folder with free space> (finished samples are kept, a re-run resumes)"
        ) from None


def in_use(run_dir: Path) -> str | None:
    """The pid holding the lock of ``run_dir``, None when no run writes it."""
    import fcntl

    path = Path(run_dir) / LOCK_FILE
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return path.read_text().strip() or "unknown"
    finally:
        os.close(fd)
    return None


class RunLock:
    """An exclusive lock on a run directory (``fcntl.flock`` on ``run.lock``), held while a run
    writes it, so that two runs of one configuration never do the same samples.

    A second run waits for the first (saying which pid holds the lock) and then resumes from
    its samples; with ``timeout`` (seconds) it gives up with :class:`RunAborted` instead.
    The lock file holds the pid of the holder; the kernel drops the lock when the holder exits.
    """

    def __init__(self, run_dir: Path, timeout: float | None = None, poll_s: float = 0.2) -> None:
        self.path = run_dir / LOCK_FILE
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
        deadline = None
        try:
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if deadline is None:  # the first try: say who holds it, once
                        deadline = time.monotonic() + (math.inf if self.timeout is None else self.timeout)
                        if deadline > time.monotonic():
                            log.warning(
                                "waiting for pid %s, which is running into %s (it finishes the same samples; "
                                "Ctrl-C to stop)",
                                self.holder(),
                                self.path.parent,
                            )
                    if time.monotonic() >= deadline:
                        raise RunAborted(
                            f"run directory {self.path.parent} is in use by pid {self.holder()} (waited "
                            f"{self.timeout:g} s); wait for that run to finish or stop it, or raise lock_timeout"
                        ) from None
                    time.sleep(self.poll_s)
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the last descriptor drops the flock
            self._fd = None


def latest_rows(path: Path) -> list[dict]:
    """The rows of a ``samples.jsonl``, one per sample (a retried sample: its last row)."""
    latest: dict[str, dict] = {}
    for r in read_rows(path):
        latest.pop(r["sample_id"], None)
        latest[r["sample_id"]] = r
    return list(latest.values())


def write_run_files(out: Path, cfg: Any, overrides: Iterable[str]) -> None:
    """``config.yaml`` (resolved), ``git_rev.txt`` and ``overrides.txt`` of a run (each atomically,
    :mod:`catpose.atomic`)."""
    from omegaconf import OmegaConf

    from catpose import atomic

    with writing(out):
        atomic.write_text(out / "config.yaml", OmegaConf.to_yaml(cfg, resolve=True))
        atomic.write_text(out / "git_rev.txt", git_revision() + "\n")
        atomic.write_text(out / "overrides.txt", "\n".join(overrides) + "\n")


def write_run_json(out: Path, meta: dict) -> None:
    """``run.json``: ``meta`` (counts) and the environment the numbers came from (library
    versions, CPU, BLAS kernels; :func:`catpose.bench.run.environment.environment`)."""
    from catpose import atomic
    from catpose.bench.run.environment import environment

    with writing(out):
        atomic.write_text(out / "run.json", json.dumps(dict(meta, environment=environment()), indent=2) + "\n")


def write_run_into(out: Path, rows: Sequence[dict], config: dict, info: dict | None = None) -> None:
    """A run directory's files (``samples.jsonl``, ``config.yaml``, ``run.json``, summaries) from
    ``rows`` (the ``samples.jsonl`` schema) and ``config`` (a plain dict with ``method``, ``dataset``,
    ``protocol`` nodes and ``seed``) into the existing, empty folder ``out``."""
    from omegaconf import OmegaConf

    from catpose import atomic
    from catpose.bench.run.evaluate import summarize_run

    with atomic.atomic_write(out / SAMPLES_FILE) as f:
        for r in rows:
            f.write(json.dumps(jsonable(r), sort_keys=False) + "\n")
    atomic.write_text(out / "config.yaml", OmegaConf.to_yaml(OmegaConf.create(config)))
    meta = {
        "method": _name(config.get("method")),
        "dataset": _name(config.get("dataset")),
        "protocol": _name(config.get("protocol")),
        "seed": config.get("seed"),
        "n_samples": len(rows),
    }
    atomic.write_text(out / "run.json", json.dumps(dict(meta, **(info or {})), indent=2) + "\n")
    atomic.write_text(out / "git_rev.txt", "external predictions\n")
    if rows:
        summarize_run(out)


def _name(node: Any) -> str:
    return str(node.get("name")) if isinstance(node, dict) else str(node)
