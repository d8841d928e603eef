"""The types every part of catpose shares.

Frames are named in fields: ``camera`` is the depth camera's optical frame (x right, y down,
z forward, OpenCV convention), ``template`` is the category template's canonical frame
(z up, x forward), ``object`` is the observed instance's canonical frame (the same convention;
category-level alignment makes ``T_template_object`` the identity). ``T_a_b`` maps points
from frame ``b`` into frame ``a``: ``p_a = T_a_b @ p_b``.

Lengths are in the object-normalised unit: every shape is centred at its bounding-box centre
and scaled so that its farthest vertex lies at distance 1 (unit bounding sphere). Translation
errors are in that unit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from catpose.errors import InvalidInputError
from catpose.geometry import norm3, unit3


def points_arg(name: str, value: Any, min_points: int = 10) -> np.ndarray:
    """``value`` as an (N, 3) float64 array of finite numbers with at least ``min_points`` rows, or
    a one-line :class:`InvalidInputError` naming ``name``."""
    if value is None:
        raise InvalidInputError(f"{name} is missing; pass an (N, 3) array")
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} is a {type(value).__name__}, not an (N, 3) array of numbers") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise InvalidInputError(f"{name} has shape {a.shape}; expected (N, 3)")
    if min_points and len(a) == 0:
        raise InvalidInputError(f"{name} has no points; the view or file is empty")
    if not np.isfinite(a).all():
        bad = int((~np.isfinite(a).all(axis=1)).sum())
        raise InvalidInputError(f"{name} has {bad} rows with NaN or inf; drop them first")
    if len(a) < min_points:
        raise InvalidInputError(f"{name} has {len(a)} points; at least {min_points} are needed")
    return a


def validate_cloud(
    name: str, points: np.ndarray, normals: np.ndarray | None = None, min_points: int = 10
) -> tuple[np.ndarray, np.ndarray | None]:
    """Check a cloud (and its normals) and return them as float64 arrays.

    Raises :class:`InvalidInputError` with one line naming ``name`` when the cloud is empty,
    has fewer than ``min_points`` points, contains NaN/inf, or is degenerate (all points equal
    or collinear: no rigid pose can be recovered from it), or when the normals do not match.
    """
    p = points_arg(name, points, min_points)
    extent = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    scale = max(float(np.abs(p).max()), 1e-12)
    if extent[0] <= 1e-9 * scale * np.sqrt(len(p)):
        raise InvalidInputError(f"{name} is degenerate: all {len(p)} points are equal")
    if extent[1] <= 1e-9 * scale * np.sqrt(len(p)):
        raise InvalidInputError(f"{name} is degenerate: all points lie on one line")
    n = None
    if normals is not None:
        n = points_arg(f"{name} normals", normals, 1)
        if n.shape != p.shape:
            raise InvalidInputError(f"{name} normals have shape {n.shape}; expected {p.shape}")
        norms = np.linalg.norm(n, axis=1)
        if (norms < 1e-8).any():
            raise InvalidInputError(f"{name} has {int((norms < 1e-8).sum())} zero-length normals; re-estimate them")
        n = n / norms[:, None]
    return p, n


@dataclass(frozen=True, eq=False)
class Template:
    """A category template (or an instance's own complete model) in the template frame.

    Attributes:
        template_id: unique id, e.g. ``"synthetic/chair/t0"`` or ``"modelnet40/chair_0001"``.
        category: category name.
        points: (M, 3) complete surface samples, template frame, object-normalised unit.
        normals: (M, 3) outward unit normals of ``points``.
        vertices: (V, 3) mesh vertices, or None when only a cloud is known.
        triangles: (F, 3) int mesh faces, or None.
        up: (3,) unit up axis in the template frame (z for every built-in set).
        symmetry_axis: (3,) main axis of a rotationally symmetric category, or None.
    """

    template_id: str
    category: str
    points: np.ndarray
    normals: np.ndarray
    vertices: np.ndarray | None = None
    triangles: np.ndarray | None = None
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    symmetry_axis: np.ndarray | None = None

    def __post_init__(self) -> None:
        p, n = validate_cloud(f"template {self.template_id}", self.points, self.normals)
        object.__setattr__(self, "points", p)
        object.__setattr__(self, "normals", n)

    @property
    def has_mesh(self) -> bool:
        return self.vertices is not None and self.triangles is not None


@dataclass(frozen=True, eq=False)
class DepthImage:
    """The depth image an observed cloud was cut from, for occlusion-aware verification.

    Attributes:
        depth: (H, W) camera-frame z of every pixel, in the unit of the problem's
            ``points_camera`` (the object-normalised unit); 0 where nothing was measured. It is the
            whole scene: other objects, the table, the background.
        K: (3, 3) pinhole intrinsics, pixels: pixel (row, col) sees the ray
            ``((col - cx) / fx, (row - cy) / fy, 1)`` (OpenCV, as :func:`catpose.datasets.render.depth_to_points`).
        mask: (H, W) bool, the object's visible pixels (the segmentation its points came from).
    """

    depth: np.ndarray
    K: np.ndarray
    mask: np.ndarray

    def __post_init__(self) -> None:
        d = np.asarray(self.depth, dtype=np.float64)
        if d.ndim != 2 or d.size == 0:
            raise InvalidInputError(f"depth image has shape {d.shape}; expected (H, W)")
        if not np.isfinite(d).all() or (d < 0).any():
            raise InvalidInputError("depth image has NaN, inf or negative values; use 0 for missing depth")
        K = np.asarray(self.K, dtype=np.float64).reshape(3, 3)
        if not np.isfinite(K).all() or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise InvalidInputError(
                f"depth image intrinsics K have focal lengths {K[0, 0]}, {K[1, 1]}; they must be positive pixels"
            )
        m = np.asarray(self.mask, dtype=bool)
        if m.shape != d.shape:
            raise InvalidInputError(f"depth image mask is {m.shape} but the depth image is {d.shape}")
        object.__setattr__(self, "depth", d)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "mask", m)


@dataclass(frozen=True, eq=False)
class RegistrationProblem:
    """What a method sees: a partial view in the camera frame and a template.

    Attributes:
        sample_id: unique id of this problem in its dataset and protocol.
        category: category name.
        points_camera: (N, 3) observed points, camera frame.
        normals_camera: (N, 3) unit normals of ``points_camera``, oriented towards the camera.
        ground_normal_camera: (3,) unit up direction (the ground plane's normal) in the camera frame.
        template: the template to register to.
        meta: dataset-specific, method-independent facts (never ground truth).
        depth_image: the depth image, intrinsics and object mask the cloud came from
            (:class:`DepthImage`), or None (a point cloud without an image, e.g. ModelNet40's
            resampled clouds). Methods may use it to verify poses; none needs it.
    """

    sample_id: str
    category: str
    points_camera: np.ndarray
    normals_camera: np.ndarray
    ground_normal_camera: np.ndarray
    template: Template
    meta: Mapping[str, Any] = field(default_factory=dict)
    depth_image: DepthImage | None = None

    def __post_init__(self) -> None:
        if self.depth_image is not None and not isinstance(self.depth_image, DepthImage):
            raise InvalidInputError(
                f"sample {self.sample_id}: depth_image is a {type(self.depth_image).__name__}; "
                "pass a catpose.types.DepthImage or None"
            )
        p, n = validate_cloud(f"sample {self.sample_id}: observed cloud", self.points_camera, self.normals_camera)
        object.__setattr__(self, "points_camera", p)
        object.__setattr__(self, "normals_camera", n)
        g = np.asarray(self.ground_normal_camera, dtype=np.float64).reshape(-1)
        if g.shape != (3,) or not np.isfinite(g).all() or norm3(g) < 1e-8:
            raise InvalidInputError(f"sample {self.sample_id}: ground normal {g} is not a finite non-zero 3-vector")
        object.__setattr__(self, "ground_normal_camera", unit3(g))


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """What only the evaluation sees.

    Attributes:
        T_template_camera: (4, 4) true pose of the camera in the template frame.
        symmetry_axis: (3,) main axis in the template frame for rotationally symmetric
            objects (scored by main-axis error), else None.
        symmetries: discrete symmetries, (4, 4) transforms ``S`` of the template frame that
            map the object onto itself (BOP ``symmetries_discrete``); ``S @ T_template_camera``
            is as correct as ``T_template_camera`` and the error is the minimum over them.
    """

    T_template_camera: np.ndarray
    symmetry_axis: np.ndarray | None = None
    symmetries: tuple = ()


@dataclass(frozen=True, eq=False)
class Sample:
    """One evaluated problem: the method's input and, kept apart, the ground truth.

    ``group_id`` ties problems that the protocol scores together (the K templates of one view,
    the two views of a relative pair); ``info`` holds protocol and dataset facts written to the
    per-sample table (instance id, view id, template id, which mask was used, ...).
    """

    problem: RegistrationProblem
    gt: GroundTruth
    group_id: str = ""
    info: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class RegistrationResult:
    """A method's answer.

    Attributes:
        T_template_camera: (4, 4) the estimated pose: it maps camera-frame points into the
            template frame, ``p_template = R @ p_camera + t``.
        score: the method's own final loss (lower is better) used to choose among templates;
            NaN when the method has none.
        runtime_s: wall-clock seconds of the registration (set by the runner).
        extras: method-specific, JSON-serialisable details (chosen template index, per-stage
            timings, per-template losses, ...); a method that names its next-best other answer
            puts it in ``extras["runner_up"]`` (:attr:`runner_up`).
        candidates_T: (K, 4, 4) every hypothesis the method scored before choosing (ours: one
            per partial template; ICP: one per start; correspondence baselines: one per target),
            same frames as ``T_template_camera``; None when the method has none. Kept in memory
            only (``catpose.register`` returns them); run files do not store them.
        candidate_scores: (K,) their scores in the method's own criterion (lower is better; inf:
            excluded, e.g. by ours' gravity filter), or None.
    """

    T_template_camera: np.ndarray
    score: float = float("nan")
    runtime_s: float = float("nan")
    extras: Mapping[str, Any] = field(default_factory=dict)
    candidates_T: np.ndarray | None = None
    candidate_scores: np.ndarray | None = None

    @property
    def runner_up(self) -> tuple[np.ndarray, float] | None:
        """The method's next-best other answer, read from ``extras["runner_up"]``
        (``{"T_template_camera": 4 x 4, "margin": float, ...}``): its (4, 4) pose, same frames as
        ``T_template_camera``, and its margin (its score minus the answer's); None when the
        method names none."""
        second = self.extras.get("runner_up")
        if not isinstance(second, Mapping) or "T_template_camera" not in second:
            return None
        return np.asarray(second["T_template_camera"], dtype=float).reshape(4, 4), float(second["margin"])
