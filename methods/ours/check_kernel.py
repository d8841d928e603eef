"""The depth check's per-window costs, compiled (numba): one call per pose instead of a dozen
NumPy operations on its window.

:class:`~catpose.methods.ours.check.DepthVerifier` scores each pose on the lattice pixels of its
window: rendered depth ``r``, observed depth ``o`` and the object's mask ``m`` (each (h, w), views
of the lattice). The sums are the NumPy expressions they replaced, to the bit: the mask pixels'
costs are gathered in row-major order (boolean indexing's order) and added the way NumPy's
``sum`` adds float64 (``0.0`` plus the pairwise sum, blocks of 8 accumulators up to 128 values,
halves on multiples of 8 above), which ``tests/test_depth_cost_kernel.py`` checks against
``np.sum`` and against the NumPy form of each cost.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["pairwise_sum", "window_cost", "window_fit"]


@numba.njit(cache=True, nogil=True)
def _block(a, lo, n):  # pragma: no cover - compiled
    """NumPy's sum of one block ``a[lo:lo + n]``, ``n`` <= 128: 8 accumulators (a plain loop
    below 8 values), combined pairwise, then the remainder."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@numba.njit(cache=True, nogil=True)
def _pairwise(a, lo, n):  # pragma: no cover - compiled
    """NumPy's pairwise sum of ``a[lo:lo + n]`` (float64, 1-D): above 128 values the sum of its two
    halves (the first half's length rounded down to a multiple of 8). NumPy recurses; this walks
    the same tree with an explicit stack (numba cannot cache a recursive function)."""
    if n <= 128:
        return _block(a, lo, n)
    depth = 64  # halving from 2**62 values; each level holds one pending node
    los = np.empty(depth, dtype=np.int64)
    ns = np.empty(depth, dtype=np.int64)
    state = np.empty(depth, dtype=np.int64)  # 0: neither half summed, 1: the first, 2: both
    sums = np.empty(depth)
    los[0], ns[0], state[0] = lo, n, 0
    sp, vp = 1, 0
    while sp > 0:
        top = sp - 1
        k = ns[top]
        if k <= 128:
            sums[vp] = _block(a, los[top], k)
            vp += 1
            sp -= 1
            continue
        n2 = k // 2
        n2 -= n2 % 8
        if state[top] == 0:
            state[top] = 1
            los[sp], ns[sp], state[sp] = los[top], n2, 0
            sp += 1
        elif state[top] == 1:
            state[top] = 2
            los[sp], ns[sp], state[sp] = los[top] + n2, k - n2, 0
            sp += 1
        else:
            sums[vp - 2] = sums[vp - 2] + sums[vp - 1]
            vp -= 1
            sp -= 1
    return sums[0]


@numba.njit(cache=True, nogil=True)
def pairwise_sum(a):  # pragma: no cover - compiled
    """``np.sum(a)`` of a 1-D float64 array, the same bits: ``0.0`` plus NumPy's pairwise sum."""
    return 0.0 + _pairwise(a, 0, a.shape[0])


@numba.njit(cache=True, nogil=True)
def window_cost(o, m, r, tau):  # pragma: no cover - compiled
    """One pose's window: ``(mask_sum, mask_count, free)``.

    ``mask_sum``: over the mask pixels (row-major), ``min(|r - o|, tau) / tau`` where ``r > 0``
    (rendered), else 1. ``mask_count``: the window's mask pixels. ``free``: pixels outside the
    mask with ``r > 0``, ``o > 0`` and ``o - r > tau`` (rendered surface in front of what the sensor
    saw). ``o``, ``r`` (h, w) float64, ``m`` (h, w) bool, ``tau`` > 0 (depth unit)."""
    h, w = m.shape
    vals = np.empty(h * w)
    count = 0
    free = 0
    for i in range(h):
        for j in range(w):
            rr = r[i, j]
            oo = o[i, j]
            if m[i, j]:
                if rr > 0:
                    d = np.abs(rr - oo)
                    vals[count] = (d if (d < tau or d != d) else tau) / tau  # np.minimum keeps NaN
                else:
                    vals[count] = 1.0
                count += 1
            elif rr > 0 and oo > 0 and oo - rr > tau:
                free += 1
    return pairwise_sum(vals[:count]), count, free


@numba.njit(cache=True, nogil=True)
def window_fit(o, m, inner, r, tol):  # pragma: no cover - compiled
    """One pose's window: ``(inliers, free)``: ``inner`` pixels with ``r > 0`` and
    ``|r - o| <= tol``, and pixels outside the mask ``m`` with ``r > 0``, ``o > 0`` and
    ``o - r > tol``. Arrays (h, w) as in :func:`window_cost`, ``inner`` bool."""
    h, w = m.shape
    inliers = 0
    free = 0
    for i in range(h):
        for j in range(w):
            rr = r[i, j]
            if rr > 0:
                oo = o[i, j]
                if inner[i, j] and np.abs(rr - oo) <= tol:
                    inliers += 1
                if not m[i, j] and oo > 0 and oo - rr > tol:
                    free += 1
    return inliers, free
