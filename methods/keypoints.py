"""Keypoint sampling: first-point voxel downsampling and farthest point sampling with indices
(Qi et al. 2017, PointNet++).

Open3D's ``farthest_point_down_sample`` returns points only and its ``voxel_down_sample``
averages; the method needs indices (to look up normals and neighbourhoods) and input points, so
these are small vectorised NumPy versions, deterministic (fixed start index, first point per voxel).
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


def voxel_downsample(points: np.ndarray, normals: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Keep one point per voxel of edge ``voxel_size`` (the first in input order; deterministic);
    normals follow. ``voxel_size <= 0`` returns the inputs. Shapes (N, 3) -> (N', 3)."""
    if voxel_size <= 0:
        return points, normals
    keys = np.floor(points / voxel_size).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    first.sort()
    return points[first], normals[first]
