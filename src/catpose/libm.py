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

import numpy as np

_ACOS = np.frompyfunc(math.acos, 1, 1)
_ATAN = np.frompyfunc(math.atan, 1, 1)
_ATAN2 = np.frompyfunc(math.atan2, 2, 1)
_TAN = np.frompyfunc(math.tan, 1, 1)
_POW = np.frompyfunc(math.pow, 2, 1)
_EXP = np.frompyfunc(math.exp, 1, 1)


def _apply(f: np.ufunc, *args: np.ndarray | float) -> np.ndarray | float:
    arrays = [np.asarray(a, dtype=np.float64) for a in args]
    out = f(*arrays)
    if isinstance(out, np.ndarray):
        return out.astype(np.float64)
    return float(out)


def arccos(x: np.ndarray | float) -> np.ndarray | float:
    """``arccos`` (radians) of values in [-1, 1] (clip first); float for a scalar."""
    return _apply(_ACOS, x)


def arctan(x: np.ndarray | float) -> np.ndarray | float:
    """``arctan`` (radians); float for a scalar."""
    return _apply(_ATAN, x)


def arctan2(y: np.ndarray | float, x: np.ndarray | float) -> np.ndarray | float:
    """``arctan2(y, x)`` (radians), broadcast; float for scalars."""
    return _apply(_ATAN2, y, x)


def tan(x: np.ndarray | float) -> np.ndarray | float:
    """``tan`` of angles in radians; float for a scalar."""
    return _apply(_TAN, x)


def power(x: np.ndarray | float, p: np.ndarray | float) -> np.ndarray | float:
    """``x ** p`` for non-negative ``x`` (``math.pow``), broadcast; float for scalars."""
    return _apply(_POW, x, p)


def exp(x: np.ndarray | float) -> np.ndarray | float:
    """``e ** x``; float for a scalar."""
    return _apply(_EXP, x)
