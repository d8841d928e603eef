"""Hidden point removal (Katz, Tal, Basri 2007) through Open3D: the points of a cloud visible
from a viewpoint. Used for the partial-template dictionary and for partial views of point-cloud
datasets."""

from __future__ import annotations

import numpy as np


def visible_indices(points: np.ndarray, viewpoint: np.ndarray, radius_factor: float = 100.0) -> np.ndarray:
    """Indices (sorted, unique, int64) of ``points`` (N, 3) visible from ``viewpoint`` (3,).

    The spherical-flip radius is ``radius_factor`` times the largest distance from the viewpoint
    to a point (Open3D's usual choice is 100); points and viewpoint share one frame and unit.
    """
    from catpose.o3d import o3d

    points = np.asarray(points, dtype=np.float64)
    viewpoint = np.asarray(viewpoint, dtype=np.float64)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    extent = float(np.linalg.norm(points - viewpoint, axis=1).max())
    try:
        _, idx = pcd.hidden_point_removal(viewpoint, extent * radius_factor)
    except RuntimeError as e:  # Qhull's many-line refusal of a flat or degenerate cloud
        from catpose.errors import InvalidInputError

        raise InvalidInputError(
            f"the points ({len(points)}) are flat or degenerate: Qhull found no volume in them "
            f"({str(e).split(chr(10))[0][:80]}); give a solid model or a view with depth"
        ) from None
    return np.unique(np.asarray(idx, dtype=np.int64))
