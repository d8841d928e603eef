"""A depth frame (:class:`~catpose.depth_frame.DepthFrame`) as what a method sees: the object's
points and normals, the ground normal and the depth image, in the object-normalised unit.

This is the one path from a depth frame to a registration problem: the BOP loader
(:mod:`catpose.datasets.bop`, so ``bench run`` on ycbv, tyol and clutter) and
``catpose.register`` (:mod:`catpose.api`) both call :func:`frame_view`. Steps:

1. back-projection of the mask's pixels with a measurement
   (:func:`catpose.datasets.render.depth_to_points`), divided by the template's radius ``scale``
   (the frame's unit -> the object-normalised unit; the camera stays at the origin);
2. the ground normal, unless given: the dominant plane of the measured depth outside the mask
   (and outside ``exclude``), by seeded RANSAC on at most ``plane_max_points`` of its points
   (:func:`catpose.datasets.depthio.fit_ground_plane`), oriented towards the camera;
3. normals by local plane fits of radius ``normal_radius`` (object unit), facing the camera;
4. at most ``max_points`` points (a seeded random subset);
5. the whole depth image in the object unit with the object's mask (``DepthImage``), for ours'
   depth check.

No outlier removal is done on the way (the depth check of ``ours`` is what copes with the stray
pixels a mask lets through). Random subsets are seeded from ``frame.seed`` and ``frame.frame_id``
with the tags the BOP loader always used, so its observations did not move when it came here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose.datasets.depthio import fit_ground_plane
from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals
from catpose.datasets.views import subsample
from catpose.depth_frame import DepthFrame
from catpose.errors import InvalidInputError
from catpose.geometry import stable_seed
from catpose.types import DepthImage

__all__ = ["FrameSettings", "FrameView", "NoGroundPlane", "frame_view"]


class NoGroundPlane(InvalidInputError):
    """The frame shows too little outside the object's mask to fit the table plane."""


@dataclass(frozen=True)
class FrameSettings:
    """How a frame becomes a view (the defaults of ``catpose.register``; ``bench run`` passes its
    dataset config's values, ``configs/dataset/bop.yaml``).

    Attributes:
        normal_radius: normal-estimation radius, object-normalised unit (template radii).
        max_points: points kept (seeded random subset; 0: all).
        plane_distance: RANSAC inlier distance of the table-plane fit, in the frame's unit (after
            ``depth_scale``); None: 1% of the median measured depth outside the mask (10 mm at 1 m,
            the scale of a depth sensor's noise there; the BOP configs' 10 mm).
        plane_iterations: RANSAC iterations.
        plane_max_points: background points the fit uses (seeded random subset).
        min_plane_points: fewer measured background pixels cannot give a plane.
    """

    normal_radius: float = 0.1
    max_points: int = 2048
    plane_distance: float | None = None
    plane_iterations: int = 1000
    plane_max_points: int = 20000
    min_plane_points: int = 100


@dataclass(frozen=True, eq=False)
class FrameView:
    """A frame's object as a method's input, object-normalised unit, camera frame.

    Attributes:
        points_camera: (N, 3) the object's points (at most ``max_points``).
        normals_camera: (N, 3) unit normals, facing the camera.
        ground_normal_camera: (3,) the table's normal towards the camera (fitted, or the given up).
        depth_image: the whole frame's depth / ``scale`` with the object's mask.
        visible_pixels: the mask's pixels with a measurement.
        ground_inliers: the plane fit's inliers (0 when the up direction was given).
    """

    points_camera: np.ndarray
    normals_camera: np.ndarray
    ground_normal_camera: np.ndarray
    depth_image: DepthImage
    visible_pixels: int
    ground_inliers: int


def frame_view(
    frame: DepthFrame,
    scale: float,
    settings: FrameSettings = FrameSettings(),
    *,
    up_camera: np.ndarray | None = None,
    exclude: np.ndarray | None = None,
    source: str = "frame",
) -> FrameView:
    """The view of ``frame``'s object for a template of radius ``scale`` (see the module docstring).

    Args:
        frame: the depth frame; without a mask, every measured pixel is the object.
        scale: the template's radius in the frame's unit (its object-normalised unit).
        settings: normals, subset and plane-fit settings.
        up_camera: (3,) the ground normal in the camera frame, if known (no plane fit then).
        exclude: (H, W) bool pixels left out of the plane fit besides the mask (the BOP loader's
            rendered model, where the mask was made by rendering).
        source: what names the frame in error messages (the BOP loader passes the depth file).

    Raises:
        NoGroundPlane: ``up_camera`` is None and no plane can be fitted (no mask, or fewer than
            ``min_plane_points`` measured pixels outside it); one line naming ``source``.
    """
    depth = frame.depth_in_unit
    h, w = depth.shape
    camera = PinholeCamera.from_K(frame.K, w, h)
    mask = frame.object_pixels
    points, _ = depth_to_points(depth, camera, mask)
    points = points / scale
    rng = np.random.default_rng(stable_seed(frame.seed, "bop", frame.frame_id))
    if up_camera is not None:
        ground, n_inliers = np.asarray(up_camera, np.float64), 0
    else:
        ground, n_inliers = _ground(frame, camera, mask, exclude, settings, rng, source)
    normals = estimate_normals(points, settings.normal_radius)
    points, normals = subsample(settings.max_points, rng, points, normals)
    return FrameView(points, normals, ground, DepthImage(depth / scale, frame.K, mask), int(mask.sum()), n_inliers)


def _ground(
    frame: DepthFrame,
    camera: PinholeCamera,
    mask: np.ndarray,
    exclude: np.ndarray | None,
    settings: FrameSettings,
    rng: np.random.Generator,
    source: str,
) -> tuple[np.ndarray, int]:
    """The table plane's normal (3,) towards the camera and its inlier count, fitted to the frame's
    measured depth outside the mask (and ``exclude``); frame unit."""
    if frame.mask is None:
        raise NoGroundPlane(f"{source}: no mask, so no pixel is known to be the table; cannot fit the ground plane")
    depth = frame.depth_in_unit
    background = (depth > 0) & ~mask
    if exclude is not None:
        background &= ~exclude
    bg_points, _ = depth_to_points(depth, camera, background)
    if settings.plane_max_points and len(bg_points) > settings.plane_max_points:
        bg_points = bg_points[rng.choice(len(bg_points), size=settings.plane_max_points, replace=False)]
    if len(bg_points) < settings.min_plane_points:
        raise NoGroundPlane(f"{source}: only {len(bg_points)} background pixels; cannot fit the ground plane")
    distance = settings.plane_distance
    if distance is None:
        distance = 0.01 * float(np.median(bg_points[:, 2]))
    ground, _, n_inliers = fit_ground_plane(
        bg_points, distance, settings.plane_iterations, stable_seed(frame.seed, "plane", frame.frame_id)
    )
    return ground, n_inliers
