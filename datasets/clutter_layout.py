"""Where the objects of a synthetic cluttered scene lie and where the camera looks from.

A scene is a pure function of ``(ClutterSpec, scene_id)``: its generator is seeded with
:func:`catpose.geometry.stable_seed` from the spec's ``scene_seed`` and the scene id, so any
subset of scenes, in any order, is the same scene by scene.

- **Objects**: ``objects_per_scene`` (a range) distinct models drawn from ``obj_ids``.
- **Resting pose**: with probability ``upright_prior`` the model's +z points up (the YCB-Video
  meshes stand on +z); otherwise a stable resting direction of the model
  (:func:`catpose.resting.resting_ups`: upright, upside down, on a side). ``resting=uniform``
  (the default) draws one of the model's resting classes with equal chance, a class being the
  directions a continuous symmetry makes one (a can on any side line;
  :func:`catpose.resting.rest_classes`) that a dropped object takes with probability at least
  ``rest_min_probability``, then one of the class's directions with equal chance: people set
  things down lid-up, lid-down and on each side, and no development prior should come from a
  drop test. ``resting=drop`` draws each direction with its drop-test probability (which puts
  most objects on a side: the mustard bottle stands upright with probability 0.04). Then a
  uniform yaw about the table normal.
- **Placement**: the footprint of each rested object is the convex hull of its vertices on the
  table; centres are drawn uniformly in a disc of radius ``table_radius_mm`` and a draw is
  rejected when its footprint comes within :data:`GAP_MM` of a placed one (separating axes; at
  most 200 draws, an object that does not fit is left out), so objects stand close and hide
  each other but never interpenetrate.
- **Camera**: at a distance drawn from ``distance_mm`` from the scene centre, elevation from
  ``elevation_deg`` above the table, uniform azimuth, looking at the centre of the objects with
  the table normal up in the image.

Lengths in mm (the BOP model unit), the table is the plane ``z = 0`` of the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from catpose.datasets.dataset import OptionGroup
from catpose.errors import ConfigError
from catpose.geometry import (
    R_onto_z,
    apply_R,
    axis_angle_to_R,
    compose_T,
    look_at_T_camera_world,
    make_T,
    matmul3,
    stable_seed,
)
from catpose.resting import RestingUp, rest_classes

#: the eight YCB-Video objects whose meshes the shared data has (BOP obj_ids)
YCBV_OBJECTS = (1, 4, 5, 6, 9, 12, 13, 14)

#: YCB-Video's camera (``camera.json`` of the BOP release): 640 x 480 pixels
YCBV_K = ((1066.778, 0.0, 312.9869), (0.0, 1067.487, 241.3109), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class ClutterSpec(OptionGroup):
    """Everything that decides the scenes (see the module docstring); ``dataset=clutter`` gives its
    fields as flat keys (an option group, :mod:`catpose.datasets.views`).

    Attributes:
        scene_seed: seed of every scene's generator.
        num_scenes: scenes ``0 .. num_scenes - 1``.
        obj_ids: models to draw from.
        objects_per_scene: (min, max) objects per scene, inclusive.
        upright_prior: probability of the model's +z up instead of a drawn resting direction.
        resting: ``uniform`` (each resting class alike) or ``drop`` (drop-test probabilities).
        rest_min_probability: ``uniform``: classes a dropped object takes less often than this
            are not drawn (knife-edge poses).
        table_radius_mm: objects' centres lie within this distance of the scene origin.
        distance_mm: (min, max) camera distance from the scene centre.
        elevation_deg: (min, max) camera elevation above the table.
        width, height, K: image size and pinhole intrinsics (pixels).
        sensor: depth-sensor model (:mod:`catpose.datasets.sensor`): ``kinect``, ``realsense``
            or ``none``.
        dropout_blobs: (min, max) fraction of each object's visible pixels whose depth is lost in
            patches (dark or shiny parts), drawn per object (:mod:`catpose.datasets.clutter_render`).
        mask_shift_px: (min, max) distance in pixels, drawn per scene with a uniform direction,
            between the segmentation and the depth image (depth-to-colour registration).
        annotation_mm, annotation_deg: (min, max) of the per-scene spread (standard deviation per
            axis) of the written ground truth's error: translation (mm) and rotation (degrees).
        depth_scale: written depth unit in mm (uint16 value times this; YCB-Video: 0.1).
    """

    scene_seed: int = 0
    num_scenes: int = 200
    obj_ids: tuple[int, ...] = YCBV_OBJECTS
    objects_per_scene: tuple[int, int] = (3, 6)
    upright_prior: float = 0.0
    resting: str = "uniform"
    rest_min_probability: float = 0.01
    table_radius_mm: float = 100.0
    distance_mm: tuple[float, float] = (900.0, 1250.0)
    elevation_deg: tuple[float, float] = (28.0, 48.0)
    width: int = 640
    height: int = 480
    K: tuple[tuple[float, ...], ...] = field(default=YCBV_K)
    sensor: str = "kinect"
    dropout_blobs: tuple[float, float] = (0.0, 0.15)
    mask_shift_px: tuple[float, float] = (1.0, 3.0)
    annotation_mm: tuple[float, float] = (0.0, 1.5)
    annotation_deg: tuple[float, float] = (0.0, 0.5)
    depth_scale: float = 0.1

    def __post_init__(self) -> None:
        k, set_ = "dataset.", object.__setattr__
        for key, kind in (("scene_seed", int), ("num_scenes", int), ("width", int), ("height", int)):
            set_(self, key, kind(getattr(self, key)))
        for key in ("upright_prior", "rest_min_probability", "table_radius_mm"):
            set_(self, key, float(getattr(self, key)))
        set_(self, "resting", str(self.resting))
        set_(self, "sensor", str(self.sensor))
        set_(self, "obj_ids", tuple(int(o) for o in self.obj_ids))
        set_(self, "objects_per_scene", tuple(int(n) for n in self.objects_per_scene))
        set_(self, "distance_mm", tuple(float(x) for x in self.distance_mm))
        set_(self, "elevation_deg", tuple(float(x) for x in self.elevation_deg))
        for key in ("dropout_blobs", "mask_shift_px", "annotation_mm", "annotation_deg"):
            lo, hi = (float(x) for x in getattr(self, key))
            if not 0.0 <= lo <= hi or (key == "dropout_blobs" and hi >= 1.0):
                raise ConfigError(f"{k}{key}={list(getattr(self, key))} must be [min, max] with 0 <= min <= max")
            set_(self, key, (lo, hi))
        set_(self, "K", tuple(tuple(float(x) for x in row) for row in np.asarray(self.K, float).reshape(3, 3)))
        lo, hi = self.objects_per_scene
        if not 1 <= lo <= hi <= len(self.obj_ids):
            raise ConfigError(
                f"{k}objects_per_scene={list(self.objects_per_scene)} must be [min, max] with "
                f"1 <= min <= max <= {len(self.obj_ids)} (the number of obj_ids)"
            )
        if int(self.num_scenes) < 1:
            raise ConfigError(f"{k}num_scenes={self.num_scenes} must be a positive number of scenes")
        if self.resting not in ("uniform", "drop"):
            raise ConfigError(f"{k}resting={self.resting!r} is unknown; use uniform or drop")
        if not 0.0 <= float(self.rest_min_probability) < 1.0:
            raise ConfigError(f"{k}rest_min_probability={self.rest_min_probability} must be in [0, 1)")
        if not 0.0 <= float(self.upright_prior) <= 1.0:
            raise ConfigError(f"{k}upright_prior={self.upright_prior} must be a probability in [0, 1]")
        if not 0 < self.distance_mm[0] <= self.distance_mm[1]:
            raise ConfigError(f"{k}distance_mm={list(self.distance_mm)} must be [min, max] in mm, 0 < min <= max")
        if not 0 < self.elevation_deg[0] <= self.elevation_deg[1] < 90:
            raise ConfigError(f"{k}elevation_deg={list(self.elevation_deg)} must be [min, max] within (0, 90)")


@dataclass(frozen=True)
class PlacedObject:
    """One object of a scene: ``T_world_model`` (4, 4, mm) puts the model on the table;
    ``rest_up`` (3,) is the model direction that points up."""

    obj_id: int
    T_world_model: np.ndarray
    rest_up: np.ndarray


@dataclass(frozen=True)
class SceneLayout:
    """A scene: its objects and the camera's ``T_camera_world`` (4, 4, mm)."""

    scene_id: int
    objects: tuple[PlacedObject, ...]
    T_camera_world: np.ndarray


