"""Small synthetic clouds with known normals, shared by the tests of the geometric kernels."""

from __future__ import annotations

import numpy as np


def box_cloud(extents, centre, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points (n, 3) and outward unit normals on the surface of an axis-aligned box of
    ``extents`` (3,) centred at ``centre`` (3,), faces drawn uniformly."""
    ext, c = np.asarray(extents, float), np.asarray(centre, float)
    faces = rng.integers(0, 6, n)
    p = rng.uniform(-0.5, 0.5, (n, 3)) * ext
    axis, sign = faces // 2, np.where(faces % 2 == 0, 1.0, -1.0)
    p[np.arange(n), axis] = sign * 0.5 * ext[axis]
    normals = np.zeros((n, 3))
    normals[np.arange(n), axis] = sign
    return p + c, normals
