"""What the datasets that draw their own views share: their option groups, the seeded subset of
the points kept and the observation they assemble.

An option group (:class:`~catpose.datasets.dataset.OptionGroup`) is a frozen dataclass that a
dataset's constructor takes as one argument (``view: ViewOptions``) while its config gives the
fields as flat keys of the group (``dataset.distance=4``): the builder
(:func:`catpose.bench.run.build.build_from_config`) gathers the keys of every option-group argument
into it, over the constructor's default. So the views of ``synthetic``, ``modelnet40`` and
``modelnet40_resampled`` are drawn from one set of knobs with one default each
(the templates' group: :class:`~catpose.datasets.templates.TemplateOptions`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from catpose import libm
from catpose.datasets.dataset import Observation, OptionGroup
from catpose.datasets.render import PinholeCamera, check_intrinsics, estimate_normals
from catpose.errors import ConfigError
from catpose.geometry import axis_angle_to_R, compose_T, invert_T, look_at_T_camera_world, make_T
from catpose.types import DepthImage


@dataclass(frozen=True)
class ViewOptions(OptionGroup):
    """Where the camera is and what a view keeps: viewpoints around an object at the origin of its
    canonical frame (z up), looking at the origin.

    Attributes:
        distance: camera distance from the object centre (object-normalised unit; > 1, outside the
            unit bounding sphere).
        elevation_min_deg, elevation_max_deg: camera elevation above the ground plane, degrees,
            drawn uniformly; azimuth is uniform in [0, 360).
        roll_max_deg: camera roll about its optical axis, uniform in [-roll, roll] degrees.
        depth_noise_std: std of zero-mean Gaussian depth noise (object-normalised unit; 0: clean).
        max_points: keep at most this many observed points (seeded random subset; 0: all).
    """

    distance: float = 3.0
    elevation_min_deg: float = 10.0
    elevation_max_deg: float = 60.0
    roll_max_deg: float = 0.0
    depth_noise_std: float = 0.0
    max_points: int = 2048

    def __post_init__(self) -> None:
        # checked once here, not discovered as every sample failing (issue 42, case 20)
        if self.distance <= 1.0:
            raise ConfigError(
                f"dataset.distance={self.distance} puts the camera inside the unit bounding sphere; use a "
                "distance > 1 (e.g. 3)"
            )
        if not 0.0 <= float(self.elevation_min_deg) <= float(self.elevation_max_deg) < 90.0:
            raise ConfigError(
                f"dataset.elevation_min_deg={self.elevation_min_deg} and dataset.elevation_max_deg="
                f"{self.elevation_max_deg}: they must satisfy 0 <= elevation_min_deg <= elevation_max_deg < 90 "
                "(degrees above the ground plane)"
            )
        if not 0.0 <= float(self.depth_noise_std) < float("inf"):
            raise ConfigError(f"dataset.depth_noise_std={self.depth_noise_std} must be >= 0 (0: clean depth)")
        if not 0.0 <= float(self.roll_max_deg) <= 180.0:
            raise ConfigError(f"dataset.roll_max_deg={self.roll_max_deg}: pass a roll in [0, 180] degrees")

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """Draw one viewpoint; returns ``T_camera_object`` (4, 4)."""
        az = np.deg2rad(rng.uniform(0.0, 360.0))
        el = np.deg2rad(rng.uniform(self.elevation_min_deg, self.elevation_max_deg))
        roll = np.deg2rad(rng.uniform(-self.roll_max_deg, self.roll_max_deg)) if self.roll_max_deg > 0 else 0.0
        eye = self.distance * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        T = look_at_T_camera_world(eye, np.zeros(3), np.array([0.0, 0.0, 1.0]))
        if roll:
            T = compose_T(make_T(axis_angle_to_R(np.array([0.0, 0.0, 1.0]), roll), np.zeros(3)), T)
        return T


@dataclass(frozen=True)
class ImageOptions(OptionGroup):
    """The depth image a rendered view is made of and what it must show.

    Attributes:
        width, height: image size in pixels.
        fx, fy: pinhole focal lengths in pixels.
        cx, cy: principal point in pixels; None: the image centre (``(width - 1) / 2``, ``(height - 1) / 2``).
        fov_deg: if set, the horizontal field of view in degrees; overrides ``fx`` and ``fy`` (square pixels).
        normal_radius: normal-estimation radius (object-normalised unit).
        min_points: a view with fewer visible points raises :class:`~catpose.errors.DatasetError`.
    """

    width: int = 320
    height: int = 240
    fx: float = 300.0
    fy: float = 300.0
    cx: float | None = None
    cy: float | None = None
    fov_deg: float | None = None
    normal_radius: float = 0.1
    min_points: int = 50

    def camera(self) -> PinholeCamera:
        """The pinhole camera (:func:`pinhole_camera`, ``fov_deg`` applied)."""
        check_intrinsics("dataset", width=self.width, height=self.height)
        if not 1 <= int(self.min_points) <= int(self.width) * int(self.height):
            raise ConfigError(
                f"dataset.min_points={self.min_points} must be in 1..{int(self.width) * int(self.height)} (the image's pixels)"
            )
        fx, fy = self.fx, self.fy
        if self.fov_deg is not None:
            if not 0.0 < self.fov_deg < 180.0:
                raise ConfigError(f"dataset.fov_deg={self.fov_deg}; use a value in (0, 180)")
            fx = fy = 0.5 * self.width / libm.tan(np.deg2rad(self.fov_deg) / 2)
        return pinhole_camera(self.width, self.height, fx, fy, self.cx, self.cy)


def pinhole_camera(
    width: int, height: int, fx: float, fy: float, cx: float | None = None, cy: float | None = None
) -> PinholeCamera:
    """A pinhole camera (image size and focal lengths checked: :func:`~catpose.datasets.render.check_intrinsics`)
    whose principal point defaults to the centre of the pixel grid (``(width - 1) / 2``, ``(height - 1) / 2``)."""
    check_intrinsics("dataset", width=width, height=height, fx=fx, fy=fy)
    width, height = int(width), int(height)
    return PinholeCamera(
        width,
        height,
        float(fx),
        float(fy),
        float((width - 1) / 2 if cx is None else cx),
        float((height - 1) / 2 if cy is None else cy),
    )


def check_counts(**counts: int | None) -> None:
    """One-line :class:`ConfigError` for a count below 1 (None means "all" and passes): with
    ``views_per_instance=0`` there would be no sample, and the error would blame ``dataset.root``."""
    for key, n in counts.items():
        if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
            raise ConfigError(
                f"dataset.{key}={n!r} must be an integer >= 1; set dataset.{key}=<N>"
                + (" (or null for all)" if key == "instances_per_category" else "")
            )


def subsample(max_points: int, rng: np.random.Generator, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """At most ``max_points`` rows of ``arrays`` (each (N, ...), the same rows of each): a seeded
    subset in their order (0 or N <= ``max_points``: all, and ``rng`` is not drawn from)."""
    n = len(arrays[0])
    if max_points and n > max_points:
        keep = np.sort(rng.choice(n, size=max_points, replace=False))
        return tuple(a[keep] for a in arrays)
    return arrays


def kept_view(
    points: np.ndarray, max_points: int, normal_radius: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The points a view keeps (:func:`subsample`) and their normals, estimated from the kept points as a
    method would estimate them from a downsampled scan: the order every rendered dataset uses
    (render, noise, subsample, normals)."""
    (points,) = subsample(max_points, rng, points)
    return points, estimate_normals(points, normal_radius)


def view_observation(
    obs_id: str,
    points_camera: np.ndarray,
    normals_camera: np.ndarray,
    ground_normal_camera: np.ndarray,
    T_camera_object: np.ndarray,
    symmetry_axis: np.ndarray | None,
    info: Mapping[str, Any],
    depth_image: DepthImage | None = None,
) -> Observation:
    """The observation of a drawn view whose id is ``<category>/<instance_id>/<view>``: camera frame,
    object-normalised unit, ``T_camera_object`` (4, 4) the object's pose in the camera."""
    category, instance_id, _ = obs_id.split("/")
    return Observation(
        obs_id=obs_id,
        category=category,
        instance_id=instance_id,
        points_camera=points_camera,
        normals_camera=normals_camera,
        ground_normal_camera=ground_normal_camera,
        T_object_camera=invert_T(T_camera_object),
        symmetry_axis=symmetry_axis,
        depth_image=depth_image,
        info=info,
    )