#: the smallest gap (mm) between two objects' footprints
GAP_MM = 2.0


def footprint(xy: np.ndarray) -> np.ndarray:
    """(K, 2) counter-clockwise convex hull of an object's vertices projected on the table (mm)."""
    from scipy.spatial import ConvexHull

    pts = np.asarray(xy, dtype=np.float64)
    return pts[ConvexHull(pts).vertices]


def polygons_overlap(a: np.ndarray, b: np.ndarray, gap: float = 0.0) -> bool:
    """Whether convex polygons ``a`` (K, 2) and ``b`` (L, 2) come closer than ``gap`` along every
    edge normal of either (the separating-axis test; False: a separating axis exists)."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
        lengths = np.sqrt(normals[:, 0] * normals[:, 0] + normals[:, 1] * normals[:, 1])
        normals = normals[lengths > 0] / lengths[lengths > 0, None]
        pa = a[:, 0:1] * normals[:, 0] + a[:, 1:2] * normals[:, 1]  # (K, axes)
        pb = b[:, 0:1] * normals[:, 0] + b[:, 1:2] * normals[:, 1]
        separated = (pa.max(axis=0) + gap <= pb.min(axis=0)) | (pb.max(axis=0) + gap <= pa.min(axis=0))
        if separated.any():
            return False
    return True


def _draw_up(
    spec: ClutterSpec, rng: np.random.Generator, rests: list[RestingUp], axis: np.ndarray | None
) -> np.ndarray:
    """One resting direction (3,) of a model (see the module docstring's resting poses)."""
    if spec.resting == "drop":
        options = [r for r in rests if r.probability > 0]
        p = np.array([r.probability for r in options])
        return options[int(rng.choice(len(options), p=p / p.sum()))].vector
    classes = [members for rep, members in rest_classes(rests, axis) if rep.probability >= spec.rest_min_probability]
    members = classes[int(rng.integers(len(classes)))]
    return members[int(rng.integers(len(members)))].vector


def layout_scene(
    spec: ClutterSpec,
    scene_id: int,
    vertices_mm: dict[int, np.ndarray],
    rests: dict[int, list[RestingUp]],
    axes: dict[int, np.ndarray | None] | None = None,
) -> SceneLayout:
    """The objects and camera of scene ``scene_id`` (see the module docstring).

    Args:
        spec: the generation settings.
        vertices_mm: obj_id -> (V, 3) model vertices, mm, model frame.
        rests: obj_id -> its resting directions (:func:`catpose.resting.resting_ups`).
        axes: obj_id -> its continuous symmetry axis (model frame) or None (``resting=uniform``
            merges the resting directions a symmetry makes one).
    """
    axes = axes or {}
    rng = np.random.default_rng(stable_seed(spec.scene_seed, "clutter", int(scene_id)))
    lo, hi = spec.objects_per_scene
    count = int(rng.integers(lo, hi + 1))
    chosen = [int(spec.obj_ids[i]) for i in rng.choice(len(spec.obj_ids), size=count, replace=False)]
    placed: list[PlacedObject] = []
    footprints: list[np.ndarray] = []
    centres: list[np.ndarray] = []
    for obj_id in chosen:
        if rng.random() < spec.upright_prior:
            up = np.array([0.0, 0.0, 1.0])
        else:
            up = _draw_up(spec, rng, rests[obj_id], axes.get(obj_id))
        yaw = float(rng.uniform(0.0, 2.0 * np.pi))
        R = matmul3(axis_angle_to_R(np.array([0.0, 0.0, 1.0]), yaw), R_onto_z(up))
        v = apply_R(R, vertices_mm[obj_id])
        centre_xy = 0.5 * (v[:, :2].min(axis=0) + v[:, :2].max(axis=0))
        outline = footprint(v[:, :2] - centre_xy)
        for _ in range(200):
            r = spec.table_radius_mm * float(np.sqrt(rng.random()))
            phi = float(rng.uniform(0.0, 2.0 * np.pi))
            xy = np.array([r * np.cos(phi), r * np.sin(phi)])
            if not any(polygons_overlap(outline + xy, other, GAP_MM) for other in footprints):
                break
        else:
            continue
        footprints.append(outline + xy)
        centres.append(xy)
        t = np.array([xy[0] - centre_xy[0], xy[1] - centre_xy[1], -float(v[:, 2].min())])
        placed.append(PlacedObject(obj_id, make_T(R, t), up))
    centre = np.zeros(3)
    if placed:
        tops = [float(apply_R(p.T_world_model[:3, :3], vertices_mm[p.obj_id])[:, 2].max()) for p in placed]
        centre = np.array([np.mean([c[0] for c in centres]), np.mean([c[1] for c in centres]), 0.5 * np.mean(tops)])
    distance = float(rng.uniform(*spec.distance_mm))
    elevation = np.deg2rad(float(rng.uniform(*spec.elevation_deg)))
    azimuth = float(rng.uniform(0.0, 2.0 * np.pi))
    eye = centre + distance * np.array(
        [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)]
    )
    T_camera_world = look_at_T_camera_world(eye, centre, np.array([0.0, 0.0, 1.0]))
    return SceneLayout(int(scene_id), tuple(placed), T_camera_world)


def T_camera_model(layout: SceneLayout, obj: PlacedObject) -> np.ndarray:
    """(4, 4) pose of one object's model in the camera frame, mm."""
    return compose_T(layout.T_camera_world, obj.T_world_model)
