"""The coarse search over every resting pose x yaw (catpose.methods.rest_grid)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import chair_template, rotation_error_deg  # noqa: E402

from catpose.geometry import axis_angle_to_R, invert_T, make_T, random_rotation  # noqa: E402
from catpose.methods.rest_grid import grid_poses, grid_rotations  # noqa: E402


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
    T_template_camera = make_T(R_true, [0.1, -0.2, 0.05]) @ invert_T(make_T(random_rotation(rng), [0, 0, 3.0]))
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
