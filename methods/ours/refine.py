"""Refinement, ours' last stage: point-to-plane ICP of the input against the complete template
from each chosen pose, all poses at once (:func:`catpose.point_to_plane_kernel.refine_many`,
compiled, on a :class:`~catpose.cell_grid.CellGrid` of the template's points)."""

from __future__ import annotations

import numpy as np

from catpose.point_to_plane_kernel import refine_many

__all__ = ["REFINE_ITERATIONS", "REFINE_MAX_DISTANCE", "refine_poses"]

#: ICP pairing distance, object-normalised unit: a few times the keypoint spacing, well inside
#: the basin a right candidate starts in (the paper's pipeline plus refinement; docs/choosing-defaults.md)
REFINE_MAX_DISTANCE = 0.05
#: ICP steps at most (converged long before on the embedded set; docs/choosing-defaults.md)
REFINE_ITERATIONS = 30


def refine_poses(points: np.ndarray, grid, normals: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Poses ``T`` (B, 4, 4) ``T_template_camera`` refined by point-to-plane ICP of ``points``
    (N, 3, camera frame) against the template (``grid``: a :class:`~catpose.cell_grid.CellGrid`
    of its points with reach at least :data:`REFINE_MAX_DISTANCE`; ``normals`` (M, 3)), pairing
    within :data:`REFINE_MAX_DISTANCE`; a copy of ``T`` when it holds no pose."""
    if len(T) == 0:
        return np.array(T, copy=True)
    return refine_many(points, grid, normals, T, REFINE_MAX_DISTANCE, REFINE_ITERATIONS)
