"""Threads for the compiled kernels: independent starts split over a small shared pool.

Ours' compiled searches and its Chamfer distances loop over many independent starts (poses,
candidates). :func:`split` hands contiguous ranges of them to :func:`threads` threads (the kernels
release the GIL); each start is still computed by one thread in its fixed order, so the answers
are the same bits for any thread count. (Not numba's ``parallel=True``: its workqueue layer breaks
when several Python threads call into it.)

The count is the runs' ``threads`` key, set per process by :func:`set_threads` (torch's intra-op
threads too); ``auto``, also the default here, is :func:`available`: ``OMP_NUM_THREADS`` where set,
else the CPUs of this process's affinity, at most :data:`MAX_AUTO`.
"""

from __future__ import annotations

import itertools
import numbers
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

__all__ = [
    "AUTO",
    "MAX_AUTO",
    "MIN_ITEMS",
    "PIECES",
    "available",
    "chunks",
    "resolve",
    "set_threads",
    "split",
    "threads",
]

#: below this many starts a call stays on the calling thread (a hand-off costs tens of microseconds,
#: a start of ours' ICP about a millisecond)
MIN_ITEMS = 2
#: ranges per thread (starts differ in cost: ICP stops on convergence)
PIECES = 4
#: the ``threads`` value that asks for :func:`available`
AUTO = "auto"
#: most threads ``auto`` takes: ours' calls split tens of starts (hypotheses, candidates, grid
#: poses) into ``PIECES`` ranges per thread, so far beyond this the ranges get too short to pay
MAX_AUTO = 8

_threads: int | None = None  # None: auto, resolved on first use
_pool: ThreadPoolExecutor | None = None
_pool_key: tuple[int, int] | None = None  # (workers, pid): grows on demand; a forked child builds its own
_lock = threading.Lock()
_local = threading.local()  # .worker: this thread is one of the pool's (no nested hand-off)


def threads() -> int:
    """The kernels' thread count (at least 1): the one set, else :func:`available`."""
    global _threads
    if _threads is None:
        _threads = available()
    return _threads


def available() -> int:
    """``auto``'s count: ``OMP_NUM_THREADS`` where it is a positive integer, else the CPUs this
    process may run on; at most :data:`MAX_AUTO`, at least 1."""
    env = os.environ.get("OMP_NUM_THREADS", "").strip()
    if env.isdigit() and int(env) >= 1:
        n = int(env)
    elif hasattr(os, "sched_getaffinity"):
        n = len(os.sched_getaffinity(0))
    else:  # pragma: no cover - not Linux
        n = os.cpu_count() or 1
    return max(1, min(n, MAX_AUTO))


def resolve(n: int | str | None) -> int | None:
    """The count a ``threads`` value stands for: ``auto`` (any case, spaces around) ->
    :func:`available`, an integer >= 1 as is, None as is. Raises ValueError for anything else (a
    float such as 2.0, a bool, a string of digits): the one check of the runs' key, ``bench perf``
    and the API."""
    if n is None:
        return None
    if isinstance(n, str) and n.strip().lower() == AUTO:
        return available()
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise ValueError(f"threads must be {AUTO} or an integer at least 1 (got {n!r})")
    return int(n)


def set_threads(n: int | str | None) -> None:
    """The runs' ``threads`` key: ``n`` threads (``auto``: :func:`available`) for the compiled
    kernels (:func:`split`) and for torch's intra-op work where torch is installed. None: the
    kernels take 1, torch keeps its count."""
    global _threads
    from catpose import extras

    count = resolve(n)
    _threads = 1 if count is None else count
    extras.set_torch_threads(count)


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool, _pool_key
    pid = os.getpid()
    with _lock:
        if _pool is None or _pool_key is None or _pool_key[1] != pid or _pool_key[0] < workers:
            if _pool is not None and _pool_key is not None and _pool_key[1] == pid:
                _pool.shutdown(wait=False)  # queued work still runs
            _pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="catpose-kernel", initializer=_mark)
            _pool_key = (workers, pid)
        return _pool


def _mark() -> None:
    _local.worker = True


def chunks(n_items: int, n: int) -> list[tuple[int, int]]:
    """``n_items`` split into at most ``n`` contiguous ``(start, stop)`` ranges, sizes within one."""
    n = max(1, min(n, n_items))
    q, r = divmod(n_items, n)
    bounds = list(itertools.accumulate((q + (i < r) for i in range(n)), initial=0))
    return list(zip(bounds[:-1], bounds[1:]))


def split(
    fn: Callable[[int, int], object],
    n_items: int,
    n: int | None = None,
    min_items: int = MIN_ITEMS,
    pieces: int = PIECES,
) -> list:
    """``fn(start, stop)`` over contiguous ranges covering ``range(n_items)``, on ``n`` threads
    (default :func:`threads`); returns the results in range order.

    The items are cut into up to ``pieces`` ranges per thread (sizes within one), handed out in
    order to whichever thread is free, so that a range of slow starts does not hold the others
    up. ``fn`` must treat each item on its own (write only its items' outputs): then the outcome
    does not depend on ``n`` or on which thread ran a range. With one thread, fewer than
    ``min_items`` items, or when called from one of the pool's threads, it is the single call
    ``fn(0, n_items)``. The calling thread takes ranges too; an exception in any range is raised
    here after every thread has stopped.
    """
    n = threads() if n is None else int(n)
    if n <= 1 or n_items < max(min_items, 2) or getattr(_local, "worker", False):
        return [fn(0, n_items)]
    ranges = chunks(n_items, n * max(1, pieces))
    n = min(n, len(ranges))
    results: list = [None] * len(ranges)
    claim = itertools.count()  # next() of a count is atomic under the GIL: each range is run once

    def work() -> None:
        while (i := next(claim)) < len(ranges):
            results[i] = fn(*ranges[i])

    futures = [_executor(n - 1).submit(work) for _ in range(n - 1)]
    try:
        work()
    finally:
        errors = [f.exception() for f in futures]  # wait for all before leaving: they write shared outputs
    for e in errors:
        if e is not None:
            raise e
    return results
