"""Compiled nearest-neighbour grid and the kernels built on it, each against an independent
reference: scipy's cKDTree, the NumPy point-to-plane ICP, the NumPy visibility-aware Chamfer."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from catpose import cell_grid
from catpose.geometry import make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _clouds import box_cloud  # noqa: E402


def _shell(rng: np.random.Generator, n: int) -> np.ndarray:
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True) * rng.uniform(0.6, 1.0, (n, 1))


@pytest.mark.parametrize("cells_per_reach", [1, 2, 3])
@pytest.mark.parametrize("reach", [0.03, 0.05, 0.2])
def test_nearest_matches_a_kd_tree_within_the_reach(reach: float, cells_per_reach: int) -> None:
    rng = np.random.default_rng(0)
    points = _shell(rng, 1500)
    queries = np.concatenate(
        [
            rng.normal(scale=0.7, size=(2000, 3)),  # inside and around
            points[:300] + rng.normal(scale=0.005, size=(300, 3)),  # on the surface
            points[300:600] + rng.normal(scale=reach, size=(300, 3)),  # near the reach
            rng.normal(scale=50.0, size=(20, 3)),
        ]
    )  # far outside the grid
    grid = cell_grid.build(points, reach, cells_per_reach)
    assert grid.cell in {reach / cells_per_reach * 2.0**k for k in range(3)}  # coarser past MAX_CELLS
    tree = cKDTree(points)
    for radius in (reach / 3, reach):
        d, j = cell_grid.nearest(grid, queries, radius)
        d_ref, j_ref = tree.query(queries, distance_upper_bound=radius)
        found = np.isfinite(d_ref)
        np.testing.assert_array_equal(np.isfinite(d), found)
        np.testing.assert_array_equal(d[found], d_ref[found])  # the same bits: exact search
        np.testing.assert_array_equal(j[found], j_ref[found])
        assert np.all(j[~found] == -1) and 0 < found.sum() < len(queries)
    with pytest.raises(ValueError, match="exceeds the grid's reach"):
        cell_grid.nearest(grid, queries, 2 * reach)


def test_nearest_edge_cases() -> None:
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    grid = cell_grid.build(points, 0.3)
    d, j = cell_grid.nearest(
        grid, np.array([[0.9, 0.0, 0.0], [np.nan, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 2.0, 0.3], [np.inf, 0.0, 0.0]]), 0.3
    )
    assert j[0] == 1  # a tie between duplicates: the lowest index
    assert j[1] == -1 and np.isinf(d[1])  # a non-finite query finds nothing
    assert j[2] == -1 and np.isinf(d[2])  # 0.5 away, beyond the radius: nothing
    assert j[3] == 3 and d[3] == pytest.approx(0.3)  # on the radius: found (inclusive)
    assert j[4] == -1
    with pytest.raises(ValueError, match="points must be"):
        cell_grid.build(np.zeros((0, 3)), 0.1)
    with pytest.raises(ValueError, match="NaN"):
        cell_grid.build(np.array([[0.0, np.nan, 0.0]]), 0.1)
    with pytest.raises(ValueError, match="reach must be > 0"):
        cell_grid.build(points, 0.0)
    with pytest.raises(ValueError, match="cells_per_reach must be"):
        cell_grid.build(points, 0.3, 0)


def test_sorted_lists_stop_early_and_keep_every_tie() -> None:
    """Lists by distance from the cell's centre, read until the triangle inequality rules the rest
    out: on a lattice with many equidistant points (queries at cell centres, edge midpoints and
    on lattice points) the answer is a brute-force search's, ties to the lowest index."""
    axis = np.arange(-5, 6) * 0.01
    points = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    points = np.concatenate([points, points[::7]])  # duplicates: the lower index must win
    rng = np.random.default_rng(3)
    queries = np.concatenate(
        [
            points[rng.integers(0, len(points), 200)],
            points[rng.integers(0, len(points), 200)] + 0.005,
            points[rng.integers(0, len(points), 200)] + np.array([0.005, 0.0, 0.0]),
            rng.uniform(-0.07, 0.07, size=(400, 3)),
        ]
    )
    for cells_per_reach in (1, 2, 3):
        grid = cell_grid.build(points, 0.02, cells_per_reach)
        for c in range(len(grid.start) - 1):  # each list ascending in distance from its centre
            assert np.all(np.diff(grid.cand_r[grid.start[c] : grid.start[c + 1]]) >= 0)
        d, j = cell_grid.nearest(grid, queries, 0.02)
        diff = queries[:, None, :] - points[None, :, :]
        d2 = diff[..., 0] * diff[..., 0] + diff[..., 1] * diff[..., 1] + diff[..., 2] * diff[..., 2]
        best = d2.min(axis=1)
        within = best <= 0.02 * 0.02
        j_ref = np.where(within, np.argmax(d2 == best[:, None], axis=1), -1)  # the first of equals
        np.testing.assert_array_equal(j, j_ref)
        np.testing.assert_array_equal(d[within], np.sqrt(best[within]))


