"""The yaw-and-translation ICP kernel (:mod:`catpose.yaw_icp_kernel`) against a NumPy reference
(the same least squares over scipy's cKDTree pairs, solved by ``numpy.linalg.solve``), and what
it promises: the resting direction stays put, a yaw and a shift are recovered."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from catpose import cell_grid
from catpose.geometry import axis_angle_to_R, make_T
from catpose.yaw_icp_kernel import refine_yaw_many

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _clouds import box_cloud  # noqa: E402
from _point_to_plane_reference import pairs  # noqa: E402


def _reference(points, tgt, normals, tree, T_init, axis, max_distance, iterations) -> np.ndarray:
    """Yaw-and-translation point-to-plane ICP in NumPy: ``min_(w, t) sum ((q - s) . n - w (a x s) . n
    - t . n)^2`` per step, ``T <- [R_a(w), t] T``; stops on a step below 1e-7 or under 4 pairs."""
    a = axis / np.linalg.norm(axis)
    T = np.array(T_init, dtype=np.float64, copy=True)
    for _ in range(iterations):
        paired = pairs(points, T, tgt, normals, tree, max_distance, 4)
        if paired is None:
            break
        s, q, n = paired
        J = np.concatenate([np.einsum("ij,ij->i", np.cross(a, s), n)[:, None], n], axis=1)
        r = np.einsum("ij,ij->i", q - s, n)
        x = np.linalg.solve(J.T @ J + 1e-9 * np.eye(4), J.T @ r)
        T = make_T(axis_angle_to_R(a, float(x[0])), x[1:]) @ T
        if abs(x[0]) < 1e-7 and np.linalg.norm(x[1:]) < 1e-7:
            break
    return T


def _bumped_box(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    p, normals = box_cloud((0.8, 0.5, 0.3), (0.0, 0.0, 0.0), 3000, rng)
    p[(p[:, 2] > 0.14) & (p[:, 0] > 0.2), 2] += 0.05  # no sliding symmetry
    return p, normals


@pytest.mark.parametrize("iterations", [1, 3, 20])
def test_matches_the_numpy_reference_from_every_start(iterations: int) -> None:
    rng = np.random.default_rng(5)
    tgt, tgt_n = _bumped_box(rng)
    up = np.array([0.0, 0.0, 1.0])
    T_gt = make_T(axis_angle_to_R(up, 0.3), [0.04, -0.02, 0.0])
    src = (tgt[::4] - T_gt[:3, 3]) @ T_gt[:3, :3]  # T_gt maps src onto the target
    starts = np.stack(
        [
            np.eye(4),
            make_T(axis_angle_to_R(up, -0.2), [0.0, 0.03, 0.01]),
            make_T(Rotation.from_rotvec([0.1, 0.0, 0.0]).as_matrix(), [0.0, 0.0, 0.02]),  # tilted: stays tilted
            make_T(np.eye(3), [5.0, 0.0, 0.0]),  # no pair within reach: unchanged
        ]
    )
    axes = np.tile(up, (len(starts), 1))
    tree, grid = cKDTree(tgt), cell_grid.build(tgt, 0.1)
    T = refine_yaw_many(src, grid, tgt_n, starts, axes, 0.1, iterations)
    for b, start in enumerate(starts):
        np.testing.assert_allclose(T[b], _reference(src, tgt, tgt_n, tree, start, up, 0.1, iterations), atol=1e-9)
    np.testing.assert_array_equal(T[3], starts[3])
    if iterations == 20:
        np.testing.assert_allclose(T[0], T_gt, atol=1e-6)  # a 17 deg yaw and a shift, recovered


def test_the_resting_direction_stays_put() -> None:
    rng = np.random.default_rng(6)
    tgt, tgt_n = _bumped_box(rng)
    src = tgt[::3] @ Rotation.from_rotvec([0.2, -0.1, 0.4]).as_matrix().T + [0.05, 0.0, -0.03]
    g = np.array([0.3, -0.2, 0.93])  # the ground normal, source (camera) frame
    starts = np.stack([make_T(Rotation.random(random_state=k).as_matrix(), [0.0, 0.0, 0.0]) for k in range(5)])
    axes = np.einsum("bij,j->bi", starts[:, :3, :3], g / np.linalg.norm(g))
    T = refine_yaw_many(src, cell_grid.build(tgt, 0.15), tgt_n, starts, axes, 0.15, 10)
    np.testing.assert_allclose(np.einsum("bij,j->bi", T[:, :3, :3], g / np.linalg.norm(g)), axes, atol=1e-9)
    np.testing.assert_allclose(
        np.einsum("bij,bkj->bik", T[:, :3, :3], T[:, :3, :3]), np.tile(np.eye(3), (5, 1, 1)), atol=1e-9
    )


def test_bad_arguments_are_refused() -> None:
    tgt, tgt_n = _bumped_box(np.random.default_rng(7))
    grid = cell_grid.build(tgt, 0.1)
    with pytest.raises(ValueError, match="reach"):
        refine_yaw_many(tgt, grid, tgt_n, np.eye(4)[None], np.array([[0.0, 0.0, 1.0]]), 0.5, 3)
    with pytest.raises(ValueError, match="axes"):
        refine_yaw_many(tgt, grid, tgt_n, np.eye(4)[None], np.zeros((2, 3)) + 1.0, 0.1, 3)
