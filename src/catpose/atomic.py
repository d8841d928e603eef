"""Files written whole or not at all.

Every file catpose writes goes through this module: written to a temporary file in the
destination's folder, flushed, and moved over the destination with ``os.replace`` (atomic on one
file system), so readers see the old version or the new one, never a truncated file; the temporary
file goes on an exception. (``samples.jsonl`` is appended a line at a time instead, fsynced per
line.) A whole folder is built beside its destination and moved into place (:func:`building_dir`).
Inside :func:`claiming`, a destination that did not exist is claimed, never replaced: if another
process took the name meanwhile, :class:`Claimed` is raised and its output is kept.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import glob
import os
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import IO

_NEW: contextvars.ContextVar[frozenset[Path]] = contextvars.ContextVar("catpose_new_outputs", default=frozenset())


class Claimed(FileExistsError):
    """A destination claimed as new (:func:`claiming`) was taken by another process meanwhile."""


@contextlib.contextmanager
def claiming(*paths: str | Path) -> Iterator[None]:
    """Within the block, the final move onto any of ``paths`` claims it: it fails with
    :class:`Claimed` instead of replacing what another process wrote there meanwhile."""
    token = _NEW.set(_NEW.get() | {Path(os.path.realpath(p)) for p in paths})
    try:
        yield
    finally:
        _NEW.reset(token)


def _claimed(path: Path) -> bool:
    return Path(os.path.realpath(path)) in _NEW.get()


def _temp_name(path: Path) -> Path:
    """A hidden temporary name beside ``path`` that keeps its suffix (libraries that pick a format
    from the suffix, such as matplotlib and ``numpy.savez``, write the right one)."""
    return path.with_name(f".{path.stem}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp{path.suffix}")


def fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (best effort: some file systems refuse it)."""
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | Path, mkdir: bool = True) -> Iterator[Path]:
    """A temporary path beside ``path`` for a library that writes to a path itself
    (``fig.savefig(tmp)``, ``np.savez_compressed(tmp, ...)``, ``OmegaConf.save(cfg, tmp)``); on a
    clean exit it replaces ``path``, on an exception it is removed and ``path`` is untouched."""
    path = Path(path)
    if mkdir:
        path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_dir():
        raise IsADirectoryError(21, "Is a directory", str(path))
    tmp = _temp_name(path)
    try:
        yield tmp
        with contextlib.suppress(OSError):  # durable before it takes the name
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        if _claimed(path):
            try:
                os.link(tmp, path)
            except FileExistsError:
                raise Claimed(errno.EEXIST, "written by another process meanwhile", str(path)) from None
            tmp.unlink()
        else:
            os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    fsync_dir(path.parent)


@contextlib.contextmanager
def atomic_write(
    path: str | Path, mode: str = "w", encoding: str | None = "utf-8", newline: str | None = None
) -> Iterator[IO]:
    """``open(path, mode)`` whose content replaces ``path`` only when the block ends without an
    exception (see the module docstring). ``mode`` is ``"w"`` or ``"wb"``."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write writes whole files: mode 'w' or 'wb', not {mode!r}")
    with atomic_path(path) as tmp:
        binary = mode == "wb"
        with open(tmp, mode, encoding=None if binary else encoding, newline=None if binary else newline) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())


def write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns ``path``."""
    with atomic_write(path, "w", encoding=encoding) as f:
        f.write(text)
    return Path(path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


@contextlib.contextmanager
def building_dir(final: str | Path) -> Iterator[Path]:
    """A fresh hidden folder beside ``final`` to build a whole folder in; on a clean exit it takes
    ``final``'s place (an existing ``final`` is moved aside first and deleted after the swap), on
    an exception it is deleted and ``final`` is untouched. Whether ``final`` may be replaced at
    all is the caller's decision (:mod:`catpose.bench.run.overwrite`)."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    for stale in final.parent.glob(f".{glob.escape(final.name)}.*-*.tmp"):  # left by a killed process
        pid = stale.name[len(final.name) + 2 :].split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(stale, ignore_errors=True)
    tmp = final.with_name(f".{final.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp")
    tmp.mkdir()
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if _claimed(final):
        try:
            os.rename(tmp, final)  # onto a missing or empty folder only
        except OSError as e:
            shutil.rmtree(tmp, ignore_errors=True)
            if e.errno in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR, errno.EISDIR):
                raise Claimed(errno.EEXIST, "written by another process meanwhile", str(final)) from None
            raise
    else:
        if final.exists() and not (final.is_dir() and not any(final.iterdir())):
            old = final.with_name(f".{final.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.old")
            os.replace(final, old)
        os.replace(tmp, final)  # onto a missing or empty folder
    fsync_dir(final.parent)
    if old is not None:
        if old.is_dir():
            shutil.rmtree(old, ignore_errors=True)
        else:
            old.unlink(missing_ok=True)
