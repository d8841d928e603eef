"""Real depth frames in the official BOP layout (TYO-L, or any BOP dataset).

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
model's bounding-box centre, farthest vertex at 1). Observed points are divided by the same
scale, so ``points_camera`` and ``T_object_camera`` are in the object-normalised unit.
Symmetric objects (``symmetries_continuous`` in ``models_info.json``, or a ``symmetric``
category entry) are scored by main-axis error.

Observation ids: ``<category>/<scene_id:06d>/<im_id:06d>/<gt_idx>``.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from catpose.datasets.bop_check import check_bop
from catpose.datasets.bop_frames import BopFrames
from catpose.datasets.bop_layout import BopLayout, camera_K, gt_obj_id, read_json, read_targets, visible_fractions
from catpose.datasets.bop_models import BopModels
from catpose.datasets.dataset import ObjectDataset
from catpose.datasets.layout_check import LayoutReport
from catpose.datasets.templates import TemplateOptions
from catpose.errors import ConfigError, DatasetError
from catpose.types import Template


class BOP(BopModels, BopFrames, ObjectDataset):
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
        self.plane_distance_mm = float(plane_distance_mm)
        self.plane_iterations = int(plane_iterations)
        self.plane_max_points = int(plane_max_points)
        self.normal_radius = float(normal_radius)
        self.max_points = int(max_points)
        self.template_points = int(template.template_points)
        self.seed = int(seed)
        self._templates = template.template_set(self.root, self.seed, self.instance_model)
        self._json: dict[Path, Any] = {}
        self._models_mm: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._norm: dict[int, tuple[np.ndarray, np.ndarray, float]] = {}
        self._instances: dict[int, Template] = {}
        self._ids: list[str] | None = None
        self._warned_no_info: set[int] = set()

    def instance_frame(self, obs_id: str):
        """The frames' loader's frame (:meth:`BopFrames.instance_frame`), its mask corrupted when
        ``mask_noise`` > 0."""
        bf = super().instance_frame(obs_id)
        if self.mask_noise <= 0:
            return bf
        from dataclasses import replace

        from catpose.datasets.mask_noise import corrupt_mask

        f = bf.frame
        return bf._replace(
            frame=replace(f, mask=corrupt_mask(f.mask, f.depth_in_unit, self.mask_noise, self.seed, obs_id))
        )

    def check_layout(self, name: str, report: LayoutReport) -> None:
        check_bop(name, self, report)

    # ------------------------------------------------------------------ files
    def _scene_dir(self, scene_id: int) -> Path:
        return self.layout.scene_dir(scene_id)

    def _read_json(self, path: Path) -> Any:
        if path not in self._json:
            self._json[path] = read_json(path)
        return self._json[path]

    def category_of_object(self, obj_id: int) -> str | None:
        if self.categories is None:
            return f"obj_{obj_id:06d}"
        return self.categories.get(obj_id)

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
        scene_dirs = sorted(p for p in split_dir.iterdir() if p.is_dir() and p.name.isdigit())
        if self.scenes is not None:  # a scene named that has no folder is a typo, not an empty scene
            absent = sorted(self.scenes - {int(p.name) for p in scene_dirs})
            if absent:
                raise DatasetError(
                    f"dataset.scenes lists {absent}, which {'has' if len(absent) == 1 else 'have'} no folder under "
                    f"{split_dir} (its scenes: {', '.join(str(int(p.name)) for p in scene_dirs) or 'none'}); "
                    "fix dataset.scenes"
                )
        for scene_dir in scene_dirs:
            scene_id = int(scene_dir.name)
            if self.scenes is not None and scene_id not in self.scenes:
                continue
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
