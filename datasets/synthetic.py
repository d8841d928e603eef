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
from catpose.datasets.render import ViewSampler, depth_to_points, estimate_normals, render_depth
from catpose.datasets.sensor import get_sensor
from catpose.datasets.shapes import SHAPES, SYMMETRIC_CATEGORIES
from catpose.datasets.views import pinhole_camera
from catpose.errors import ConfigError, DatasetError
from catpose.geometry import apply_R, axis_angle_to_R, dot3, invert_T, stable_seed, unit3
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
        width, height: image size in pixels.
        fx, fy, cx, cy: pinhole intrinsics in pixels; ``cx``/``cy`` None means the image centre
            (``(width - 1) / 2``, ``(height - 1) / 2``).
        fov_deg: if set, the horizontal field of view in degrees; overrides ``fx`` and ``fy``
            (square pixels).
        distance: camera distance from the object centre (object-normalised unit).
        elevation_min_deg, elevation_max_deg: camera elevation above the ground plane, degrees,
            drawn uniformly; azimuth is uniform in [0, 360).
        roll_max_deg: camera roll about its optical axis, uniform in [-roll, roll] degrees.
        depth_noise_std: std of zero-mean Gaussian noise added to each valid depth pixel
            (object-normalised unit; 0 for clean depth).
        normal_radius: search radius for normal estimation (object-normalised unit).
        max_points: keep at most this many observed points (seeded random subset).
        min_points: fewer visible points than this raises :class:`DatasetError`.
        ground_normal_noise_deg: std of the angle (degrees) by which the reported ground normal
            is tilted about a random perpendicular axis (0: exact).
        sensor: ``none`` (default: clean depth as above), ``kinect`` or ``realsense``: render the
            object at its physical size (:data:`catpose.datasets.sensor.CATEGORY_SIZE_M`) on a
            table plane at a physical distance and apply the sensor model
            (:func:`catpose.datasets.sensor.apply_sensor`); the ground normal is then a RANSAC
            plane fit to the measured background, as for real frames.
    """

    name = "synthetic"

    def __init__(
        self,
        seed: int = 0,
        categories: Sequence[str] | None = None,
        instances_per_category: int = 3,
        views_per_instance: int = 2,
        num_templates: int = 3,
        template_points: int = 2048,
        width: int = 320,
        height: int = 240,
        fx: float = 300.0,
        fy: float = 300.0,
        cx: float | None = None,
        cy: float | None = None,
        fov_deg: float | None = None,
        distance: float = 3.0,
        elevation_min_deg: float = 10.0,
        elevation_max_deg: float = 60.0,
        roll_max_deg: float = 0.0,
        depth_noise_std: float = 0.0,
        normal_radius: float = 0.1,
        max_points: int = 2048,
        min_points: int = 50,
        ground_normal_noise_deg: float = 0.0,
        sensor: str | None = "none",
    ) -> None:
        cats = list(DEFAULT_CATEGORIES) if categories is None else [str(c) for c in categories]
        unknown = [c for c in cats if c not in SHAPES]
        if unknown:
            raise ConfigError(f"synthetic dataset: unknown categories {unknown}; valid: {sorted(SHAPES)}")
        if not cats:
            raise ConfigError(f"synthetic dataset: categories is empty; list at least one of {sorted(SHAPES)}")
        for name, value in (
            ("instances_per_category", instances_per_category),
            ("views_per_instance", views_per_instance),
            ("template_points", template_points),
            ("max_points", max_points),
            ("width", width),
            ("height", height),
        ):
            if int(value) < 1:
                raise ConfigError(f"synthetic dataset: {name}={value}; it must be a positive integer")
        if not 0 <= float(depth_noise_std) < float("inf") or not 1 <= int(min_points) <= int(width) * int(height):
            raise ConfigError(
                f"synthetic dataset: depth_noise_std={depth_noise_std} must be >= 0 and min_points={min_points} in "
                f"1..{int(width) * int(height)} (the image's pixels)"
            )
        if int(num_templates) < 0:
            raise ConfigError(f"synthetic dataset: num_templates={num_templates}; it must be >= 0")
        if distance <= 1.0:
            raise ConfigError(
                f"synthetic dataset: distance={distance} puts the camera inside the unit "
                "bounding sphere; use a distance > 1 (e.g. 3)"
            )
        if fov_deg is not None:
            if not 0.0 < fov_deg < 180.0:
                raise ConfigError(f"synthetic dataset: fov_deg={fov_deg}; use a value in (0, 180)")
            fx = fy = 0.5 * width / libm.tan(np.deg2rad(fov_deg) / 2)
        self.seed = int(seed)
        self.categories = cats
        self.instances_per_category = int(instances_per_category)
        self.views_per_instance = int(views_per_instance)
        self.num_templates = int(num_templates)
        self.template_points = int(template_points)
        self.camera = pinhole_camera(width, height, fx, fy, cx, cy)
        self.view_sampler = ViewSampler(
            float(distance), float(elevation_min_deg), float(elevation_max_deg), float(roll_max_deg)
        )
        self.depth_noise_std = float(depth_noise_std)
        self.normal_radius = float(normal_radius)
        self.max_points = int(max_points)
        self.min_points = int(min_points)
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
        parts = obs_id.split("/")
        ok = (
            len(parts) == 3
            and parts[0] in self.categories
            and parts[1].isdigit()
            and int(parts[1]) < self.instances_per_category
            and parts[2].startswith("v")
            and parts[2][1:].isdigit()
            and int(parts[2][1:]) < self.views_per_instance
        )
        if not ok:
            raise DatasetError(
                f"synthetic dataset has no observation {obs_id!r}; ids look like "
                f"'{self.categories[0]}/000/v00' (see observation_ids())"
            )
        return parts[0], parts[1], int(parts[2][1:])

    def _check_category(self, category: str) -> None:
        if category not in SHAPES:
            raise ConfigError(f"synthetic dataset: unknown category {category!r}; valid: {sorted(SHAPES)}")

    # ------------------------------------------------------------------ models

    def _build(self, category: str, model_id: str, stream: str) -> Template:
        """Mesh and outer-surface cloud of one instance or template, cached."""
        key = (category, model_id)
        if key not in self._models:
            mesh_rng = np.random.default_rng(stable_seed(self.seed, "synthetic", stream, "mesh", category, model_id))
            mesh = SHAPES[category](mesh_rng)
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
        self._check_category(category)
        if not (instance_id.isdigit() and int(instance_id) < self.instances_per_category):
            raise DatasetError(
                f"synthetic dataset has no {category} instance {instance_id!r}; "
                f"ids are 000..{self.instances_per_category - 1:03d}"
            )
        return self._build(category, f"{int(instance_id):03d}", "instance")

    def category_templates(self, category: str) -> list[Template]:
        """``num_templates`` other instances of ``category`` (ids ``t0``, ``t1``, ...), drawn from
        a seed stream separate from the observed instances'."""
        self._check_category(category)
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
        T_camera_object = self.view_sampler.sample(rng)
        if self.sensor is not None:
            return self._sensor_observation(obs_id, category, instance_id, view, model, T_camera_object, rng)
        depth = render_depth(model.vertices, model.triangles, T_camera_object, self.camera)
        if self.depth_noise_std > 0:
            noise = rng.normal(0.0, self.depth_noise_std, size=depth.shape).astype(np.float32)
            depth = np.where(depth > 0, depth + noise, 0.0).astype(np.float32)
        points, _ = depth_to_points(depth, self.camera)
        n_pixels = int(len(points))
        if len(points) < self.min_points:
            raise DatasetError(
                f"synthetic observation {obs_id}: only {len(points)} points visible (need "
                f"{self.min_points}); move the camera closer or enlarge the image"
            )
        if len(points) > self.max_points:
            keep = np.sort(rng.choice(len(points), size=self.max_points, replace=False))
            points = points[keep]
        # normals from the kept points, as a method would estimate them from a downsampled scan
        normals = estimate_normals(points, self.normal_radius)

        R_camera_object = T_camera_object[:3, :3]
        ground = apply_R(R_camera_object, np.array([0.0, 0.0, 1.0]))
        if self.ground_normal_noise_deg > 0:
            axis = np.cross(ground, rng.normal(size=3))
            angle = np.deg2rad(rng.normal(0.0, self.ground_normal_noise_deg))
            ground = apply_R(axis_angle_to_R(axis, angle), ground)
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=instance_id,
            points_camera=points,
            normals_camera=normals,
            ground_normal_camera=unit3(ground),
            T_object_camera=invert_T(T_camera_object),
            symmetry_axis=model.symmetry_axis,
            depth_image=DepthImage(depth, self.camera.K, depth > 0),
            info={"view": f"v{view:02d}", "n_depth_pixels": n_pixels},
        )

    def _sensor_observation(
        self,
        obs_id: str,
        category: str,
        instance_id: str,
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
        if n_pixels < self.min_points:
            raise DatasetError(
                f"synthetic observation {obs_id}: only {n_pixels} points measured with "
                f"sensor={sensor.name} (need {self.min_points}); enlarge the image"
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
        points = points_m / size
        if len(points) > self.max_points:
            keep = np.sort(rng.choice(len(points), size=self.max_points, replace=False))
            points = points[keep]
        normals = estimate_normals(points, self.normal_radius)
        if self.ground_normal_noise_deg > 0:
            axis = np.cross(ground, rng.normal(size=3))
            angle = np.deg2rad(rng.normal(0.0, self.ground_normal_noise_deg))
            ground = apply_R(axis_angle_to_R(axis, angle), ground)
        T_camera_object_unit = make_T(T_camera_object_m[:3, :3], T_camera_object_m[:3, 3] / size)
        true_up = apply_R(T_camera_object[:3, :3], np.array([0.0, 0.0, 1.0]))
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=instance_id,
            points_camera=points,
            normals_camera=normals,
            ground_normal_camera=unit3(ground),
            T_object_camera=invert_T(T_camera_object_unit),
            symmetry_axis=model.symmetry_axis,
            depth_image=DepthImage(depth / size, cam.K, mask),
            info={
                "view": f"v{view:02d}",
                "n_depth_pixels": n_pixels,
                "sensor": sensor.name,
                "scale_mm": 1000.0 * size,
                "distance_m": distance_m,
                "bleed_pixels": int((mask & ~true_mask).sum()),
                "missing_fraction": float(1.0 - (depth[true_mask] > 0).mean()) if true_mask.any() else 0.0,
                "ground_vs_object_up_deg": float(np.degrees(libm.arccos(np.clip(dot3(ground, true_up), -1, 1)))),
            },
        )
