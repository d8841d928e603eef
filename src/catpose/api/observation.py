"""The observation of :func:`catpose.register` in the methods' unit: an (N, 3) cloud of the object
or a :class:`~catpose.depth_frame.DepthFrame`, divided by the template's radius, with its normals,
its ground normal (given, fitted to the frame's table, or left to the up search) and, for a frame,
the depth image of ours' depth check.

A frame goes through :func:`catpose.datasets.frame_view.frame_view`, the function the BOP loader
calls for every instance of ``bench run``: with the same frame, template and settings the method
sees the same problem.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.api.inputs import (
    NormalisedTemplate,
    check_position,
    estimated_normals,
    normals_arg,
    oriented_to_camera,
)
from catpose.depth_frame import DepthFrame
from catpose.errors import InvalidInputError
from catpose.geometry import norm3, stable_seed
from catpose.types import DepthImage, points_arg

__all__ = ["Observed", "observed"]

#: the sample id and per-call seed of an observation given as points (frames: their frame_id, seed)
POINTS_SAMPLE_ID = "catpose.register"


@dataclass(frozen=True, eq=False)
class Observed:
    """An observation ready for the methods (object-normalised unit, camera frame).

    Attributes:
        points: (N, 3) the object's points; ``normals`` (N, 3) unit normals facing the camera.
        ground: (3,) the up direction to use, or None: unknown (the up search decides).
        depth_image: the frame's depth image (ours' depth check), or None for points.
        sample_id: the problem's id (a frame's ``frame_id``); ``seed``: the global seed of each call.
        radius: the observation's bounding-box half diagonal, template radii (the unit check).
        facts: ``ground`` (``given``, ``plane`` or ``search``) and a frame's ``visible_pixels``
            and ``ground_inliers``.
    """

    points: np.ndarray
    normals: np.ndarray
    ground: np.ndarray | None
    depth_image: DepthImage | None
    sample_id: str
    seed: int
    radius: float
    facts: dict[str, Any] = field(default_factory=dict)


def _radius(points: np.ndarray) -> float:
    """Half the diagonal of the box holding the central 95 % of ``points`` on each axis: a mask's
    few stray pixels (depth seen past the object's edge, on real frames 1-2 % of the mask, 340 mm
    behind a YCB-V mustard bottle) do not make a view span several template radii."""
    lo, hi = np.percentile(points, [2.5, 97.5], axis=0)
    return float(0.5 * norm3(hi - lo))


def observed(
    observation: Any,
    template: NormalisedTemplate,
    *,
    up: np.ndarray | None,
    observation_normals: Any,
    max_points: int,
    plane_distance: float | None,
) -> Observed:
    """``observation`` (an (N, 3) array or a :class:`DepthFrame`) for ``template``'s methods.

    Raises:
        InvalidInputError: a bad argument, in one line naming it.
    """
    if isinstance(observation, DepthFrame):
        if observation_normals is not None:
            raise InvalidInputError(
                "observation_normals applies to a point array; a DepthFrame's normals are estimated from its depth"
            )
        return _from_frame(observation, template, up, max_points, plane_distance)
    if plane_distance is not None:
        raise InvalidInputError("plane_distance applies to a DepthFrame (its table plane); drop it for a point array")
    pts = points_arg("observation", observation)
    check_position("observation", pts)
    obs_normals = normals_arg("observation_normals", observation_normals, pts)
    points = pts / template.scale
    normals = oriented_to_camera(points, obs_normals) if obs_normals is not None else estimated_normals(points)
    radius = _radius(points)
    from catpose.datasets.views import subsample

    rng = np.random.default_rng(stable_seed("catpose.register", "observation"))
    points, normals = subsample(int(max_points), rng, points, normals)
    return Observed(
        points, normals, up, None, POINTS_SAMPLE_ID, 0, radius, {"ground": "search" if up is None else "given"}
    )


def _from_frame(
    frame: DepthFrame,
    template: NormalisedTemplate,
    up: np.ndarray | None,
    max_points: int,
    plane_distance: float | None,
) -> Observed:
    """A frame through :func:`~catpose.datasets.frame_view.frame_view`: the table plane is fitted
    outside the mask when ``up`` is None and the frame has a mask; without a mask the up search
    decides (no pixel is known to be the table)."""
    from catpose.datasets.frame_view import FrameSettings, NoGroundPlane, frame_view

    if plane_distance is not None and not (
        isinstance(plane_distance, (int, float, np.integer, np.floating))
        and not isinstance(plane_distance, bool)
        and np.isfinite(plane_distance)
        and plane_distance > 0
    ):
        raise InvalidInputError(f"plane_distance={plane_distance!r} must be a positive length in the frame's unit")
    settings = FrameSettings(max_points=int(max_points), plane_distance=plane_distance)
    search = up is None and frame.mask is None
    given = up if up is not None else (np.array([0.0, -1.0, 0.0]) if search else None)
    try:
        view = frame_view(frame, template.scale, settings, up_camera=given, source="frame")
    except NoGroundPlane as e:
        raise InvalidInputError(f"{e}; pass up (the table's normal in the camera frame)") from None
    points = view.points_camera
    if len(points) < 10:
        raise InvalidInputError(
            f"frame: the mask's pixels with depth give {len(points)} points; at least 10 are needed"
        )
    check_position("frame", points)
    ground_source = "search" if search else ("given" if up is not None else "plane")
    facts = {"ground": ground_source, "visible_pixels": view.visible_pixels}
    if ground_source == "plane":
        facts["ground_inliers"] = view.ground_inliers
    return Observed(
        points,
        view.normals_camera,
        None if search else view.ground_normal_camera,
        view.depth_image,
        frame.frame_id,
        stable_seed(frame.seed, frame.frame_id),
        _radius(points),
        facts,
    )
