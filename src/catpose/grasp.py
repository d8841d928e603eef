"""Grasp transfer (the paper's robot application, Section IV-D).

A grasp is defined once in the template frame (``T_template_grasp``: the gripper pose at grasp
time, expressed in the template's canonical frame). After registering the observed view to the
template, the estimate ``T_template_camera`` carries it into the camera frame:

    T_camera_grasp = inv(T_template_camera) @ T_template_grasp

With the hand-eye calibration ``T_gripper_camera`` (the camera pose in the current gripper
frame), the grasp in the current gripper frame, i.e. the relative motion to command, is

    T_gripper_grasp = T_gripper_camera @ T_camera_grasp

Translations are in the template's unit; a template normalised to the unit bounding sphere
needs ``scale`` (metres per template unit, e.g. the object's bounding radius) to command a robot.
"""

from __future__ import annotations

import numpy as np

from catpose.geometry import compose_T, invert_T
from catpose.types import validate_pose


def transfer_grasp(
    T_template_grasp: np.ndarray,
    T_template_camera_est: np.ndarray,
    T_gripper_camera: np.ndarray | None = None,
    scale: float = 1.0,
) -> np.ndarray:
    """Map a grasp defined on the template into the camera (or current gripper) frame.

    Args:
        T_template_grasp: (4, 4) grasp pose in the template frame.
        T_template_camera_est: (4, 4) estimated camera pose in the template frame (a method's
            ``RegistrationResult.T_template_camera``).
        T_gripper_camera: optional (4, 4) hand-eye transform (camera pose in the gripper frame,
            translation in metres). When given, the result is ``T_gripper_grasp``.
        scale: metres per template unit; multiplies the translations of the two template-frame
            poses before composing (1.0 when they are already metric).

    Returns:
        (4, 4) ``T_camera_grasp``, or ``T_gripper_grasp`` when ``T_gripper_camera`` is given.
    """
    T_tg = validate_pose("T_template_grasp", T_template_grasp).copy()
    T_tc = validate_pose("T_template_camera_est", T_template_camera_est).copy()
    if not np.isfinite(scale) or scale <= 0:
        from catpose.errors import InvalidInputError

        raise InvalidInputError(f"grasp scale {scale} must be a positive number of metres per template unit")
    T_tg[:3, 3] *= scale
    T_tc[:3, 3] *= scale
    T_camera_grasp = compose_T(invert_T(T_tc), T_tg)
    if T_gripper_camera is None:
        return T_camera_grasp
    return compose_T(validate_pose("T_gripper_camera", T_gripper_camera), T_camera_grasp)
