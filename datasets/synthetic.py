"""The embedded synthetic dataset (``dataset=synthetic``): no download, seeded, bit-reproducible.

Instances come from the procedural generators in :mod:`catpose.datasets.shapes` (canonical
frame: z up, front +x, unit bounding sphere). Each observation is a depth image of one instance
rendered from a random viewpoint with Open3D's ``RaycastingScene``
(:func:`catpose.datasets.render.render_depth`), optionally corrupted by Gaussian depth noise,
back-projected to camera-frame points with normals estimated by local plane fitting.

Every observation, model and template is a pure function of ``(seed, id)``: each instance's
mesh, each template and each view draws from its own generator seeded by
:func:`catpose.geometry.stable_seed`, never from a shared sequential stream, so subsets,
reordered loads and resumed runs see bit-identical samples.

Ids: observations ``"<category>/<iii>/v<jj>"`` (instance ``iii``, view ``jj``); instance models
``"synthetic/<category>/<iii>"``; category templates ``"synthetic/<category>/t<k>"``, drawn from
a separate seed stream so a template is never one of the observed instances.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from catpose import libm
from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.datasets.meshio import sample_outer_surface
from catpose.datasets.render import depth_to_points, render_depth
from catpose.datasets.sensor import get_sensor
from catpose.datasets.shapes import SHAPES, SYMMETRIC_CATEGORIES, make_shape
from catpose.datasets.views import ImageOptions, ViewOptions, check_counts, kept_view, view_observation
from catpose.errors import ConfigError, DatasetError
from catpose.geometry import apply_R, axis_angle_to_R, dot3, stable_seed, unit3
from catpose.types import DepthImage, Template

DEFAULT_CATEGORIES = ("airplane", "chair", "car", "mug", "bottle", "bowl", "can", "plate")


class SyntheticDataset(ObjectDataset):
    """Rendered partial views of procedurally generated category instances.

    Args:
        seed: fixes every instance, template and view.
        categories: categories to include (any of ``shapes.SHAPES``); None for all eight.
        instances_per_category: observed instances per category (ids ``000``, ``001``, ...).
        views_per_instance: rendered views per instance (``v00``, ``v01``, ...).
        num_templates: category templates per category (other instances, ``t0``, ``t1``, ...).
        template_points: points in each complete cloud (instance models and templates).
        view: viewpoints, depth noise and the points kept (:class:`~catpose.datasets.views.ViewOptions`;
            ``distance`` must exceed 1, the unit bounding sphere).
        image: image size, intrinsics, normal radius and ``min_points``
            (:class:`~catpose.datasets.views.ImageOptions`).
        ground_normal_noise_deg: std of the angle (degrees) by which the reported ground normal
            is tilted about a random perpendicular axis (0: exact).
        sensor: ``none`` (default: clean depth as above), ``kinect`` or ``realsense``: render the
            object at its physical size (:data:`catpose.datasets.sensor.CATEGORY_SIZE_M`) on a
            table plane at a physical distance and apply the sensor model
            (:func:`catpose.datasets.sensor.apply_sensor`); the ground normal is then a RANSAC
            plane fit to the measured background, as for real frames.
    """

    name = "synthetic"
    generated = "generated (no files, no root to check)"

    def __init__(
        self,
        seed: int = 0,
        categories: Sequence[str] | None = None,
        instances_per_category: int = 3,
        views_per_instance: int = 2,
        num_templates: int = 3,
        template_points: int = 2048,
        view: ViewOptions = ViewOptions(),
        image: ImageOptions = ImageOptions(),
        ground_normal_noise_deg: float = 0.0,
        sensor: str | None = "none",
    ) -> None:
        cats = list(DEFAULT_CATEGORIES) if categories is None else [str(c) for c in categories]
        unknown = [c for c in cats if c not in SHAPES]
        if unknown:
            raise ConfigError(f"synthetic dataset: unknown categories {unknown}; valid: {sorted(SHAPES)}")
        if not cats:
            raise ConfigError(f"synthetic dataset: categories is empty; list at least one of {sorted(SHAPES)}")
        check_counts(
            instances_per_category=instances_per_category,
            views_per_instance=views_per_instance,
            template_points=template_points,
            max_points=view.max_points,
        )
        if int(num_templates) < 0:
            raise ConfigError(f"synthetic dataset: num_templates={num_templates}; it must be >= 0")
        self.seed = int(seed)
        self.categories = cats
        self.instances_per_category = int(instances_per_category)
        self.views_per_instance = int(views_per_instance)
        self.num_templates = int(num_templates)
        self.template_points = int(template_points)
        self.view, self.image = view, image
        self.camera = image.camera()
        self.ground_normal_noise_deg = float(ground_normal_noise_deg)
        self.sensor = get_sensor(sensor)
        self._models: dict[tuple[str, str], Template] = {}

    # ------------------------------------------------------------------ ids

    def observation_ids(self) -> list[str]:
        return [
            f"{c}/{i:03d}/v{j:02d}"
            for c in self.categories
            for i in range(self.instances_per_category)
            for j in range(self.views_per_instance)
        ]

    def _parse(self, obs_id: str) -> tuple[str, str, int]:
        if obs_id not in self.observation_ids():
            raise DatasetError(
                f"synthetic dataset has no observation {obs_id!r}; ids look like "
                f"'{self.categories[0]}/000/v00' (see observation_ids())"
            )
        category, instance_id, view = obs_id.split("/")
        return category, instance_id, int(view[1:])

    # ------------------------------------------------------------------ models

    def _build(self, category: str, model_id: str, stream: str) -> Template:
        """Mesh and outer-surface cloud of one instance or template, cached."""
        key = (category, model_id)
        if key not in self._models:
            mesh_rng = np.random.default_rng(stable_seed(self.seed, "synthetic", stream, "mesh", category, model_id))
            mesh = make_shape(category, mesh_rng)  # an unknown category: a one-line ConfigError
            cloud_rng = np.random.default_rng(stable_seed(self.seed, "synthetic", stream, "cloud", category, model_id))
            vertices, triangles = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
            points, normals = sample_outer_surface(vertices, triangles, self.template_points, cloud_rng)
            self._models[key] = Template(
                template_id=f"synthetic/{category}/{model_id}",
                category=category,
                points=points,
                normals=normals,
                vertices=vertices,
                triangles=triangles,
                up=np.array([0.0, 0.0, 1.0]),
                symmetry_axis=np.array([0.0, 0.0, 1.0]) if category in SYMMETRIC_CATEGORIES else None,
            )
        return self._models[key]

    def instance_model(self, category: str, instance_id: str) -> Template:
        """The instance's complete model: mesh plus outer-surface cloud, object frame."""
        if not (instance_id.isdigit() and int(instance_id) < self.instances_per_category):
            raise DatasetError(
                f"synthetic dataset has no {category} instance {instance_id!r}; "
                f"ids are 000..{self.instances_per_category - 1:03d}"
            )
        return self._build(category, f"{int(instance_id):03d}", "instance")

    def category_templates(self, category: str) -> list[Template]:
        """``num_templates`` other instances of ``category`` (ids ``t0``, ``t1``, ...), drawn from
        a seed stream separate from the observed instances'."""
        return [self._build(category, f"t{k}", "template") for k in range(self.num_templates)]

    # ------------------------------------------------------------------ observations

    def observation(self, obs_id: str) -> Observation:
        """Render view ``obs_id``; a pure function of ``(seed, obs_id)`` and the settings.

        Raises :class:`DatasetError` for an unknown id or a view that sees fewer than
        ``min_points`` points.
        """
        category, instance_id, view = self._parse(obs_id)
        model = self.instance_model(category, instance_id)
        rng = np.random.default_rng(stable_seed(self.seed, "synthetic", "view", obs_id))
        T_camera_object = self.view.sample(rng)
        if self.sensor is not None:
            return self._sensor_observation(obs_id, category, view, model, T_camera_object, rng)
        depth = render_depth(model.vertices, model.triangles, T_camera_object, self.camera)
        if self.view.depth_noise_std > 0:
            noise = rng.normal(0.0, self.view.depth_noise_std, size=depth.shape).astype(np.float32)
            depth = np.where(depth > 0, depth + noise, 0.0).astype(np.float32)
        points, _ = depth_to_points(depth, self.camera)
        n_pixels = int(len(points))
        if len(points) < self.image.min_points:
            raise DatasetError(
                f"synthetic observation {obs_id}: only {len(points)} points visible (need "
                f"{self.image.min_points}); move the camera closer or enlarge the image"
            )
        ground = apply_R(T_camera_object[:3, :3], np.array([0.0, 0.0, 1.0]))
        depth_image = DepthImage(depth, self.camera.K, depth > 0)
        info = {"view": f"v{view:02d}", "n_depth_pixels": n_pixels}
        return self._observation(obs_id, model, points, ground, T_camera_object, depth_image, info, rng)

    def _observation(
        self,
        obs_id: str,
        model: Template,
        points: np.ndarray,
        ground: np.ndarray,
        T_camera_object: np.ndarray,
        depth_image: DepthImage,
        info: dict,
        rng: np.random.Generator,
        true_up: np.ndarray | None = None,
    ) -> Observation:
        """What both paths end with: subsample, normals, the reported ground normal's tilt (and,
        given the object's ``true_up`` in the camera, the reported normal's angle to it)."""
        points, normals = kept_view(points, self.view.max_points, self.image.normal_radius, rng)
        if self.ground_normal_noise_deg > 0:
            axis = np.cross(ground, rng.normal(size=3))
            angle = np.deg2rad(rng.normal(0.0, self.ground_normal_noise_deg))
            ground = apply_R(axis_angle_to_R(axis, angle), ground)
        if true_up is not None:
            info["ground_vs_object_up_deg"] = float(np.degrees(libm.arccos(np.clip(dot3(ground, true_up), -1, 1))))
        return view_observation(
            obs_id, points, normals, unit3(ground), T_camera_object, model.symmetry_axis, info, depth_image
        )

    def _sensor_observation(
        self,
        obs_id: str,
        category: str,
        view: int,
        model: Template,
        T_camera_object: np.ndarray,
        rng: np.random.Generator,
    ) -> Observation:
        """Render at physical scale on a table, apply the sensor model, then subsample and
        estimate normals (order: render, noise, subsample, normals). Points are returned in the
        object-normalised unit like every other view."""
        from catpose.datasets.depthio import fit_ground_plane
        from catpose.datasets.sensor import CATEGORY_SIZE_M, apply_sensor, table_mesh
        from catpose.geometry import make_T

        sensor, cam = self.sensor, self.camera
        size = CATEGORY_SIZE_M[category]  # metres per object unit
        distance_m = max(float(rng.uniform(*sensor.distance_m)), 2.5 * size)
        t = T_camera_object[:3, 3]
        T_camera_object_m = make_T(T_camera_object[:3, :3], unit3(t) * distance_m)
        v_m = model.vertices * size
        table_v, table_f = table_mesh(float(v_m[:, 2].min()) - 1e-4)
        scene_v = np.concatenate([v_m, table_v])
        scene_f = np.concatenate([model.triangles, table_f + len(v_m)])
        depth_object = render_depth(v_m, model.triangles, T_camera_object_m, cam).astype(np.float64)
        depth_scene = render_depth(scene_v, scene_f, T_camera_object_m, cam).astype(np.float64)
        true_mask = (depth_object > 0) & (depth_object <= depth_scene + 1e-6)
        depth, mask = apply_sensor(depth_scene, true_mask, cam.fx, cam.fy, cam.cx, cam.cy, sensor, rng)
        points_m, _ = depth_to_points(depth, cam, mask)
        n_pixels = int(len(points_m))
        if n_pixels < self.image.min_points:
            raise DatasetError(
                f"synthetic observation {obs_id}: only {n_pixels} points measured with "
                f"sensor={sensor.name} (need {self.image.min_points}); enlarge the image"
            )
        background_m, _ = depth_to_points(depth, cam, (depth > 0) & ~mask)
        if len(background_m) > 4000:  # the table is the dominant plane: a few thousand points fit it
            background_m = background_m[rng.choice(len(background_m), size=4000, replace=False)]
        if len(background_m) < 100:
            raise DatasetError(
                f"synthetic observation {obs_id}: only {len(background_m)} background pixels "
                "to fit the ground plane; enlarge the image"
            )
        ground, _, _ = fit_ground_plane(background_m, 0.01, 300, stable_seed(self.seed, "synthetic", "plane", obs_id))
        T_camera_object_unit = make_T(T_camera_object_m[:3, :3], T_camera_object_m[:3, 3] / size)
        true_up = apply_R(T_camera_object[:3, :3], np.array([0.0, 0.0, 1.0]))
        info = {
            "view": f"v{view:02d}",
            "n_depth_pixels": n_pixels,
            "sensor": sensor.name,
            "scale_mm": 1000.0 * size,
            "distance_m": distance_m,
            "bleed_pixels": int((mask & ~true_mask).sum()),
            "missing_fraction": float(1.0 - (depth[true_mask] > 0).mean()) if true_mask.any() else 0.0,
        }
        depth_image = DepthImage(depth / size, cam.K, mask)
        points = points_m / size
        return self._observation(obs_id, model, points, ground, T_camera_object_unit, depth_image, info, rng, true_up)
