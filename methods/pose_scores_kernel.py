"""The visibility-aware Chamfer score of :func:`catpose.methods.pose_scores.visibility_chamfer` as one
compiled call for many poses (numba).

Same score (``mean_i min(d(T x_i, template), trunc) + mean_{v in V} min(d(v, T X), trunc)``, ``V``
the template points whose outward normal faces the camera centre ``T[:3, 3]``), with both nearest
neighbour searches on :class:`~catpose.cell_grid.CellGrid` s (reach ``trunc`` at least) instead of
KD-trees: the template's grid for the first term; for the second the visible template points are mapped back into the
camera frame (``d(v, T X) = d(T^-1 v, X)`` for a rigid ``T``) and searched in one grid of the
input, built once per problem instead of one KD-tree per pose. The poses are split over the run's
``threads`` (:mod:`catpose.kernel_threads`). The NumPy version is the reference in
``tests/test_cell_grid.py``.
"""

from __future__ import annotations

import numba
import numpy as np

from catpose import cell_grid, kernel_threads
from catpose.cell_grid import CellGrid
from catpose.point_to_plane_kernel import transform_point


def visibility_scores(
    points_camera: np.ndarray,
    input_grid: CellGrid,
    T_template_camera: np.ndarray,
    template_grid: CellGrid,
    template_normals: np.ndarray,
    trunc: float,
) -> np.ndarray:
    """(B,) truncated two-directional visible Chamfer of ``points_camera`` (N, 3; ``input_grid``
    is its grid) under each pose ``T_template_camera`` (B, 4, 4), against the template of
    ``template_grid`` with unit ``template_normals`` (M, 3); object-normalised unit."""
    if not (trunc <= input_grid.reach and trunc <= template_grid.reach):
        raise ValueError(
            f"visibility_scores: trunc {trunc} exceeds a grid's reach ({input_grid.reach}, {template_grid.reach})"
        )
    T = np.ascontiguousarray(T_template_camera, dtype=np.float64).reshape(-1, 4, 4)
    out = np.empty(len(T))
    points = np.ascontiguousarray(points_camera, dtype=np.float64)
    grids = (*cell_grid.arrays(input_grid), *cell_grid.arrays(template_grid))
    normals = np.ascontiguousarray(template_normals, dtype=np.float64)

    def run(lo: int, hi: int) -> None:  # poses lo..hi-1, each on one thread (the same bits on any count)
        _scores_into(points, *grids, normals, T[lo:hi], float(trunc), out[lo:hi])

    kernel_threads.split(run, len(T))
    return out


@numba.njit(cache=True, nogil=True)
def _scores_into(
    points,
    ip,
    i_origin,
    i_cell,
    i_dims,
    i_start,
    i_cand,
    i_cand_r,
    tp,
    t_origin,
    t_cell,
    t_dims,
    t_start,
    t_cand,
    t_cand_r,
    normals,
    T,
    trunc,
    out,
):  # pragma: no cover - compiled
    for b in range(T.shape[0]):
        d_in = 0.0
        for i in range(points.shape[0]):
            sx, sy, sz = transform_point(T, b, points, i)
            d, _ = cell_grid.nearest_one(tp, t_origin, t_cell, t_dims, t_start, t_cand, t_cand_r, sx, sy, sz, trunc)
            d_in += min(d, trunc)
        d_in /= max(points.shape[0], 1)
        cx, cy, cz = T[b, 0, 3], T[b, 1, 3], T[b, 2, 3]
        d_vis = 0.0
        visible = 0
        for v in range(tp.shape[0]):
            vx, vy, vz = tp[v, 0], tp[v, 1], tp[v, 2]
            if normals[v, 0] * (cx - vx) + normals[v, 1] * (cy - vy) + normals[v, 2] * (cz - vz) <= 0.0:
                continue
            visible += 1
            # T^-1 v = R^T (v - t): the visible point in the camera frame
            ux, uy, uz = vx - cx, vy - cy, vz - cz
            qx = T[b, 0, 0] * ux + T[b, 1, 0] * uy + T[b, 2, 0] * uz
            qy = T[b, 0, 1] * ux + T[b, 1, 1] * uy + T[b, 2, 1] * uz
            qz = T[b, 0, 2] * ux + T[b, 1, 2] * uy + T[b, 2, 2] * uz
            d, _ = cell_grid.nearest_one(ip, i_origin, i_cell, i_dims, i_start, i_cand, i_cand_r, qx, qy, qz, trunc)
            d_vis += min(d, trunc)
        out[b] = d_in + (d_vis / visible if visible > 0 else trunc)
