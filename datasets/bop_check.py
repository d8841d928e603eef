"""``bench data check`` of a BOP root (:meth:`catpose.datasets.bop.BOP.check_layout`): folders, every
JSON file parsed, the files the frames reference, and every depth image, mask and model whole by its
header and chunks (Pillow's PNG ``verify``) or by reading it (trimesh). Archive names: docs/data.md."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from catpose.datasets.bop_layout import camera_K, gt_obj_id, gt_pose, read_json, read_targets, visible_fractions
from catpose.datasets.depthio import png_problem, png_size, read_depth
from catpose.datasets.layout_check import LayoutReport, check_templates
from catpose.datasets.meshio import mesh_problem
from catpose.errors import CatposeError

#: BOP dataset config name -> (prefix of its archives, its test archive) (docs/data.md)
BOP_ARCHIVES = {
    "ycbv": ("ycbv", "ycbv_test_bop19.zip"),
    "tyol": ("tyol", "tyol_test_bop19.zip"),
    "lmo": ("lmo", "lmo_test_bop19.zip"),
    "tless": ("tless", "tless_test_primesense_bop19.zip"),
}


def check_bop(name: str, ds: Any, report: LayoutReport) -> None:
    """The layout of BOP dataset ``ds`` (config name ``name``)."""
    layout = ds.layout
    prefix, test_zip = BOP_ARCHIVES.get(name, ("<dataset>", "<dataset>_test_bop19.zip"))
    models_dir, split_dir = layout.root / layout.models_dir, layout.split_dir()
    if not models_dir.is_dir():
        others = sorted(p.name for p in layout.root.glob("models*") if p.is_dir())
        hint = f" or set dataset.models_dir to one of {others}" if others else ""
        report.problem(f"{models_dir} does not exist: unzip {prefix}_models.zip into {layout.root}{hint}")
    if not split_dir.is_dir():
        others = sorted(p.name for p in layout.root.iterdir() if p.is_dir() and p.name.startswith(("test", "val")))
        hint = f" or set dataset.split to one of {others}" if others else ""
        report.problem(f"{split_dir} does not exist: unzip {test_zip} into {layout.root}{hint}")
    if report.problems:
        return
    try:
        if layout.models_info().is_file():
            read_json(layout.models_info())
        else:
            report.warn(f"{layout.models_info()} is missing: every object is scored as non-symmetric")
        if ds.targets is not None:
            path = layout.targets(ds.targets)
            if path.is_file():
                report.facts.append(f"{path.name}: {len(read_targets(path))} (scene, image, object) targets")
            else:
                report.warn(
                    f"{path} is missing: every frame is used, not BOP's target list (unzip {prefix}_base.zip "
                    f"into {layout.root})"
                )
    except CatposeError as e:
        report.problem(str(e))
    try:
        scenes = ds.scene_dirs()
    except CatposeError as e:
        report.problem(str(e))
        return
    if not scenes:
        report.problem(
            f"{split_dir} has no scene folders (000001, ...): unzip {test_zip} into "
            f"{layout.root}, or check dataset.split and dataset.scenes"
        )
        return
    frames, objects, missing_depth, first_depth, expected = 0, set(), 0, None, None
    size = camera_size(layout.root)
    for scene in scenes:
        sid = int(scene.name)
        try:
            gt = read_json(layout.scene_gt(sid))
            cam_path = layout.scene_camera(sid)
            cameras = read_json(cam_path)
            visible_fractions(layout.scene_gt_info(sid))
            if not isinstance(gt, dict):
                raise CatposeError(f"{layout.scene_gt(sid)} must map image ids to lists of objects (BOP format)")
            for im_key, entries in gt.items():
                for i, e in enumerate(entries if isinstance(entries, list) else []):
                    objects.add(gt_obj_id(layout.scene_gt(sid), im_key, i, e))
                    if gt_pose(layout.scene_gt(sid), im_key, i, e)[1][2] <= 0:
                        raise CatposeError(
                            f"{layout.scene_gt(sid)}: image {im_key}, object index {i}: cam_t_m2c has z <= 0 (behind "
                            "the camera); fix the file (mm, camera frame)"
                        )
                if layout.depth(sid, int(im_key)).is_file():
                    frames += 1
                    K = camera_K(cam_path, cameras, im_key)[0]
                    if size and not (0 <= K[0, 2] <= size[0] and 0 <= K[1, 2] <= size[1]):
                        raise CatposeError(
                            f"{cam_path}: cam_K of image {im_key} puts the principal point ({K[0, 2]:g}, {K[1, 2]:g}) "
                            f"outside the {size[0]}x{size[1]} image; fix cx, cy (pixels)"
                        )
                    first_depth = first_depth or layout.depth(sid, int(im_key))
                else:
                    missing_depth += 1
                    expected = expected or layout.depth(sid, int(im_key))
        except CatposeError as e:
            report.problem(str(e))
        except ValueError:
            report.problem(f"{layout.scene_gt(sid)} has a non-integer image id: BOP keys are image numbers")
    if report.problems:
        return
    if frames == 0:
        report.problem(
            f"no depth images under {split_dir} (e.g. {expected} for the first frame of scene_gt.json): "
            f"unzip {test_zip} into {layout.root}, or set dataset.depth_ext / dataset.sensor"
        )
        return
    if missing_depth:
        report.warn(
            f"{missing_depth} frames of scene_gt.json have no depth image (left out by the loader, or failed samples "
            "where the target list names them)"
        )
    models = [o for o in sorted(objects) if not layout.model(o).is_file()]
    if models:
        report.problem(
            f"{len(models)} objects the frames show have no model in {models_dir} "
            f"(obj_{models[0]:06d}.ply, ...): unzip {prefix}_models.zip into {layout.root}"
        )
    check_bop_files(layout, scenes, objects, report)
    try:
        read_depth(first_depth)
    except CatposeError as e:
        report.problem(str(e))
    report.facts.append(f"{layout.split}/: {len(scenes)} scenes, {frames} frames with depth, objects {sorted(objects)}")

    def model_exists(_category: str, instance: str) -> bool:
        try:
            return layout.model(ds._obj_id(instance)).is_file()
        except CatposeError:
            return False

    check_templates(ds, report, model_exists)


def check_bop_files(layout: Any, scenes: list[Path], objects: set[int], report: LayoutReport) -> None:
    """Every depth image and visible-object mask (PNG: 16-bit and one channel for depth, whole,
    one size: camera.json's or the first image's; Pillow's ``verify``, nothing decoded) and every
    model the frames show (read whole: :func:`~catpose.datasets.meshio.mesh_problem`)."""
    size = camera_size(layout.root)
    depth_problems, mask_problems, counts = [], [], [0, 0]
    for scene in scenes:  # the folders of the configured sensor only (their images share one size)
        sid = int(scene.name)
        folders = (
            (layout.depth(sid, 0).parent, depth_problems, True),
            (layout.mask_visib(sid, 0, 0).parent, mask_problems, False),
        )
        for k, (folder, problems, depth16) in enumerate(folders):
            for png in sorted(folder.glob("*.png")):
                counts[k] += 1
                size = size or png_size(png)
                why = png_problem(png, size, depth16)
                if why:
                    problems.append(why)
    no_masks = [s.name for s in scenes if not layout.mask_visib(int(s.name), 0, 0).parent.is_dir()]
    if no_masks:
        report.warn(
            f"{len(no_masks)} scenes have no mask_visib/ (e.g. {no_masks[0]}): their masks are rendered from the model "
            "and the ground truth pose, not measured; unzip the dataset's masks for BOP's visible masks"
        )
    report.note_files(depth_problems, "depth images")
    report.note_files(mask_problems, "masks")
    models = [layout.model(o) for o in sorted(objects) if layout.model(o).is_file()]
    report.note_files([w for w in map(mesh_problem, models) if w], "models")
    report.facts.append(
        f"headers: {counts[0]} depth PNGs, {counts[1]} masks and {len(models)} models whole"
        + (f", images {size[0]}x{size[1]}" if size else "")
    )


def camera_size(root: Path) -> tuple[int, int] | None:
    """``(width, height)`` of a BOP dataset's ``camera.json``, None without one."""
    try:
        cam = json.loads((root / "camera.json").read_text())
        return int(cam["width"]), int(cam["height"])
    except (OSError, KeyError, TypeError, ValueError):
        return None