def test_huge_extent_coarsens_the_grid_and_stays_exact() -> None:
    rng = np.random.default_rng(1)
    points = rng.uniform(-1e4, 1e4, size=(500, 3))
    grid = cell_grid.build(points, 1e-3 * 2e4)
    assert np.prod(grid.dims) <= cell_grid.MAX_CELLS and grid.cell > grid.reach
    queries = points[:200] + rng.normal(scale=20.0, size=(200, 3))
    d, _ = cell_grid.nearest(grid, queries, grid.reach)
    d_ref = cKDTree(points).query(queries, distance_upper_bound=grid.reach)[0]
    np.testing.assert_array_equal(d, d_ref)


def _box_cloud(rng: np.random.Generator, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Points and outward normals on a 0.8 x 0.5 x 0.3 box with a bump (no sliding symmetry)."""
    p, normals = box_cloud((0.8, 0.5, 0.3), (0.0, 0.0, 0.0), n, rng)
    bump = (p[:, 2] > 0.14) & (p[:, 0] > 0.2)
    p[bump, 2] += 0.05
    return p, normals


def test_refine_many_matches_the_numpy_icp_from_every_start() -> None:
    from _point_to_plane_reference import refine_point_to_plane

    from catpose.point_to_plane_kernel import refine_many

    rng = np.random.default_rng(3)
    tgt, tgt_n = _box_cloud(rng)
    T_gt = make_T(Rotation.from_rotvec([0.05, -0.03, 0.04]).as_matrix(), [0.02, -0.03, 0.01])
    src = (tgt[::4] - T_gt[:3, 3]) @ T_gt[:3, :3]  # T_gt maps src onto the target
    starts = np.stack(
        [
            np.eye(4),
            make_T(Rotation.from_rotvec([0.1, 0.0, -0.1]).as_matrix(), [0.03, 0.0, 0.0]),
            make_T(Rotation.from_rotvec([0.0, 2.5, 0.0]).as_matrix(), [0.0, 0.0, 0.2]),
            make_T(np.eye(3), [5.0, 0.0, 0.0]),
        ]
    )  # no pair within reach: unchanged
    tree, grid = cKDTree(tgt), cell_grid.build(tgt, 0.1)
    for iterations in (1, 3, 30):
        T, steps = refine_many(src, grid, tgt_n, starts, 0.1, iterations, return_steps=True)
        for b, start in enumerate(starts):
            T_ref = refine_point_to_plane(src, tgt, tgt_n, tree, start, 0.1, iterations)
            np.testing.assert_allclose(T[b], T_ref, atol=1e-9)
        assert np.all(steps <= iterations) and steps[3] == 1
    np.testing.assert_allclose(T[0], T_gt, atol=1e-6)
    assert steps[0] < 30  # stopped on convergence
    np.testing.assert_allclose(
        np.einsum("bij,bkj->bik", T[:, :3, :3], T[:, :3, :3]), np.tile(np.eye(3), (4, 1, 1)), atol=1e-12
    )


def test_visibility_scores_match_the_numpy_score() -> None:
    from catpose.methods import pose_scores as S
    from catpose.methods.pose_scores_kernel import visibility_scores

    rng = np.random.default_rng(4)
    points, normals = _box_cloud(rng)
    R = Rotation.from_rotvec([2.2, 0.3, -0.4]).as_matrix()
    T = make_T(R, [0.1, -0.2, 2.5])  # T_template_camera
    visible = S.visible_mask(points, normals, T[:3, 3])
    observed = (points[visible] - T[:3, 3]) @ R  # camera frame
    observed = observed[::5] + rng.normal(scale=0.003, size=observed[::5].shape)
    poses = np.stack(
        [T, S.half_turns()[1] @ T, S.half_turns()[3] @ T, make_T(R, [0.1, -0.2, 9.0])]
    )  # far away: everything truncated
    ref = S.visibility_chamfer(observed, poses, points, normals, cKDTree(points), 0.1)
    got = visibility_scores(observed, cell_grid.build(observed, 0.1), poses, cell_grid.build(points, 0.1), normals, 0.1)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)
    assert got[0] < min(got[1], got[2])
