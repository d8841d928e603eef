"""The coarse search over every resting pose x yaw (catpose.methods.ours.rest_search)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import chair_template, rotation_error_deg  # noqa: E402

from catpose.geometry import axis_angle_to_R, invert_T, make_T  # noqa: E402
from catpose.methods.ours.rest_search import grid_poses, grid_rotations  # noqa: E402


def test_every_rotation_rests_the_template_on_its_up_and_the_yaws_differ():
    rng = np.random.default_rng(0)
    g = rng.normal(size=3)
    g /= np.linalg.norm(g)
    ups = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -0.6, -0.8]])
    R, rest = grid_rotations(ups, g, 8)
    assert R.shape == (24, 3, 3) and list(np.bincount(rest)) == [8, 8, 8]
    for Ri, k in zip(R, rest):
        assert Ri @ Ri.T == pytest.approx(np.eye(3), abs=1e-12) and np.linalg.det(Ri) == pytest.approx(1.0)
        assert Ri @ g == pytest.approx(ups[k] / np.linalg.norm(ups[k]), abs=1e-12)  # g maps onto the up
    yaws = [rotation_error_deg(R[0], R[j]) for j in range(1, 8)]
    assert sorted(np.round(yaws, 6)) == sorted(np.round([45, 90, 135, 180, 135, 90, 45], 6))


def test_an_up_along_the_symmetry_axis_needs_one_yaw():
    ups = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    _, rest = grid_rotations(ups, np.array([0.0, -1.0, 0.0]), 12, symmetry_axis=np.array([0.0, 0.0, 1.0]))
    assert list(np.bincount(rest)) == [1, 1, 12]


def test_the_translation_puts_the_template_front_on_the_observation():
    """At the right rotation, the pose places the observed front points within a fraction of the
    object's size of where they are."""
    tpl = chair_template()
    rng = np.random.default_rng(1)
    R_true = axis_angle_to_R(np.array([0.0, 0.0, 1.0]), np.radians(90.0))  # a yaw on the table
    T_template_camera = make_T(R_true, [0.1, -0.2, 0.05]) @ invert_T(
        make_T(Rotation.random(random_state=rng).as_matrix(), [0, 0, 3.0])
    )
    T_camera_template = invert_T(T_template_camera)
    cam = T_template_camera[:3, 3]  # the camera centre, template frame
    front = tpl.points[((cam - tpl.points) * tpl.normals).sum(axis=1) > 0]
    points = front @ T_camera_template[:3, :3].T + T_camera_template[:3, 3]
    g = T_camera_template[:3, :3] @ np.array([0.0, 0.0, 1.0])  # the template's up seen from the camera
    T, rest = grid_poses(np.array([[0.0, 0.0, 1.0]]), g, points, tpl.points, tpl.normals, 72)
    errs = [rotation_error_deg(t[:3, :3], T_template_camera[:3, :3]) for t in T]
    best = int(np.argmin(errs))
    assert errs[best] <= 2.5 + 1e-9  # every rotation resting on the up is within half a 5-degree step
    moved = points @ T[best, :3, :3].T + T[best, :3, 3]
    truth = points @ T_template_camera[:3, :3].T + T_template_camera[:3, 3]
    assert np.linalg.norm(moved - truth, axis=1).max() < 0.2  # unit-sphere template: under a fifth of its radius


def test_a_single_yaw_up_gets_the_others_budget_as_shifted_placements():
    """``shift``: an up along the symmetry axis starts from its placement and ``yaws - 1`` copies
    moved along the ground by ``shift`` x the template's radius about it; the other ups keep
    their yaws, and ``shift=0`` gives the unshifted grid bit for bit."""
    rng = np.random.default_rng(2)
    h = rng.uniform(-0.3, 0.3, 4000)  # a cylinder of radius 0.8 about z
    a = rng.uniform(0.0, 2.0 * np.pi, 4000)
    P = np.stack([0.8 * np.cos(a), 0.8 * np.sin(a), h], axis=1)
    N = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    g = np.array([0.0, -0.6, -0.8])
    obs = rng.normal(size=(50, 3)) * 0.1 + [0.0, 0.0, 2.0]
    ups = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    axis = np.array([0.0, 0.0, 1.0])
    T0, rest0 = grid_poses(ups, g, obs, P, N, 8, axis)
    T00, _ = grid_poses(ups, g, obs, P, N, 8, axis, 0.0)
    assert list(np.bincount(rest0)) == [1, 1, 8] and np.array_equal(T0, T00)
    T, rest = grid_poses(ups, g, obs, P, N, 8, axis, 0.5)
    assert list(np.bincount(rest)) == [8, 8, 8]
    for k in (0, 1):
        base = T0[rest0 == k][0]
        poses = T[rest == k]
        assert np.array_equal(poses[0], base)  # the unshifted placement first
        moves = []
        for t in poses[1:]:
            assert np.array_equal(t[:3, :3], base[:3, :3])
            moves.append(base[:3, :3].T @ (base[:3, 3] - t[:3, 3]))  # the object moved, camera frame
        moves = np.array(moves)
        assert moves @ g == pytest.approx(np.zeros(7), abs=1e-12)  # along the ground
        radius = np.sqrt(((P[:, :2] - P[:, :2].mean(axis=0)) ** 2).sum(axis=1)).max()  # about z
        assert np.linalg.norm(moves, axis=1) == pytest.approx(np.full(7, 0.5 * radius), rel=1e-9)
        angles = np.degrees(np.arctan2(np.cross(moves[0], moves[1:]) @ g, moves[1:] @ moves[0]))
        assert np.sort(np.mod(angles, 360.0)) == pytest.approx(np.arange(1, 7) * 360.0 / 7, abs=1e-9)
    assert np.array_equal(T[rest == 2], T0[rest0 == 2])  # the side up keeps its eight yaws
