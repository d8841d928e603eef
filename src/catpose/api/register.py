"""``catpose.register``: one call from an observed view and a template to a camera pose, in the
caller's frames and unit (the methods' answer ``T_n`` in the normalised frames maps back as
``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``, see :mod:`catpose.api.inputs`). It is a one-off
:class:`~catpose.api.registrar.Registrar`; hold one to register many views of one template."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

from catpose.api.registrar import UP_HYPOTHESES, Registrar
from catpose.api.result import Registration

__all__ = ["Registration", "register", "UP_HYPOTHESES"]


def register(
    observation: Any,
    template: Any,
    method: str | Any = "ours",
    up: Sequence[float] | None = None,
    *,
    observation_normals: Any = None,
    template_normals: Any = None,
    template_up: Sequence[float] = (0.0, 0.0, 1.0),
    max_points: int = 2048,
    template_points: int = 2048,
    up_hypotheses: int = UP_HYPOTHESES,
    plane_distance: float | None = None,
    **options: Any,
) -> Registration:
    """Estimate the camera pose ``T_template_camera`` of a view of an object (each argument in
    full: docs/api.md).

    Args:
        observation: the view, camera frame, in the template's unit: (N, 3) points of the object
            only, or a :class:`~catpose.depth_frame.DepthFrame` (taken the way ``bench run`` takes
            a BOP frame: the mask back-projected, the table fitted for ``up``, the depth checked).
        template: the template in its own frame: (M, 3) points, a ``trimesh.Trimesh``, a
            ``(vertices, faces)`` pair, an OFF/OBJ/PLY path (a mesh is sampled on its outer
            surface), or a :class:`~catpose.api.inputs.NormalisedTemplate`.
        method: a registered method's config name (``configs/method/<name>.yaml``, built as
            ``bench run`` builds it) or a :class:`~catpose.methods.method.RegistrationMethod`.
        up: the template's up (``template_up``) seen in the camera frame (3,); None: fitted to a
            frame's table, else searched over ``up_hypotheses`` directions where the method
            reads it (slower, can be less accurate: docs/api.md).
        observation_normals, template_normals: (N, 3) / (M, 3) normals, or None to estimate them
            (towards the camera; away from the template's centre).
        template_up: the template's up axis in its own frame.
        max_points, template_points: points kept of the observation (0: all) and of the template.
        up_hypotheses: up directions tried when ``up`` is None and the method needs one.
        plane_distance: a frame's table-plane inlier distance, frame unit (None: 1% of the
            median depth outside the mask).
        **options: method options as in ``bench run`` (``voxel_size=0.05``,
            ``selection={"gravity_max_deg": None}``, ``descriptor="pfh"``); none for an instance.

    Returns:
        a :class:`Registration` in the caller's frames and unit.

    Raises:
        InvalidInputError: a bad argument, in one line naming it and the fix.
        RegistrationFailed: the method gave no pose for valid input.

    Warns:
        UserWarning: the observation spans more than 2 or less than 0.1 template radii (two
        units, or more than the object), or the answer is :attr:`~Registration.ambiguous`.

    Deterministic: the global NumPy, torch and Open3D seeds are set before each method call, as
    ``bench run`` does per sample.
    """
    registrar = Registrar(
        template,
        method,
        template_normals=template_normals,
        template_up=template_up,
        template_points=template_points,
        prepare=False,
        **options,
    )
    result = registrar(
        observation,
        up,
        observation_normals=observation_normals,
        max_points=max_points,
        up_hypotheses=up_hypotheses,
        plane_distance=plane_distance,
        _stacklevel=3,
    )
    doubt = result.doubt()
    if doubt is not None:
        warnings.warn(doubt, UserWarning, stacklevel=2)
    return result
