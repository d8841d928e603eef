"""Farthest point sampling that returns indices (Qi et al. 2017, PointNet++).

Open3D's ``farthest_point_down_sample`` returns points only; the method needs indices (to
look up normals and neighbourhoods), so this is a small vectorised NumPy version with a fixed
start index, hence deterministic.
"""

from __future__ import annotations

import numpy as np


def farthest_point_indices(points: np.ndarray, k: int, start: int = 0) -> np.ndarray:
    """Indices of ``k`` points chosen by farthest point sampling.

    Args:
        points: (N, 3) cloud, any frame.
        k: number of samples; if ``k >= N`` all indices ``0..N-1`` are returned (in FPS order).
        start: index of the first sample (fixed, so the result is deterministic).

    Returns:
        (min(k, N),) int64 indices into ``points``; each next one maximises the distance to
        the already chosen set.
    """
    p = np.asarray(points, dtype=np.float64)
    n = len(p)
    k = min(int(k), n)
    out = np.empty(k, dtype=np.int64)
    if k == 0:
        return out
    idx = int(start) % n
    d2 = np.full(n, np.inf)
    for i in range(k):
        out[i] = idx
        diff = p - p[idx]
        d2 = np.minimum(d2, np.einsum("ij,ij->i", diff, diff))
        idx = int(np.argmax(d2))
    return out
