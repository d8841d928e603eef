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
    """Estimate the camera pose ``T_template_camera`` of a view of an object.

    Args:
        observation: the view, camera frame, in the template's unit: an (N, 3) array of the
            object's surface points (segmented: only the object), or a
            :class:`~catpose.depth_frame.DepthFrame` (depth image, camera matrix, the object's
            mask). A frame goes the way ``bench run`` takes a BOP frame (the same code): its
            mask's pixels back-projected, the table plane fitted to the depth outside the mask for
            ``up`` when ``up`` is None, and the whole depth image checked by ours' depth check.
        template: the object or category template in its own frame: an (M, 3) point array, a
            ``trimesh.Trimesh``, a ``(vertices (V, 3), faces (F, 3))`` pair, the path of an OFF,
            OBJ or PLY mesh, or a :class:`~catpose.api.inputs.NormalisedTemplate`. A mesh is
            sampled on its outer surface (``template_points``).
        method: a config name, ``ours`` (the paper's method), ``icp``, ``fgr``, ``ransac``,
            ``teaser`` (``configs/method/<name>.yaml``, built as ``bench run`` builds it), or a
            :class:`~catpose.methods.method.RegistrationMethod` instance.
        up: the template's up direction (``template_up``) seen in the camera frame, i.e. the
            ground plane's normal pointing away from the ground (3,). ICP and the FPFH/PFH
            baselines do not use it. Ours does (LPS descriptor frames and its gravity filter):
            without it (and without a frame with a mask to fit the table to), ours is run once
            per direction of ``up_hypotheses`` spread over the sphere and the best-scoring answer
            is kept, which costs up to ``up_hypotheses`` times the time and can be less accurate
            (figures: docs/api.md, quoting ``results/api/without_up_*.md``).
        observation_normals: (N, 3) normals of an array ``observation`` (any orientation: they
            are turned towards the camera), or None to estimate them by local plane fits (radius
            0.1 template radii, as the datasets do).
        template_normals: (M, 3) outward normals of a point-cloud template, or None to estimate
            them (oriented away from the template's bounding-box centre: right for convex-ish
            shapes; pass them for shapes with deep concavities).
        template_up: the template's up axis in its own frame (default +z).
        max_points: the observation keeps at most this many points (seeded random subset, after
            normal estimation; 0 keeps all), as the datasets do.
        template_points: points sampled on a mesh template, or kept of a cloud template (at most
            :data:`~catpose.api.inputs.MAX_TEMPLATE_POINTS`).
        up_hypotheses: up directions tried when ``up`` is None and the method needs one.
        plane_distance: a frame's table-plane RANSAC inlier distance, frame unit (None: 1% of the
            median depth outside the mask; ``bench run`` on BOP: 10 mm).
        **options: method options as in ``bench run`` (``method.<key>=<value>``), e.g.
            ``voxel_size=0.05`` (icp), ``selection={"gravity_max_deg": None}`` or
            ``descriptor="pfh"`` (ours). Ignored when ``method`` is an instance (pass none).

    Returns:
        a :class:`Registration` in the caller's frames and unit.

    Raises:
        InvalidInputError: a bad argument, in one line naming it and the fix.
        RegistrationFailed: the method gave no pose for valid input.

    Warns:
        UserWarning: the observation spans more than 2 or less than 0.1 template radii (two
        units, or more than the object), with the ratio; the answer is
        :attr:`~Registration.ambiguous` (a runner-up lost by less than
        :data:`~catpose.api.result.AMBIGUOUS_MARGIN`), in one line.

    Deterministic: the same inputs give the same answer (the global NumPy, torch and Open3D
    seeds are set before each method call, as ``bench run`` does per sample).
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
