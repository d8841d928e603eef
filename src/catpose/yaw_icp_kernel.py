"""Point-to-plane ICP restricted to a yaw and a translation, as one compiled call for many starts.

An object resting on a known ground (a tabletop) has one rotational degree of freedom left: the
yaw about the ground normal. For a start ``T`` (mapping source points into the target frame) and
that normal's direction ``a`` in the target frame, each step solves
``min_(w, t) sum ((q - s) . n - w (a x s) . n - t . n)^2`` over the pairs within ``max_distance``
(``s``: the moved source point, ``q``, ``n``: its nearest target point and normal), rotates by
``w`` about ``a`` (applied on the left, so the resting direction stays where it was) and
translates by ``t``. Stops on a step below 1e-7 or with fewer than 4 pairs. Same pairing
(:class:`~catpose.cell_grid.CellGrid`, exact within ``max_distance``) and the same one-thread,
fixed-order float64 arithmetic as :mod:`catpose.point_to_plane_kernel` (starts split over the
run's ``threads`` the same way); tested against a NumPy reference in
``tests/test_yaw_icp_kernel.py``.
"""

from __future__ import annotations

import numba
import numpy as np

from catpose import cell_grid, kernel_threads
from catpose.cell_grid import CellGrid
from catpose.point_to_plane_kernel import normal_equations, rodrigues_into, solve_spd, turn_and_shift

__all__ = ["refine_yaw_many"]


def refine_yaw_many(
    points: np.ndarray,
    grid: CellGrid,
    target_normals: np.ndarray,
    T_init: np.ndarray,
    axes: np.ndarray,
    max_distance: float,
    iterations: int,
) -> np.ndarray:
    """Refine every start ``T_init`` (B, 4, 4) by yaw about its unit axis ``axes`` (B, 3, target
    frame) and translation, pairing ``points`` (N, 3, source frame) with the grid's points (unit
    ``target_normals`` (M, 3)) within ``max_distance`` (the points' unit), at most ``iterations``
    Gauss-Newton steps each. Returns (B, 4, 4); each rotation is the start's turned about its axis."""
    if not max_distance <= grid.reach:
        raise ValueError(f"refine_yaw_many: max_distance {max_distance} exceeds the grid's reach {grid.reach}")
    T = np.array(T_init, dtype=np.float64, copy=True).reshape(-1, 4, 4)
    A = np.ascontiguousarray(axes, dtype=np.float64).reshape(-1, 3)
    A = A / np.linalg.norm(A, axis=1, keepdims=True)
    if len(A) != len(T):
        raise ValueError(f"refine_yaw_many: {len(T)} starts but {len(A)} axes")
    points = np.ascontiguousarray(points, dtype=np.float64)
    arrays = cell_grid.arrays(grid)
    normals = np.ascontiguousarray(target_normals, dtype=np.float64)

    def run(lo: int, hi: int) -> None:  # the starts lo..hi-1, in place
        _refine_yaw_into(points, *arrays, normals, T[lo:hi], A[lo:hi], float(max_distance), int(iterations))

    kernel_threads.split(run, len(T))
    return T


@numba.njit(cache=True, nogil=True)
def _refine_yaw_into(
    points, tp, origin, cell, dims, start, cand, cand_r, normals, T, A, max_distance, iterations
):  # pragma: no cover - compiled
    H = np.zeros((4, 4))
    g = np.zeros(4)
    J = np.zeros(4)
    x = np.zeros(4)
    dR = np.zeros((3, 3))
    for b in range(T.shape[0]):
        ax, ay, az = A[b, 0], A[b, 1], A[b, 2]
        for _ in range(iterations):
            pairs = normal_equations(
                points, tp, origin, cell, dims, start, cand, cand_r, normals, T, b, max_distance, A[b], H, g, J
            )
            if pairs < 4:
                break
            if not solve_spd(H, g, x):
                break
            w = x[0]
            rodrigues_into(dR, ax, ay, az, np.sin(w), 1.0 - np.cos(w))
            turn_and_shift(T, b, dR, x[1], x[2], x[3])
            if abs(w) < 1e-7 and np.sqrt(x[1] * x[1] + x[2] * x[2] + x[3] * x[3]) < 1e-7:
                break
