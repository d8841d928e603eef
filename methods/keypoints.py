"""Keypoint sampling: first-point voxel downsampling and farthest point sampling with indices
(Qi et al. 2017, PointNet++).

Open3D's ``farthest_point_down_sample`` returns points only and its ``voxel_down_sample``
averages; the method needs indices (to look up normals and neighbourhoods) and input points, so
these are small versions of our own, deterministic (fixed start index, first point per voxel). FPS
is compiled (numba): ours samples 256 of ~1,500 points per problem, which in NumPy cost ~10 ms of
per-step overhead.
"""

from __future__ import annotations

import numba
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
    p = np.ascontiguousarray(points, dtype=np.float64)
    n = len(p)
    k = min(int(k), n)
    out = np.empty(k, dtype=np.int64)
    if k == 0:
        return out
    _fps_into(p, int(start) % n, out)
    return out


@numba.njit(cache=True, nogil=True)
def _fps_into(p, idx, out):  # pragma: no cover - compiled
    """Farthest point sampling from index ``idx`` into ``out`` (k,); ties go to the lowest index."""
    n = p.shape[0]
    d2 = np.full(n, np.inf)
    for i in range(out.shape[0]):
        out[i] = idx
        x, y, z = p[idx, 0], p[idx, 1], p[idx, 2]
        best, nxt = -1.0, 0
        for j in range(n):
            dx, dy, dz = p[j, 0] - x, p[j, 1] - y, p[j, 2] - z
            d = dx * dx + dy * dy + dz * dz
            if d < d2[j]:
                d2[j] = d
            if d2[j] > best:
                best, nxt = d2[j], j
        idx = nxt


def voxel_downsample(points: np.ndarray, normals: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Keep one point per voxel of edge ``voxel_size`` (the first in input order; deterministic);
    normals follow. ``voxel_size <= 0`` returns the inputs. Shapes (N, 3) -> (N', 3)."""
    if voxel_size <= 0:
        return points, normals
    keys = np.floor(points / voxel_size).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    first.sort()
    return points[first], normals[first]


def too_few_points(sample_id: str, n: int, points: np.ndarray, voxel_size: float) -> str:
    """Why a view (N, 3), object-normalised, left ``n`` (fewer than 3) points after downsampling at
    ``voxel_size`` template radii, and the fix: a partial view spans 0.3-1.2 template radii, so
    one spanning under 0.1 is in another unit than the template (the unit check has warned), not
    a voxel too coarse."""
    span = 0.5 * float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    fix = (
        "the observation is in another unit than the template (a depth frame: set depth_scale)"
        if span < 0.1
        else "lower method.descriptor.voxel_size"
    )
    return (
        f"sample {sample_id}: only {n} points after voxel "
        f"downsampling at {voxel_size} template radii (the observation spans {span:.3g} of them); {fix}"
    )
