"""The lock that keeps two runs of one configuration apart: an exclusive ``fcntl.flock`` on the
run directory's ``run.lock``."""

from __future__ import annotations

import logging
import math
import os
import time
from pathlib import Path

from catpose.errors import RunAborted

LOCK_FILE = "run.lock"

log = logging.getLogger(__name__)


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
