"""The runner: every sample of a dataset + protocol through one method, into one run directory
(:mod:`catpose.bench.run.rundir`: rows appended and fsynced as they finish, so a re-run skips
finished samples). What is a sample's own fault is its row's failure; what is not (Ctrl-C, an
import error, no memory, an unwritable run directory) aborts the run in one line (:func:`run`)."""

from __future__ import annotations

import contextlib
import importlib
import logging
import signal
import sys
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from catpose import extras, kernel_threads
from catpose.bench.run.build import build_choice, build_parts, validate_run_options
from catpose.bench.run.evaluate import format_summary, summarize_run
from catpose.bench.run.rundir import (
    SAMPLES_FILE,
    RunLock,
    SampleWriter,
    latest_rows,
    read_rows,
    run_dir_for,
    write_run_files,
    write_run_json,
    writing,
)
from catpose.bench.run.sample_run import facts_hook, run_batch, run_one
from catpose.errors import CatposeError, ConfigError, RunAborted
from catpose.errors import one_line as _one_line

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------------------------
# what aborts a run (never a sample failure)

# heavy libraries, imported before the first sample so that a Ctrl-C during their import
# (seconds) stops the run instead of turning into an ImportError of every sample. trimesh wraps
# its optional imports (scipy, networkx, PIL, its own submodules) in `except BaseException`, so
# it and what it looks for are imported first, before the builders need them: once loaded, no
# window is left where a Ctrl-C would be swallowed for long. torch and Open3D come after the
# builds, so that a config mistake is reported without waiting for them.
_EARLY_MODULES = ("numpy", "scipy.spatial", "scipy.sparse", "scipy.optimize", "scipy.ndimage", "PIL.Image", "trimesh")
_LATE_MODULES = ("torch", "catpose.o3d")
_OPTIONAL_MODULES = ("networkx",)  # trimesh uses it when present
_IF_INSTALLED = ("torch",)  # the torch extra: imported early where it is installed


