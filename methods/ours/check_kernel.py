"""The depth check's per-window costs, compiled (numba): one call per pose instead of a dozen
NumPy operations on its window.

:class:`~catpose.methods.ours.check.DepthVerifier` scores each pose on the lattice pixels of its
window: rendered depth ``r``, observed depth ``o`` and the object's mask ``m`` (each (h, w), views
of the lattice). The mask pixels' costs come back in row-major order (boolean indexing's order)
for NumPy's ``sum``, so the score has the bits of the NumPy expressions the kernel replaced
(``tests/test_depth_cost_kernel.py``).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["needed", "window_cost", "window_fit"]


@numba.njit(cache=True, nogil=True)
def window_cost(o, m, r, tau):  # pragma: no cover - compiled
    """One pose's window: ``(mask_costs, free)``.

    ``mask_costs``: per mask pixel (row-major), ``min(|r - o|, tau) / tau`` where ``r > 0``
    (rendered), else 1 (as many as the window's mask pixels). ``free``: pixels outside the
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
    return vals[:count], free


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


@numba.njit(cache=True, nogil=True)
def needed(o, m, d, t, lo, hi, tol):  # pragma: no cover - compiled
    """``(need, rays)``: which pixels (h * w,) of one pose's window can change :func:`window_cost`
    or :func:`window_fit` of tolerance ``tol`` or more, and their rows of the rays ``d`` (h * w, 3;
    from ``t``, template frame; the parameter is depth). Every hit lies in the box ``lo``, ``hi``,
    no nearer than the ray's entry: needed are the rays into it in the mask ``m`` or where the
    observed depth ``o`` lies more than ``tol`` behind that entry."""
    h, w = m.shape
    need = np.zeros(h * w, dtype=np.bool_)
    rays = np.empty((h * w, 3))
    count = 0
    for i in range(h):
        for j in range(w):
            if not m[i, j] and not o[i, j] > 0:
                continue
            p = i * w + j
            near, far = 0.0, np.inf
            for a in range(3):
                if d[p, a] != 0.0:
                    inv = 1.0 / d[p, a]  # rounding moves the entry far less than the box's margin
                    s0, s1 = (lo[a] - t[a]) * inv, (hi[a] - t[a]) * inv
                    near, far = max(near, min(s0, s1)), min(far, max(s0, s1))
                elif t[a] < lo[a] or t[a] > hi[a]:
                    far = -1.0
            if near <= far and (m[i, j] or o[i, j] - tol > near):
                need[p] = True
                rays[count] = d[p]
                count += 1
    return need, rays[:count]
