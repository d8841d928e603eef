"""Grasp transfer against a known pose."""

from __future__ import annotations

import numpy as np
import pytest

from catpose.errors import InvalidInputError
from catpose.geometry import invert_T, make_T, random_rotation, transform_points
from catpose.grasp import transfer_grasp


def test_transfer_grasp_known_pose():
    rng = np.random.default_rng(0)
    T_template_camera = make_T(random_rotation(rng), rng.normal(size=3))
    T_template_grasp = make_T(random_rotation(rng), rng.normal(size=3))
    T_camera_grasp = transfer_grasp(T_template_grasp, T_template_camera)
    # The grasp point (grasp-frame origin) lands where the template point is seen by the camera.
    p_template = T_template_grasp[:3, 3]
    p_camera = transform_points(invert_T(T_template_camera), p_template[None])[0]
    np.testing.assert_allclose(T_camera_grasp[:3, 3], p_camera, atol=1e-12)
    np.testing.assert_allclose(T_template_camera @ T_camera_grasp, T_template_grasp, atol=1e-12)


def test_transfer_grasp_hand_eye_and_scale():
    rng = np.random.default_rng(1)
    T_template_camera = make_T(random_rotation(rng), rng.normal(size=3))
    T_template_grasp = make_T(random_rotation(rng), rng.normal(size=3))
    T_gripper_camera = make_T(random_rotation(rng), np.array([0.05, 0.0, 0.1]))
    out = transfer_grasp(T_template_grasp, T_template_camera, T_gripper_camera, scale=0.2)
    T_tc, T_tg = T_template_camera.copy(), T_template_grasp.copy()
    T_tc[:3, 3] *= 0.2
    T_tg[:3, 3] *= 0.2
    np.testing.assert_allclose(out, T_gripper_camera @ np.linalg.inv(T_tc) @ T_tg, atol=1e-12)
    # Identity estimate and hand-eye: the grasp is returned unchanged.
    np.testing.assert_allclose(transfer_grasp(T_template_grasp, np.eye(4), np.eye(4)), T_template_grasp)


def test_transfer_grasp_rejects_bad_input():
    with pytest.raises(InvalidInputError):
        transfer_grasp(np.eye(3), np.eye(4))
    with pytest.raises(InvalidInputError):
        transfer_grasp(np.eye(4), np.eye(4), scale=0.0)
