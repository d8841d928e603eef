"""Real depth frames in the official BOP layout (TYO-L, or any BOP dataset). Kept whole because it
is one format's loader: the frame index (with BOP19's filters), the models' normalisation and
symmetries and a frame's view share the loader's settings and caches (the files' paths and JSON
readers: :mod:`catpose.datasets.bop_layout`; ``bench data check``: :mod:`catpose.datasets.bop_check`).

Layout (BOP toolkit conventions)::

    <root>/models/obj_XXXXXX.ply, models_info.json   (model units: mm)
    <root>/<split>/<scene_id:06d>/depth/<im_id:06d>.png  (uint16; depth_mm = value * depth_scale)
    <root>/<split>/<scene_id:06d>/mask_visib/<im_id:06d>_<gt_idx:06d>.png   (optional)
    <root>/<split>/<scene_id:06d>/scene_gt.json       ({im_id: [{obj_id, cam_R_m2c, cam_t_m2c}]})
    <root>/<split>/<scene_id:06d>/scene_camera.json   ({im_id: {cam_K, depth_scale}})

Only frames whose depth image is present are listed. The object's pixels come from
``mask_visib`` when present; otherwise the model is rendered at the ground-truth pose and a
pixel belongs to the object where the rendered depth matches the measured depth within
``depth_tolerance_mm`` (``Observation.info["mask_source"]`` says which). The ground normal is
the normal of the dominant plane of the background depth (RANSAC as in Open3D's
``segment_plane``, seeded: :func:`fit_ground_plane`), oriented towards the camera, as in the paper.

Units and frames: the object frame is the BOP model frame rotated by the configured model axes
(``up`` -> +z, ``forward`` -> +x) and normalised like every shape in catpose (centre at the
model's bounding-box centre, moved onto the continuous-symmetry axis where the object has one,
farthest vertex at 1). Observed points are divided by the same
scale, so ``points_camera`` and ``T_object_camera`` are in the object-normalised unit.
Symmetric objects (``symmetries_continuous`` in ``models_info.json``, or a ``symmetric``
category entry) are scored by main-axis error.

Observation ids: ``<category>/<scene_id:06d>/<im_id:06d>/<gt_idx>``.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from catpose import libm
from catpose.datasets.bop_check import check_bop
from catpose.datasets.bop_layout import (
    BopLayout,
    camera_K,
    continuous_symmetry_origin,
    gt_obj_id,
    gt_pose,
    read_json,
    read_targets,
    visible_fractions,
)
from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.datasets.depthio import read_depth, read_mask_png
from catpose.datasets.frame_view import FrameSettings, NoGroundPlane, frame_view
from catpose.datasets.layout_check import LayoutReport
from catpose.datasets.mask_noise import corrupt_mask
from catpose.datasets.meshio import R_template_file, read_mesh, sampled_template
from catpose.datasets.render import PinholeCamera, render_depth
from catpose.datasets.templates import TemplateOptions, TemplateSet
from catpose.depth_frame import DepthFrame, scaled_depth
from catpose.errors import ConfigError, DatasetError, InvalidInputError
from catpose.geometry import apply_R, dot3, make_T, matmul3, norm3, normalize_to_unit_sphere, small_matmul, unit3
from catpose.types import Template


class BopFrame(NamedTuple):
    """One instance of a BOP frame as the loader reads it (:meth:`BOP.instance_frame`).

    Attributes:
        frame: the :class:`~catpose.depth_frame.DepthFrame` (raw depth, ``cam_K``, the
            instance's mask, ``depth_scale`` to mm; ``frame_id`` the observation id).
        exclude: (H, W) bool, the rendered model's pixels, left out of the plane fit (mask made by
            rendering), or None.
        category, scene_id, im_id, gt_idx, obj_id: the instance.
        T_camera_model: (4, 4) its ground-truth pose, BOP model frame, mm.
        depth_path: the depth file; mask_source: ``mask_visib`` or ``render``.
    """

    frame: DepthFrame
    exclude: np.ndarray | None
    category: str
    scene_id: int
    im_id: int
    gt_idx: int
    obj_id: int
    T_camera_model: np.ndarray
    depth_path: Path
    mask_source: str


class BOP(ObjectDataset):
    """BOP depth frames and models.

    Args:
        root: BOP dataset folder (``models/``, ``<split>/``).
        split: e.g. ``"test"``.
        scenes: scene ids to use (None: all).
        categories: object id -> category name; objects not listed are skipped (None: every
            object, category ``obj_XXXXXX``).
        template: templates (mesh specs, or ``obj_XXXXXX`` to use a BOP model), their root,
            points per model, and ``symmetric`` (category -> main axis, object frame), which
            overrides ``models_info.json`` (:class:`~catpose.datasets.templates.TemplateOptions`).
        model_up, model_forward: the BOP model axes that become +z and +x.
        object_axes: object id -> ``{up, forward}`` per-object override of the model axes.
        mask: ``"auto"`` (mask_visib when present, else render), ``"mask_visib"`` or ``"render"``.
        depth_tolerance_mm: rendered-vs-measured depth agreement of an object pixel.
        min_visible_pixels: fewer object pixels raise :class:`DatasetError`.
        plane_distance_mm, plane_iterations: RANSAC ground-plane fit.
        plane_max_points: background points used by the fit (random subset).
        normal_radius: normal-estimation radius (object-normalised unit).
        max_points: points kept per view (0: all).
        seed: fixes the random subsets.
        models_dir: ``models`` or ``models_eval``; depth_ext: ``.png`` or ``.tif`` (ITODD);
            sensor: multi-sensor layouts (``depth_<sensor>/``, ``scene_gt_<sensor>.json``, ...).
        min_visib_fract: gt instances less visible than this (``scene_gt_info.json``) are left
            out, as in BOP19 (0: keep all; no effect where the file is absent).
        targets: the split's target list (``test_targets_bop19.json``): only the listed
            (scene, image, object) are used when the file exists (None: every frame).
            ``self.filters`` says which filters were applied.
        mask_noise: the loaded masks corrupted as a segmenter's are, strength drawn per instance
            up to this (:mod:`catpose.datasets.mask_noise`; 0: the masks as loaded), seeded by the run.
    """

    name = "bop"

    def __init__(
        self,
        root: str,
        split: str = "test",
        scenes: list[int] | None = None,
        categories: dict[int | str, str] | None = None,
        template: TemplateOptions = TemplateOptions(),
        model_up: str = "+z",
        model_forward: str = "+x",
        object_axes: dict[int | str, dict[str, str]] | None = None,
        mask: str = "auto",
        depth_tolerance_mm: float = 15.0,
        min_visible_pixels: int = 50,
        plane_distance_mm: float = 10.0,
        plane_iterations: int = 1000,
        plane_max_points: int = 20000,
        normal_radius: float = 0.1,
        max_points: int = 2048,
        seed: int = 0,
        models_dir: str = "models",
        depth_ext: str = ".png",
        sensor: str | None = None,
        min_visib_fract: float = 0.1,
        targets: str | None = "test_targets_bop19.json",
        mask_noise: float = 0.0,
    ) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise DatasetError(
                f"BOP root {self.root} is not a folder; set dataset.root to the folder with models/ and <split>/"
            )
        if mask not in ("auto", "mask_visib", "render"):
            raise DatasetError(f"dataset.mask {mask!r} is not auto, mask_visib or render")
        if not 0.0 <= float(mask_noise) <= 1.0:
            raise ConfigError(f"dataset.mask_noise={mask_noise!r} must be in [0, 1] (0: the masks as loaded)")
        self.mask_noise = float(mask_noise)
        self.split = str(split)
        self.layout = BopLayout(self.root, self.split, models_dir, depth_ext, sensor)
        self.min_visib_fract = float(min_visib_fract)
        self.targets = None if targets in (None, "", "none") else str(targets)
        self.filters: list[str] = []
        self.scenes = None if scenes is None else {int(s) for s in scenes}
        self.categories = None if categories is None else {int(k): str(v) for k, v in categories.items()}
        self.symmetric = template.symmetry_axes()
        self.model_axes = (str(model_up), str(model_forward))
        self.object_axes = {
            int(k): (str(v.get("up", model_up)), str(v.get("forward", model_forward)))
            for k, v in (object_axes or {}).items()
        }
        self.mask = mask
        self.depth_tolerance_mm = float(depth_tolerance_mm)
        self.min_visible_pixels = int(min_visible_pixels)
        #: the frame -> view settings, as :func:`~catpose.datasets.frame_view.frame_view` takes them
        self.frame_settings = FrameSettings(
            float(normal_radius),
            int(max_points),
            float(plane_distance_mm),
            int(plane_iterations),
            int(plane_max_points),
        )
        self.template_points = int(template.template_points)
        self.seed = int(seed)
        self._templates = TemplateSet(template, self.root, self.seed, self.instance_model)
        self._json: dict[Path, Any] = {}
        self._models_mm: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._norm: dict[int, tuple[np.ndarray, np.ndarray, float]] = {}
        self._instances: dict[int, Template] = {}
        self._ids: list[str] | None = None
        self._warned_no_info: set[int] = set()

    def check_layout(self, name: str, report: LayoutReport) -> None:
        check_bop(name, self, report)

    # ------------------------------------------------------------------ files
    def _read_json(self, path: Path) -> Any:
        if path not in self._json:
            self._json[path] = read_json(path)
        return self._json[path]

    def category_of_object(self, obj_id: int) -> str | None:
        if self.categories is None:
            return f"obj_{obj_id:06d}"
        return self.categories.get(obj_id)

    def scene_dirs(self) -> list[Path]:
        """The split's scene folders that ``scenes`` names (all without it), sorted; a named scene
        with no folder is a typo, not an empty scene: a :class:`DatasetError`."""
        split_dir = self.layout.split_dir()
        scene_dirs = sorted(p for p in split_dir.iterdir() if p.is_dir() and p.name.isdigit())
        if self.scenes is None:
            return scene_dirs
        absent = sorted(self.scenes - {int(p.name) for p in scene_dirs})
        if absent:
            raise DatasetError(
                f"dataset.scenes lists {absent}, which {'has' if len(absent) == 1 else 'have'} no folder under "
                f"{split_dir} (its scenes: {', '.join(str(int(p.name)) for p in scene_dirs) or 'none'}); "
                "fix dataset.scenes"
            )
        return [p for p in scene_dirs if int(p.name) in self.scenes]

    def observation_ids(self) -> list[str]:
        if self._ids is not None:
            return self._ids
        split_dir = self.layout.split_dir()
        if not split_dir.is_dir():
            raise DatasetError(f"BOP split folder {split_dir} does not exist; check dataset.root and dataset.split")
        targets = None
        if self.targets is not None and self.layout.targets(self.targets).is_file():
            targets = read_targets(self.layout.targets(self.targets))
        ids: list[str] = []
        seen_objects: set[int] = set()
        n_low_visib, n_not_target, visib_files, n_no_depth = 0, 0, 0, 0
        no_depth_targets: list[str] = []
        matched: set[tuple[int, int, int]] = set()
        for scene_dir in self.scene_dirs():
            scene_id = int(scene_dir.name)
            gt_path, cam_path = self.layout.scene_gt(scene_id), self.layout.scene_camera(scene_id)
            scene_gt = self._read_json(gt_path)
            if not isinstance(scene_gt, dict) or not all(str(k).isdigit() for k in scene_gt):
                raise DatasetError(f"{gt_path} must map image ids to lists of objects (BOP format)")
            cameras = self._read_json(cam_path) if cam_path.is_file() else None
            visib = visible_fractions(self.layout.scene_gt_info(scene_id)) if self.min_visib_fract > 0 else None
            visib_files += visib is not None
            for im_key in sorted(scene_gt, key=int):
                im_id = int(im_key)
                has_depth = self.layout.depth(scene_id, im_id).is_file()
                if not has_depth and targets is None:  # a partial download: frames without depth are left out, and said
                    n_no_depth += 1
                    continue
                if cameras is not None and has_depth:  # a bad focal length fails the run here, not every sample
                    camera_K(cam_path, cameras, im_key)
                entries = scene_gt[im_key]
                if not isinstance(entries, list):
                    raise DatasetError(f"{gt_path}: image {im_key} must map to a list of objects (BOP format)")
                for gt_idx, gt in enumerate(entries):
                    obj_id = gt_obj_id(gt_path, im_key, gt_idx, gt)
                    seen_objects.add(obj_id)
                    category = self.category_of_object(obj_id)
                    if category is None:
                        continue
                    if targets is not None and (scene_id, im_id, obj_id) not in targets:
                        n_not_target += 1
                        continue
                    matched.add((scene_id, im_id, obj_id))
                    fr = (visib or {}).get(im_id)
                    if fr is not None and gt_idx < len(fr) and fr[gt_idx] < self.min_visib_fract:
                        n_low_visib += 1
                        continue
                    ids.append(f"{category}/{scene_id:06d}/{im_id:06d}/{gt_idx}")
                    if not has_depth:  # a listed target: its sample fails with the missing file, it is not dropped
                        no_depth_targets.append(ids[-1])
        self.seen_objects = sorted(seen_objects)
        if self.categories is not None:
            unseen = sorted(set(self.categories) - seen_objects)
            unmapped = sorted(seen_objects - set(self.categories))
            if unseen:  # e.g. unverified ids in configs/dataset/tyol.yaml
                warnings.warn(
                    f"BOP {split_dir}: dataset.categories lists object ids {unseen} that no frame shows; "
                    f"the frames show object ids {self.seen_objects} (unmapped: {unmapped})",
                    stacklevel=2,
                )
        self.filters = []
        if targets is not None:
            self.filters.append(f"targets from {self.targets} ({n_not_target} instances not listed left out)")
        lost = [
            k
            for k in sorted(targets or {})
            if k not in matched and (self.scenes is None or k[0] in self.scenes) and self.category_of_object(k[2])
        ]
        if lost:  # a missing scene, an emptied scene_gt.json, an object the frame does not show
            self.filters.append(
                f"{len(lost)} targets of {self.targets} have no ground truth in scene_gt.json (e.g. scene {lost[0][0]} "
                f"image {lost[0][1]} object {lost[0][2]}) left out"
            )
            warnings.warn(
                f"BOP {split_dir}: {self.filters[-1]}; check the scene folders and scene_gt.json", stacklevel=2
            )
        if no_depth_targets:
            self.filters.append(
                f"{len(no_depth_targets)} targets have no depth image (e.g. {no_depth_targets[0]}): kept, they fail "
                "as samples with that reason"
            )
        if n_no_depth:
            self.filters.append(f"{n_no_depth} frames of scene_gt.json without a depth image left out (no target list)")
        if visib_files:
            self.filters.append(f"visib_fract >= {self.min_visib_fract:g} ({n_low_visib} instances left out)")
        if not ids and self.categories is not None:
            raise DatasetError(
                f"no depth frames with configured objects under {split_dir}; the frames show "
                f"object ids {self.seen_objects}: map them in dataset.categories"
            )
        if not ids:
            raise DatasetError(
                f"no depth frames with configured objects under {split_dir}; check "
                "dataset.split, dataset.scenes and dataset.categories"
            )
        self._ids = ids
        return ids

    def category_templates(self, category: str) -> list[Template]:
        return self._templates.get(category)

    # ------------------------------------------------------------------ models

    def model_mm(self, obj_id: int) -> tuple[np.ndarray, np.ndarray]:
        """Model vertices (V, 3) in mm (BOP model frame) and triangles (F, 3)."""
        if obj_id not in self._models_mm:
            self._models_mm[obj_id] = read_mesh(self.layout.model(obj_id))
        return self._models_mm[obj_id]

    def normalisation(self, obj_id: int) -> tuple[np.ndarray, np.ndarray, float]:
        """``(R_object_model (3, 3), centre (3,) mm, scale mm)``: ``p_object = (R p_model - centre) / scale``.

        The centre is the bounding-box centre, moved onto the continuous-symmetry axis (the
        point of the axis nearest to it, BOP's ``offset`` included) when the object has one,
        so that a spin about the axis leaves the object origin in place.
        """
        if obj_id not in self._norm:
            R = R_template_file(*self.object_axes.get(obj_id, self.model_axes))
            v, _ = self.model_mm(obj_id)
            vr = apply_R(R, v)
            _, centre, scale = normalize_to_unit_sphere(vr)
            cont = self.continuous_symmetries(obj_id)
            if cont:
                rotated = [
                    {
                        "axis": apply_R(R, np.asarray(e["axis"], float)),
                        "offset": apply_R(R, np.asarray(e["offset"], float)),
                    }
                    for e in cont
                ]
                centre = continuous_symmetry_origin(rotated, centre)
                scale = float(norm3(vr - centre).max())
            self._norm[obj_id] = (R, centre, scale)
        return self._norm[obj_id]

    def models_info(self, obj_id: int) -> dict:
        """The object's ``models_info.json`` entry (empty when the file or entry is absent)."""
        path = self.layout.models_info()
        if not path.is_file():
            return {}
        entry = self._read_json(path).get(str(obj_id))
        if entry is None and obj_id not in self._warned_no_info:  # once per object: it is non-symmetric then
            self._warned_no_info.add(obj_id)
            warnings.warn(
                f"{path} has no entry for object {obj_id}; it is scored as non-symmetric: add "
                f'"{obj_id}" there, or set dataset.symmetric.<category>=[x, y, z] if it is symmetric',
                stacklevel=2,
            )
        return {} if entry is None else entry

    def continuous_symmetries(self, obj_id: int) -> list[dict]:
        """Every ``symmetries_continuous`` entry, ``{"axis": (3,), "offset": (3,) mm}`` (model frame)."""
        out = []
        for k, e in enumerate(self.models_info(obj_id).get("symmetries_continuous") or []):
            try:
                axis = np.asarray(e["axis"], float).reshape(3)
                offset = np.asarray(e.get("offset", (0.0, 0.0, 0.0)), float).reshape(3)
            except (KeyError, TypeError, ValueError):
                raise DatasetError(
                    f"{self.layout.models_info()}: symmetries_continuous[{k}] of object {obj_id} "
                    "needs axis and offset (3 numbers each)"
                ) from None
            if not np.isfinite(axis).all() or norm3(axis) == 0 or not np.isfinite(offset).all():
                raise DatasetError(
                    f"{self.layout.models_info()}: symmetries_continuous[{k}] of object {obj_id} "
                    "has a zero or non-finite axis or offset"
                )
            out.append({"axis": axis.tolist(), "offset": offset.tolist()})
        return out

    def symmetry_axis(self, obj_id: int, category: str) -> np.ndarray | None:
        """Main axis (3,) in the object frame: the category entry, else ``models_info.json``."""
        if category in self.symmetric:
            return self.symmetric[category]
        sym = self.continuous_symmetries(obj_id)
        if not sym:
            return None
        R, _, _ = self.normalisation(obj_id)
        return unit3(apply_R(R, np.asarray(sym[0]["axis"], float)))

    def discrete_symmetries(self, obj_id: int) -> tuple[np.ndarray, ...]:
        """``symmetries_discrete`` of ``models_info.json`` as (4, 4) transforms of the normalised
        object frame: ``S_object = N S_model N^-1`` with ``N`` the normalisation
        ``p_object = (R p_model - centre) / scale`` (BOP gives S_model with t in mm)."""
        info_path = self.layout.models_info()
        entries = self.models_info(obj_id).get("symmetries_discrete") or []
        R, centre, scale = self.normalisation(obj_id)
        N = make_T(R / scale, -centre / scale)
        N_inv = make_T(scale * R.T, apply_R(R.T, centre))  # p_model = R^T (scale p_object + centre)
        out = []
        for k, entry in enumerate(entries):
            S = np.asarray(entry, float).reshape(-1)
            if S.size != 16 or not np.isfinite(S).all():
                raise DatasetError(f"{info_path}: symmetries_discrete[{k}] of object {obj_id} is not 16 numbers")
            out.append(small_matmul(small_matmul(N, S.reshape(4, 4)), N_inv))
        return tuple(out)

    @staticmethod
    def _obj_id(instance_id: str) -> int:
        try:
            return int(str(instance_id).rsplit("_", 1)[-1])
        except ValueError:
            raise DatasetError(f"BOP instance id {instance_id!r} is not obj_XXXXXX") from None

    def instance_model(self, category: str, instance_id: str) -> Template:
        obj_id = self._obj_id(instance_id)
        if obj_id not in self._instances:
            v_mm, f = self.model_mm(obj_id)
            R, centre, scale = self.normalisation(obj_id)
            v = (apply_R(R, v_mm) - centre) / scale
            self._instances[obj_id] = sampled_template(
                v,
                f,
                f"bop/obj_{obj_id:06d}",
                category,
                self.template_points,
                self.seed,
                self.symmetry_axis(obj_id, category),
            )
        return self._instances[obj_id]

    # ------------------------------------------------------------------ frames

    def instance_frame(self, obs_id: str) -> BopFrame:
        """The instance's depth frame (raw depth, ``cam_K``, its mask, corrupted when ``mask_noise`` >
        0, ``depth_scale`` to mm, named by ``obs_id`` and the run's seed) and what the loader knows
        beside it (:class:`BopFrame`); a bad file or entry raises :class:`DatasetError` naming it."""
        try:
            category, scene_s, im_s, gt_s = obs_id.split("/")
            scene_id, im_id, gt_idx = int(scene_s), int(im_s), int(gt_s)
        except ValueError:
            raise DatasetError(f"observation id {obs_id!r} is not <category>/<scene>/<image>/<gt index>") from None
        gt_path, cam_path = self.layout.scene_gt(scene_id), self.layout.scene_camera(scene_id)
        try:
            gt = self._read_json(gt_path)[str(im_id)][gt_idx]
        except (KeyError, IndexError, TypeError):
            raise DatasetError(f"{gt_path} has no valid pose for image {im_id}, object index {gt_idx}") from None
        obj_id = gt_obj_id(gt_path, str(im_id), gt_idx, gt)
        R_cam_model, t_cam_model = gt_pose(gt_path, im_id, gt_idx, gt)
        K, depth_scale = camera_K(cam_path, self._read_json(cam_path), im_id)
        if self.category_of_object(obj_id) is None:
            raise DatasetError(f"object {obj_id} in {gt_path} is not in dataset.categories; add it there")

        depth_path = self.layout.depth(scene_id, im_id)
        raw_depth = read_depth(depth_path)
        depth_mm = scaled_depth(raw_depth, depth_scale)
        h, w = depth_mm.shape
        camera = PinholeCamera.from_K(K, w, h)
        T_camera_model = make_T(R_cam_model, t_cam_model)

        mask_path = self.layout.mask_visib(scene_id, im_id, gt_idx)
        rendered = None
        if self.mask != "render" and mask_path.is_file():
            mask, source = read_mask_png(mask_path), "mask_visib"
            if mask.shape != depth_mm.shape:
                raise DatasetError(f"{mask_path} is {mask.shape[::-1]} but the depth image is {(w, h)}")
        elif self.mask == "mask_visib":
            raise DatasetError(f"{mask_path} does not exist; set dataset.mask=auto to render the model instead")
        else:
            v_mm, f = self.model_mm(obj_id)
            rendered = render_depth(v_mm, f, T_camera_model, camera).astype(np.float64)
            mask = (rendered > 0) & (depth_mm > 0) & (np.abs(depth_mm - rendered) < self.depth_tolerance_mm)
            source = "render"
        mask &= depth_mm > 0
        n_pix = int(mask.sum())
        if n_pix < max(self.min_visible_pixels, 1):
            raise DatasetError(
                f"object {obj_id} has {n_pix} visible pixels in {depth_path} (mask: {source}); "
                f"at least {self.min_visible_pixels} are needed"
            )
        if self.mask_noise > 0:  # corrupted as a segmenter's masks are, after the visible-pixel check
            mask = corrupt_mask(mask, depth_mm, self.mask_noise, self.seed, obs_id)
        try:
            frame = DepthFrame(raw_depth, K, mask, depth_scale, frame_id=obs_id, seed=self.seed)
        except InvalidInputError as e:
            raise DatasetError(f"{depth_path}: {e}") from None
        return BopFrame(
            frame,
            None if rendered is None else rendered > 0,
            category,
            scene_id,
            im_id,
            gt_idx,
            obj_id,
            T_camera_model,
            depth_path,
            source,
        )

    def observation(self, obs_id: str) -> Observation:
        bf = self.instance_frame(obs_id)
        category, scene_id, im_id, gt_idx, obj_id = bf.category, bf.scene_id, bf.im_id, bf.gt_idx, bf.obj_id
        R_cam_model, t_cam_model = bf.T_camera_model[:3, :3], bf.T_camera_model[:3, 3]
        R_obj_model, centre, scale = self.normalisation(obj_id)
        # the same frame -> view path as catpose.register(DepthFrame(...)) (datasets/frame_view.py)
        try:
            view = frame_view(bf.frame, scale, self.frame_settings, exclude=bf.exclude, source=str(bf.depth_path))
        except NoGroundPlane as e:
            raise DatasetError(str(e)) from None
        depth_mm = float(np.median(bf.frame.depth_in_unit[bf.frame.object_pixels]))
        pts = view.points_camera
        radius = norm3(pts.max(axis=0) - pts.min(axis=0)) / 2 if len(pts) else 0.0
        if not (0.5 < depth_mm / t_cam_model[2] < 2 and radius > 0.05):  # a view spans 0.3 to 1.2 model radii
            raise DatasetError(
                f"{bf.depth_path}: object {obj_id} is seen at {depth_mm:.4g} mm but cam_t_m2c puts it at "
                f"{t_cam_model[2]:.4g} mm, and its visible points span {radius:.3g} radii of its model "
                f"{self.layout.model(obj_id)}: the depth and the model are in different units; fix depth_scale in "
                "scene_camera.json or the model's unit (mm)"
            )

        # p_object = R_obj_model R^T (p_cam - t) / s - centre / s, with p_cam in mm
        R_object_camera = matmul3(R_obj_model, R_cam_model.T)
        T_object_camera = make_T(R_object_camera, -(apply_R(R_object_camera, t_cam_model) + centre) / scale)
        up_camera = apply_R(R_object_camera.T, np.array([0.0, 0.0, 1.0]))
        ground_err = float(np.degrees(libm.arccos(np.clip(dot3(view.ground_normal_camera, up_camera), -1.0, 1.0))))
        return Observation(
            obs_id=obs_id,
            category=category,
            instance_id=f"obj_{obj_id:06d}",
            points_camera=view.points_camera,
            normals_camera=view.normals_camera,
            ground_normal_camera=view.ground_normal_camera,
            T_object_camera=T_object_camera,
            symmetry_axis=self.symmetry_axis(obj_id, category),
            symmetries=self.discrete_symmetries(obj_id),
            depth_image=view.depth_image,
            info={
                "scene_id": scene_id,
                "im_id": im_id,
                "gt_idx": gt_idx,
                "obj_id": obj_id,
                "mask_source": bf.mask_source,
                "visible_pixels": view.visible_pixels,
                "ground_inliers": view.ground_inliers,
                "ground_vs_object_up_deg": ground_err,
                "scale_mm": scale,
                "centre_mm": [float(x) for x in centre],
                "R_object_model": [float(x) for x in R_obj_model.ravel()],
                "bop_filters": "; ".join(self.filters) or "none",
            },
        )
