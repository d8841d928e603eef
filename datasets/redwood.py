"""Redwood-3DScan RGB-D frames (or any folder of depth PNGs with an optional ``.log`` trajectory).

Layout: ``<root>/<scan>/depth/*.png`` (uint16, millimetres; frames in file-name order), with
an optional camera trajectory ``<root>/<scan>/*.log`` in the Redwood / Open3D format (per
frame: a line ``<frame index> <frame index> <count>`` then the 4x4 ``T_world_camera`` in
metres, row by row). A scan's category comes from ``scan_categories``, else from a
``<category>_<id>`` folder name, else from ``<root>/meta/categories.json`` (the dataset's own
index). Intrinsics default to the PrimeSense ones (fx = fy = 525, cx = 319.5, cy = 239.5).

Segmentation: points within ``depth_range`` (metres); the floor is the dominant RANSAC plane
(:func:`catpose.datasets.depthio.fit_ground_plane`), whose normal oriented towards the camera is the ground normal;
the object is what lies between ``min_height`` and ``max_height`` above it, and (when
``cluster_eps`` > 0) the DBSCAN cluster with the most points in the central image window
(the operator points the camera at the object).

Scale: scans are in metres. Points are divided by the object's size ``object_size`` (metres;
the radius of its bounding sphere), or, when it is None, by the largest distance of the
segmented points of the scan's first listed frame from their camera-frame bounding-box centre (estimated once per scan, so that all views
of a scan share one unit). ``Observation.info["scale_m"]`` states the value used.

Ground truth: the object frame of a scan is unknown. ``T_object_camera`` is the trajectory pose
``T_world_camera`` (translation divided by the scale) when a trajectory exists and the identity
otherwise; ``info["absolute_gt"]`` is False and ``info["pose_source"]`` is ``"trajectory"`` or
``"none"``; ``info["relative_gt"]`` is True only with a trajectory. Only relative poses between
two views (the ``relative`` protocol) are meaningful, and only with a trajectory: without one,
every view has the identity pose and any score against it is meaningless.

Observation ids: ``<category>/<scan>/<frame index:04d>``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.datasets.depthio import fit_ground_plane, png_problem, png_size, read_depth, read_log_trajectory
from catpose.datasets.layout_check import LayoutReport, check_templates
from catpose.datasets.render import depth_to_points, estimate_normals
from catpose.datasets.templates import TemplateOptions, TemplateSet
from catpose.datasets.views import pinhole_camera, subsample
from catpose.errors import CatposeError, DatasetError
from catpose.geometry import dot3, stable_seed
from catpose.types import DepthImage, Template


class Redwood(ObjectDataset):
    """Depth frames of object scans, segmented from the floor.

    Args:
        root: folder with ``<scan>/depth/*.png``.
        scans: scan folder names to use (None: every folder with a ``depth/`` subfolder).
        scan_categories: scan folder name -> category (overrides the name and meta index).
        frames: frame indices to use (positions in the sorted depth list; None: all).
        frame_stride: use every ``frame_stride``-th frame.
        max_frames: use at most this many frames per scan (None: all).
        width, height, fx, fy, cx, cy: intrinsics (pixels; PrimeSense defaults).
        depth_scale: depth-PNG units per metre (1000: millimetres).
        depth_range: (near, far) metres of kept depth.
        trajectory: ``"auto"`` (the scan's only ``*.log`` if any), a file name in the scan
            folder, or None (no poses).
        plane_distance, plane_iterations, plane_max_points: RANSAC floor fit (metres).
        min_height, max_height: object points' height band above the floor (metres).
        cluster_eps: DBSCAN radius (metres) for keeping the central cluster; 0 disables.
        object_size: object bounding radius in metres, or None to estimate it per scan.
        normal_radius: normal-estimation radius (object-normalised unit).
        max_points: points kept per view (0: all).
        template: template meshes, their root, points per template, symmetric categories
            (:class:`~catpose.datasets.templates.TemplateOptions`).
        seed: fixes random subsets.
    """

    name = "redwood"

    def __init__(
        self,
        root: str,
        scans: list[str] | None = None,
        scan_categories: dict[str, str] | None = None,
        frames: list[int] | None = None,
        frame_stride: int = 1,
        max_frames: int | None = None,
        width: int = 640,
        height: int = 480,
        fx: float = 525.0,
        fy: float = 525.0,
        cx: float = 319.5,
        cy: float = 239.5,
        depth_scale: float = 1000.0,
        depth_range: tuple[float, float] = (0.3, 3.0),
        trajectory: str | None = "auto",
        plane_distance: float = 0.02,
        plane_iterations: int = 1000,
        plane_max_points: int = 30000,
        min_height: float = 0.02,
        max_height: float = 2.0,
        cluster_eps: float = 0.05,
        object_size: float | None = None,
        normal_radius: float = 0.1,
        max_points: int = 2048,
        template: TemplateOptions = TemplateOptions(),
        seed: int = 0,
    ) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise DatasetError(
                f"Redwood root {self.root} is not a folder; set dataset.root to the folder with <scan>/depth/*.png"
            )
        self.scans = None if scans is None else [str(s) for s in scans]
        self.scan_categories = {str(k): str(v) for k, v in (scan_categories or {}).items()}
        self.frames = None if frames is None else [int(f) for f in frames]
        self.frame_stride = max(1, int(frame_stride))
        self.max_frames = max_frames
        self.camera = pinhole_camera(width, height, fx, fy, cx, cy)
        self.depth_scale = float(depth_scale)
        self.depth_range = (float(depth_range[0]), float(depth_range[1]))
        self.trajectory = trajectory
        self.plane_distance = float(plane_distance)
        self.plane_iterations = int(plane_iterations)
        self.plane_max_points = int(plane_max_points)
        self.min_height, self.max_height = float(min_height), float(max_height)
        self.cluster_eps = float(cluster_eps)
        self.object_size = None if object_size is None else float(object_size)
        self.normal_radius = float(normal_radius)
        self.max_points = int(max_points)
        self.symmetric = template.symmetry_axes()
        self.seed = int(seed)
        self._templates = TemplateSet(template, self.root, self.seed)
        self._ids: list[str] | None = None
        self._frames: dict[str, list[Path]] = {}
        self._poses: dict[str, dict[int, np.ndarray] | None] = {}
        self._scale: dict[str, float] = {}

    # ------------------------------------------------------------------ index
    def scan_dirs(self) -> list[Path]:
        """Scan folders (those with a ``depth/`` subfolder), sorted by name."""
        if self.scans is not None:
            dirs = [self.root / s for s in self.scans]
            for d in dirs:
                if not (d / "depth").is_dir():
                    raise DatasetError(f"scan folder {d} has no depth/ subfolder; check dataset.scans")
            return dirs
        return sorted(p for p in self.root.iterdir() if (p / "depth").is_dir())

    def category_of_scan(self, scan: str) -> str:
        if scan in self.scan_categories:
            return self.scan_categories[scan]
        m = re.fullmatch(r"([A-Za-z][A-Za-z ._-]*?)_(\d+)", scan)
        if m:
            return m.group(1)
        meta = self.root / "meta" / "categories.json"
        if meta.is_file() and scan.isdigit():
            try:
                index = json.loads(meta.read_text())
            except json.JSONDecodeError:
                raise DatasetError(f"{meta} is not valid JSON") from None
            for category, ids in index.items():
                if scan in ids:
                    return str(category)
        raise DatasetError(
            f"no category for scan {scan!r}: name it <category>_<id>, list it in "
            "dataset.scan_categories, or provide <root>/meta/categories.json"
        )

    def frame_files(self, scan: str) -> list[Path]:
        if scan not in self._frames:
            files = sorted((self.root / scan / "depth").glob("*.png"))
            if not files:
                raise DatasetError(f"{self.root / scan / 'depth'} has no PNG depth images")
            self._frames[scan] = files
        return self._frames[scan]

    def frame_indices(self, scan: str) -> list[int]:
        n = len(self.frame_files(scan))
        idx = [i for i in (self.frames if self.frames is not None else range(n)) if 0 <= i < n]
        idx = idx[:: self.frame_stride]
        return idx[: self.max_frames] if self.max_frames else idx

    def observation_ids(self) -> list[str]:
        if self._ids is None:
            ids = [
                f"{self.category_of_scan(d.name)}/{d.name}/{i:04d}"
                for d in self.scan_dirs()
                for i in self.frame_indices(d.name)
            ]
            if not ids:
                raise DatasetError(f"no depth frames under {self.root}/<scan>/depth; check dataset.root")
            self._ids = ids
        return self._ids

    def poses(self, scan: str) -> dict[int, np.ndarray] | None:
        """The scan's trajectory ``{frame index: T_world_camera}`` in metres, or None."""
        if scan not in self._poses:
            path = None
            if self.trajectory == "auto":
                logs = sorted((self.root / scan).glob("*.log"))
                if len(logs) > 1:
                    raise DatasetError(
                        f"{self.root / scan} has several .log files {[p.name for p in logs]}; "
                        "name one in dataset.trajectory"
                    )
                path = logs[0] if logs else None
            elif self.trajectory:
                path = self.root / scan / self.trajectory
            self._poses[scan] = None if path is None else read_log_trajectory(path)
        return self._poses[scan]

    def check_layout(self, name: str, report: LayoutReport) -> None:
        try:
            scans = self.scan_dirs()
        except CatposeError as e:
            report.problem(str(e))
            return
        if not scans:
            report.problem(
                f"no scan folders with depth/ under {self.root}: unzip each scan <id>.zip into "
                f"{self.root}/<category>_<id>/ (docs/data.md)"
            )
            return
        no_trajectory = []
        for scan in scans:
            try:
                self.category_of_scan(scan.name)
                files, poses = self.frame_files(scan.name), self.poses(scan.name)
            except CatposeError as e:
                report.problem(str(e))
                continue
            if poses is None:
                no_trajectory.append(scan.name)
            elif len(poses) < len(files):
                report.warn(
                    f"the trajectory of {scan.name} has {len(poses)} poses for {len(files)} depth images; frames "
                    "without a pose fail under protocol=relative"
                )
        if report.problems:
            return
        if no_trajectory:
            report.warn(
                f"{len(no_trajectory)} scans have no trajectory (*.log), e.g. {no_trajectory[0]}: "
                "protocol=relative cannot score them (docs/data.md says how to make one)"
            )
        files = [f for scan in scans for f in self.frame_files(scan.name)]
        try:
            read_depth(files[0])
        except CatposeError as e:
            report.problem(str(e))
        size = png_size(files[0]) if files else None
        report.note_files([w for w in (png_problem(f, size, True) for f in files) if w], "depth images")
        report.facts.append(f"{len(scans)} scans with depth/, {len(files)} depth images whole")
        check_templates(self, report, lambda _c, _i: False)

    # ------------------------------------------------------------------ segmentation
    def segment(self, scan: str, index: int) -> tuple[np.ndarray, np.ndarray, dict]:
        """Object points (N, 3, metres, camera frame), floor normal (3,) and facts of one frame."""
        path = self.frame_files(scan)[index]
        depth = read_depth(path).astype(np.float64) / self.depth_scale
        if depth.shape != (self.camera.height, self.camera.width):
            raise DatasetError(
                f"{path} is {depth.shape[1]}x{depth.shape[0]} but the intrinsics are for "
                f"{self.camera.width}x{self.camera.height}; set dataset.width/height/fx/fy/cx/cy"
            )
        points, _ = depth_to_points(depth, self.camera, depth_range=self.depth_range)
        if len(points) < 100:
            raise DatasetError(f"{path} has only {len(points)} pixels in depth_range {self.depth_range} m")
        rng = np.random.default_rng(stable_seed(self.seed, "redwood", scan, index))
        fit = points
        if self.plane_max_points and len(points) > self.plane_max_points:
            fit = points[rng.choice(len(points), size=self.plane_max_points, replace=False)]
        normal, offset, n_inliers = fit_ground_plane(
            fit, self.plane_distance, self.plane_iterations, stable_seed(self.seed, "floor", scan, index)
        )
        height = dot3(points, normal) + offset
        obj = points[(height > self.min_height) & (height < self.max_height)]
        if self.cluster_eps > 0 and len(obj) >= 10:
            obj = self._object_cluster(obj)
        if len(obj) < 10:
            raise DatasetError(
                f"{path}: only {len(obj)} points above the floor plane; check depth_range and min_height/max_height"
            )
        return obj, normal, {"floor_inliers": n_inliers, "object_points_raw": len(obj)}

    def object_mask(self, scan: str, index: int, obj_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The frame's depth (H, W, metres) and the object's pixels: those whose back-projected
        point lies within a voxel diagonal (``cluster_eps / 4 * sqrt(3)``; 5 mm without
        clustering) of the segmented object points ``obj_m`` (N, 3)."""
        from scipy.spatial import cKDTree

        depth = read_depth(self.frame_files(scan)[index]).astype(np.float64) / self.depth_scale
        points, pixels = depth_to_points(depth, self.camera, depth_range=self.depth_range)
        reach = self.cluster_eps / 4 * np.sqrt(3.0) if self.cluster_eps > 0 else 0.005
        near = cKDTree(obj_m).query(points, distance_upper_bound=reach)[0] <= reach
        mask = np.zeros(depth.shape, dtype=bool)
        mask[pixels[near, 0], pixels[near, 1]] = True
        return np.where(np.isfinite(depth) & (depth > 0), depth, 0.0), mask

    def _object_cluster(self, points: np.ndarray) -> np.ndarray:
        """The DBSCAN cluster with the most points projecting into the central image window
        (the middle half of each image axis): the operator points the camera at the object."""
        from catpose.o3d import o3d

        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        pcd = pcd.voxel_down_sample(self.cluster_eps / 4)
        labels = np.asarray(pcd.cluster_dbscan(eps=self.cluster_eps, min_points=5))
        pts = np.asarray(pcd.points)
        if (labels >= 0).sum() == 0:
            return pts
        cam = self.camera
        u = cam.fx * pts[:, 0] / pts[:, 2] + cam.cx
        v = cam.fy * pts[:, 1] / pts[:, 2] + cam.cy
        central = (np.abs(u - cam.width / 2) < cam.width / 4) & (np.abs(v - cam.height / 2) < cam.height / 4)
        ok = labels >= 0
        votes = (
            np.bincount(labels[ok & central], minlength=labels.max() + 1)
            if (ok & central).any()
            else np.bincount(labels[ok])
        )
        return pts[labels == votes.argmax()]

    def scale_m(self, scan: str) -> float:
        """The scan's object-normalisation scale (metres per unit)."""
        if self.object_size is not None:
            return self.object_size
        if scan not in self._scale:
            first = self.frame_indices(scan)[0] if self.frame_indices(scan) else 0
            pts, _, _ = self.segment(scan, first)
            centre = 0.5 * (pts.min(0) + pts.max(0))
            self._scale[scan] = float(np.linalg.norm(pts - centre, axis=1).max())
        return self._scale[scan]

    # ------------------------------------------------------------------ interface
    def observation(self, obs_id: str) -> Observation:
        try:
            category, scan, frame = obs_id.split("/")
            index = int(frame)
        except ValueError:
            raise DatasetError(f"observation id {obs_id!r} is not <category>/<scan>/<frame>") from None
        if not (self.root / scan / "depth").is_dir():
            raise DatasetError(f"scan folder {self.root / scan} has no depth/ subfolder")
        if not 0 <= index < len(self.frame_files(scan)):
            raise DatasetError(f"frame {index} is not in {self.root / scan / 'depth'}")
        obj_m, ground, facts = self.segment(scan, index)
        scale = self.scale_m(scan)
        depth_m, mask = self.object_mask(scan, index, obj_m)
        points = obj_m / scale
        normals = estimate_normals(points, self.normal_radius)
        rng = np.random.default_rng(stable_seed(self.seed, "redwood-points", obs_id))
        points, normals = subsample(self.max_points, rng, points, normals)
        poses = self.poses(scan)
        if poses is not None and index not in poses:
            raise DatasetError(f"trajectory of scan {scan} has no pose for frame {index}")
        T = np.eye(4) if poses is None else poses[index].copy()
        T[:3, 3] /= scale
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=scan,
            points_camera=points,
            normals_camera=normals,
            ground_normal_camera=ground,
            T_object_camera=T,
            symmetry_axis=self.symmetric.get(category),
            depth_image=DepthImage(depth_m / scale, self.camera.K, mask),
            info={
                "scan": scan,
                "frame": index,
                "file": self.frame_files(scan)[index].name,
                "absolute_gt": False,
                "relative_gt": poses is not None,
                "pose_source": "none" if poses is None else "trajectory",
                "scale_m": scale,
                "scale_source": "config" if self.object_size is not None else "first_frame",
                **facts,
            },
        )

    def instance_model(self, category: str, instance_id: str) -> Template:
        raise DatasetError(
            f"Redwood scan {instance_id} has no complete model; use protocol=templates or protocol=relative"
        )

    def category_templates(self, category: str) -> list[Template]:
        return self._templates.get(category)
