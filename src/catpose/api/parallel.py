"""``Registrar.many(..., processes=N)``: views registered by ``N`` worker processes.

Workers are started with ``spawn`` (a fresh interpreter each: no thread pool of torch, Open3D or
OpenBLAS is inherited half-way through a fork). Each builds the same method and template from the
parent's recipe (the normalised template travels whole, so no worker re-samples a mesh) and
prepares it, loading the template's dictionary and descriptors from the disk cache that the
parent's preparation filled. Every call is seeded as in the parent, so the answers equal those of
one process; they come back in the order of the views. Each worker uses one thread (the runs'
``threads`` key at 1: ours' compiled kernels and torch).
"""

from __future__ import annotations

import pickle
from typing import Any

from catpose.errors import InvalidInputError

__all__ = ["register_in_processes"]

_WORKER: Any = None  # the worker's Registrar


def _recipe(registrar: Any) -> bytes:
    """What a worker needs to rebuild ``registrar``: its template and method (name and options,
    or the pickled instance)."""
    from catpose.methods.registry import registered

    method = registrar.method_name if registrar.method_name in registered() else registrar.method
    try:
        return pickle.dumps((registrar.template, method, registrar.options))
    except Exception as e:  # noqa: BLE001 - an instance that does not pickle
        raise InvalidInputError(
            f"processes > 1 needs a method that pickles; {type(registrar.method).__name__} does not "
            f"({type(e).__name__}): pass a method config name, or processes=1"
        ) from None


def _start(recipe: bytes) -> None:
    global _WORKER
    from catpose import kernel_threads
    from catpose.api.registrar import Registrar

    kernel_threads.set_threads(1)  # the processes are the parallelism: one thread each, torch's too
    template, method, options = pickle.loads(recipe)
    _WORKER = Registrar(template, method, **options)


def _one(job: tuple[Any, Any, dict]) -> Any:
    observation, up, kwargs = job
    return _WORKER(observation, up, **kwargs)


def register_in_processes(registrar: Any, views: list, ups: list, kwargs: dict, processes: int) -> list:
    """``registrar(view, up, **kwargs)`` for every view, by ``processes`` spawned workers, in order."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    recipe = _recipe(registrar)
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=processes, mp_context=ctx, initializer=_start, initargs=(recipe,)) as pool:
        return list(pool.map(_one, [(v, u, dict(kwargs)) for v, u in zip(views, ups)]))
