"""Point-to-plane ICP (Chen & Medioni 1992) in NumPy against a KD-tree of the target: the test
reference of the compiled kernel (:mod:`catpose.point_to_plane_kernel`).

Each step pairs every transformed source point ``s`` with its nearest target point ``q``
(normal ``n``) within ``max_distance`` and solves the linearised least squares
``min_x sum ((q - s) . n - [s x n, n] . x)^2`` for a small rotation ``x[:3]`` (axis-angle) and
translation ``x[3:]``, applied on the left. Unlike Open3D's ICP it is reproducible on any number
of threads (no parallel reductions).
"""

from __future__ import annotations

import numpy as np

from catpose.geometry import axis_angle_to_R, make_T


def pairs(points, T, target_points, target_normals, tree, max_distance: float, min_pairs: int):
    """``points`` (N, 3) moved by ``T`` (4, 4) and paired with their nearest target points within
    ``max_distance``: (moved points, their targets, the targets' normals), each (k, 3); None with
    fewer than ``min_pairs`` pairs."""
    src = points @ T[:3, :3].T + T[:3, 3]
    d, j = tree.query(src, distance_upper_bound=max_distance)
    ok = np.isfinite(d)
    if ok.sum() < min_pairs:
        return None
    return src[ok], target_points[j[ok]], target_normals[j[ok]]


def refine_point_to_plane(
    points: np.ndarray,
    target_points: np.ndarray,
    target_normals: np.ndarray,
    tree,
    T_init: np.ndarray,
    max_distance: float,
    iterations: int,
) -> np.ndarray:
    """Refine the (4, 4) source-to-target transform from ``T_init``.

    Args:
        points: (N, 3) source points, source frame.
        target_points, target_normals: (M, 3) target points and unit normals, target frame.
        tree: ``scipy.spatial.cKDTree`` of ``target_points``.
        max_distance: correspondence distance cap, same unit as the points.
        iterations: the most Gauss-Newton steps; stops early on a step below 1e-7 or with fewer
            than 6 pairs.

    Returns:
        (4, 4) refined transform with an orthonormal rotation.
    """
    T = np.array(T_init, dtype=np.float64, copy=True)
    for _ in range(iterations):
        paired = pairs(points, T, target_points, target_normals, tree, max_distance, 6)
        if paired is None:
            break
        s, q, n = paired
        J = np.concatenate([np.cross(s, n), n], axis=1)  # (k, 6)
        r = np.einsum("ij,ij->i", q - s, n)
        H = J.T @ J + 1e-9 * np.eye(6)
        x = np.linalg.solve(H, J.T @ r)
        angle = float(np.linalg.norm(x[:3]))
        dR = axis_angle_to_R(x[:3], angle) if angle > 1e-12 else np.eye(3)
        T = make_T(dR, x[3:]) @ T
        if angle < 1e-7 and np.linalg.norm(x[3:]) < 1e-7:
            break
    U, _, Vt = np.linalg.svd(T[:3, :3])
    T[:3, :3] = U @ Vt
    return T