class _Interrupts:
    """Ctrl-C (and SIGTERM) that no library can swallow or turn into another exception.

    While active (main thread only, and only when SIGINT has Python's default handler), SIGINT
    raises ``KeyboardInterrupt`` as usual and also sets :attr:`seen`; :meth:`check` re-raises it
    after code that may have caught it (trimesh's imports catch ``BaseException``; a C extension
    may report it as an ``ImportError`` or ``RuntimeError``).
    """

    def __init__(self) -> None:
        self.seen = False
        self._previous: Any = None
        self._term: Any = None

    def _handler(self, signum: int, frame: Any) -> None:
        self.seen = True
        raise KeyboardInterrupt

    def __enter__(self) -> _Interrupts:
        if threading.current_thread() is threading.main_thread():
            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                self._previous = signal.signal(signal.SIGINT, self._handler)
            if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:  # a kill is said too, not a silent 143
                self._term = signal.signal(signal.SIGTERM, self._handler)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
        if self._term is not None:
            signal.signal(signal.SIGTERM, self._term)

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` if a Ctrl-C arrived, whatever became of its exception."""
        if self.seen:
            raise KeyboardInterrupt


def import_heavy_libraries(
    interrupts: _Interrupts | None = None, modules: tuple[str, ...] = _EARLY_MODULES + _LATE_MODULES
) -> None:
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
        if name in _IF_INSTALLED and not extras.installed(name):
            continue  # an extra (catpose.extras): a configuration that needs it says so when it does
        try:
            importlib.import_module(name)
        except Exception as e:  # noqa: BLE001 - a swallowed Ctrl-C can surface as anything (trimesh: TypeError)
            if interrupts is not None:
                interrupts.check()
            raise RunAborted(
                f"cannot import {name} ({_one_line(e)}); the installation is broken: "
                "reinstall with `make setup` (or pip install -e .)"
            ) from None
        if interrupts is not None:
            interrupts.check()


class _Progress:
    """The progress bar, with no time left shown until the first :data:`WARMUP_SAMPLES` of this
    command are done: their time holds one-time setup (compiling the kernels, building a
    template's dictionary; ours' first sample ~25 s against ~0.1 s after), and tqdm's estimate
    from them said 20 minutes for a run of two. Then a fresh bar times the rest."""

    #: samples of a command whose time is not extrapolated
    WARMUP_SAMPLES = 1
    NO_ETA = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}, first sample: one-time setup, no estimate yet]"

    def __init__(self, total: int, done: int, desc: str, enabled: bool) -> None:
        self._args = {"total": total, "unit": "sample", "dynamic_ncols": True, "desc": desc, "file": sys.stderr}
        self._enabled = bool(enabled)
        self._run = 0
        self._bar = self._new(done, self.NO_ETA)

    def _new(self, done: int, bar_format: str | None):
        from tqdm import tqdm

        return tqdm(initial=done, bar_format=bar_format, disable=not self._enabled, **self._args)

    def update(self, n: int = 1) -> None:
        self._bar.update(n)
        self._run += n
        if self._run == self.WARMUP_SAMPLES and self._bar.n < self._args["total"]:
            self._bar.leave = False  # replaced in place by a bar that times the rest
            self._bar.close()
            self._bar = self._new(self._bar.n, None)

    @property
    def bar_format(self) -> str | None:
        return self._bar.bar_format

    def close(self) -> None:
        self._bar.close()


def _short(value: Any) -> str:
    """A number in a log line (3 decimals), or ``-``."""
    return "-" if value is None else f"{float(value):.3f}"


def _abort_message(e: BaseException, sample_id: str) -> str:
    """One line for an exception that stops the run while ``sample_id`` was in progress."""
    redo = f"sample {sample_id} was not recorded; re-run the same command to resume"
    missing = extras.missing_extra(e)
    if missing is not None:
        return f"{missing}; nothing was recorded for sample {sample_id}: install it, then re-run the same command"
    if isinstance(e, MemoryError):
        return f"out of memory on sample {sample_id}; free memory or lower dataset.max_points, then re-run ({redo})"
    name = getattr(e, "name", None) or "a module"
    return (
        f"cannot import {name} on sample {sample_id} ({_one_line(e)}); the installation is broken: "
        f"reinstall with `make setup` (or pip install -e .), then re-run ({redo})"
    )


# ---------------------------------------------------------------------------------------------
# run and summarize


def run(cfg: Any, overrides: Iterable[str] = ()) -> Path:
    """Run ``cfg.method`` on every sample of ``cfg.dataset`` under ``cfg.protocol``.

    Returns the run directory, named from the parameters (:func:`run_dir_for`). Finished samples
    already in its ``samples.jsonl`` are skipped.
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
    """Build the pieces, list the samples, lock the run directory and run (see :func:`run`). The
    finished samples are read after locking, so a run that waited for another skips what that one
    finished."""
    import_heavy_libraries(interrupts, _EARLY_MODULES)
    kernel_threads.set_threads(cfg.get("threads"))
    method_name, method, dataset, protocol = build_parts(cfg)
    facts = facts_hook(protocol, build_choice(cfg))  # a templates run's choice facts after each registration
    interrupts.check()
    # after the builds (so that a config mistake is reported without waiting for torch) and
    # before the first sample (so that a Ctrl-C during an import stops the run)
    import_heavy_libraries(interrupts, _LATE_MODULES)

    ids = protocol.sample_ids(dataset)
    if cfg.get("sample_ids"):
        unknown = sorted(set(cfg.sample_ids) - set(ids))
        if unknown:
            raise ConfigError(
                f"sample_ids not in {dataset.name}/{cfg.protocol.name}: {unknown[:3]}; valid ids look like {ids[:2]}"
            )
        ids = list(cfg.sample_ids)
    if cfg.get("limit") is not None:
        ids = ids[: int(cfg.limit)]

    out = run_dir_for(cfg, overrides)
    samples_path = out / SAMPLES_FILE
    lock = RunLock(out, cfg.get("lock_timeout"))
    with writing(out):
        out.mkdir(parents=True, exist_ok=True)
        lock.acquire()
    try:
        write_run_files(out, cfg, overrides)
        retry = bool(cfg.get("retry_failed", False))
        done = {r["sample_id"] for r in read_rows(samples_path) if r.get("status") == "ok" or not retry}
        todo = [s for s in ids if s not in done]
        base = {
            "method": method_name,
            "dataset": dataset.name,
            "protocol": str(cfg.protocol.name),
            "seed": int(cfg.seed),
        }
        base["threads"] = kernel_threads.threads()  # what threads=auto came to here: the runtimes' context
        with writing(out):
            writer = SampleWriter(samples_path)
            # until the last sample is done the run says it is running (bench table: incomplete)
            write_run_json(out, dict(base, n_samples=len(ids), state="running", output_dir=str(out)))
        log.debug("%s: %d samples, %d done before, %d to run", out, len(ids), len(ids) - len(todo), len(todo))
        bar = _Progress(len(ids), len(ids) - len(todo), f"{method_name} on {dataset.name}", cfg.get("progress", True))
        batch = int(cfg.get("batch") or 1)
        try:
            for start in range(0, len(todo), batch):
                chunk = todo[start : start + batch]
                try:
                    if batch == 1:
                        rows = [run_one(method, protocol, dataset, chunk[0], base, int(cfg.seed), facts)]
                    else:
                        rows = run_batch(method, protocol, dataset, chunk, base, int(cfg.seed), facts)
                except (ImportError, MemoryError) as e:
                    interrupts.check()
                    raise RunAborted(_abort_message(e, ", ".join(chunk))) from None
                interrupts.check()  # a Ctrl-C caught inside the sample is not the sample's failure
                for row in rows:
                    with writing(out):
                        writer.write(row)
                    bar.update(1)
                    if row["status"] != "ok":
                        log.warning("sample %s failed: %s", row["sample_id"], row["error"])
                    else:
                        log.debug(
                            "sample %s: ok, error %s deg, %s s",
                            row["sample_id"],
                            _short(row.get("err_deg")),
                            _short(row.get("runtime_s")),
                        )
        finally:
            bar.close()
            with contextlib.suppress(OSError):
                writer.close()

        held = len(latest_rows(samples_path))
        meta = dict(base, n_samples=len(ids), n_run_now=len(todo), n_in_directory=held, state="finished")
        write_run_json(out, dict(meta, output_dir=str(out)))
        with writing(out):
            summary = summarize_run(out)  # the directory's, as summary.md and bench table have it
    finally:
        lock.release()
    if cfg.get("print_summary", True):
        print(f"\n{method_name} on {dataset.name} ({cfg.protocol.name}), seed {int(cfg.seed)}: {out}")
        if held != len(ids):
            print(
                f"this command's {len(ids)} samples ({len(todo)} run now) are {len(ids)} of the {held} the run "
                f"directory holds; the summary (summary.md, bench table) is of all {held}:"
            )
        print(format_summary(summary))
    return out
