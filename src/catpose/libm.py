"""Transcendental functions that round the same way on every x86-64 CPU.

NumPy dispatches its float64 ``exp``, ``log``, ``tan``, ``arccos``, ``arcsin``, ``arctan``,
``arctan2``, ``power`` (and a few more) to AVX-512 loops on CPUs that have AVX-512 and to its
baseline loops elsewhere; the two round differently in the last bit for 0.1-10% of inputs
(measured with ``NPY_DISABLE_CPU_FEATURES=X86_V4``). ``sin``, ``cos``, ``sqrt`` and the
arithmetic operators are exact or dispatch-independent and need no wrapper.

Python's :mod:`math` calls the C library's scalar routines, which take the same code path on
every x86-64 CPU with FMA (the AVX2 and AVX-512 machines alike), so datasets use these wrappers
wherever a transcendental value becomes part of a sample (shapes, poses, sensor noise). They are
slower than NumPy's loops (about 0.1 us per element) and meant for geometry-sized arrays and
images, not for inner loops of a method.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np


def _wrap(f: Callable[..., float], nin: int, doc: str) -> Callable[..., np.ndarray | float]:
    """``f`` (a :mod:`math` routine of ``nin`` arguments) over float64 arrays, broadcast; a float
    for scalars."""
    ufunc = np.frompyfunc(f, nin, 1)

    def apply(*args: np.ndarray | float) -> np.ndarray | float:
        out = ufunc(*[np.asarray(a, dtype=np.float64) for a in args])
        return out.astype(np.float64) if isinstance(out, np.ndarray) else float(out)

    apply.__name__, apply.__qualname__, apply.__doc__ = f.__name__, f.__name__, doc
    return apply


arccos = _wrap(math.acos, 1, "``arccos(x)`` (radians) of values in [-1, 1] (clip first).")
arctan = _wrap(math.atan, 1, "``arctan(x)`` (radians).")
arctan2 = _wrap(math.atan2, 2, "``arctan2(y, x)`` (radians).")
tan = _wrap(math.tan, 1, "``tan(x)`` of angles in radians.")
power = _wrap(math.pow, 2, "``power(x, p)``: ``x ** p`` for non-negative ``x``.")
exp = _wrap(math.exp, 1, "``exp(x)``: ``e ** x``.")
