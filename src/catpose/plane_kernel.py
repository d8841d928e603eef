"""The RANSAC plane fit's inlier counts, compiled (numba): one pass over the points per range of
hypotheses instead of NumPy temporaries of (points x 64 hypotheses).

:func:`catpose.datasets.depthio.fit_ground_plane` scores each of its (about 1000) three-point
planes ``n . p + d = 0`` by how many of the (up to 20,000) background points lie within
``distance`` of it. The count of each plane is the NumPy expression it replaced, to the bit: the
signed distance is ``((p_x n_x + p_y n_y) + p_z n_z) + d`` in that order, in float64, without fused
multiply-adds (:func:`catpose.geometry.dot3`'s order), compared with ``distance`` after ``abs``;
``tests/test_plane_kernel.py`` checks the counts against NumPy's. Ranges of planes go to the run's
``threads`` (:func:`catpose.kernel_threads.split`); each plane is counted by one thread, so the counts
do not depend on the number of threads.
"""

from __future__ import annotations

import numba
import numpy as np

from catpose import kernel_threads

__all__ = ["inlier_counts"]


@numba.njit(cache=True, nogil=True)
def _counts(p, normals, offsets, distance, lo, hi, out):  # pragma: no cover - compiled
    """``out[h]`` for planes ``lo <= h < hi``: points of ``p`` (N, 3) within ``distance``."""
    n_points = p.shape[0]
    for h in range(lo, hi):
        nx, ny, nz, d = normals[h, 0], normals[h, 1], normals[h, 2], offsets[h]
        c = 0
        for i in range(n_points):
            if abs(p[i, 0] * nx + p[i, 1] * ny + p[i, 2] * nz + d) < distance:
                c += 1
        out[h] = c


def inlier_counts(points: np.ndarray, normals: np.ndarray, offsets: np.ndarray, distance: float) -> np.ndarray:
    """(H,) int64: for each plane ``normals[h] . p + offsets[h] = 0`` (``normals`` (H, 3) unit,
    ``offsets`` (H,)), how many of ``points`` (N, 3) lie strictly within ``distance`` of it (the
    points' unit)."""
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.ascontiguousarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.ascontiguousarray(offsets, dtype=np.float64).reshape(-1)
    out = np.zeros(len(n), dtype=np.int64)
    kernel_threads.split(lambda lo, hi: _counts(p, n, d, float(distance), lo, hi, out), len(n))
    return out
