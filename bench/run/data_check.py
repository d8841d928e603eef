"""``bench data check dataset=NAME dataset.root=PATH``: is a dataset root laid out as its loader expects?

Walks the layout with the loader's own code (the dataset object built from the config exactly as
``bench run`` builds it, :class:`~catpose.datasets.bop_layout.BopLayout` and the BOP JSON
readers), in seconds and without loading every sample: folders, every JSON file parsed, the
files the frames and templates reference, one file of each kind read, and finally the loader's
sample list and its first sample loaded. Prints one line per problem with its fix (``problem:``)
and exits 2 when there is any; things that only limit some protocols are ``warning:`` lines
(exit 0). On an empty folder it stops after the first missing level (at most two lines).
Layouts and downloads: docs/data.md.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from catpose.errors import CatposeError, ConfigError, one_line

_USAGE = """usage: bench data check dataset=NAME dataset.root=PATH [dataset.KEY=VALUE ...]

Check that a dataset root has the layout its loader expects (docs/data.md), in seconds: prints one
line per problem with the fix and exits 2 when there is any, 0 when the root is good."""

#: BOP dataset config name -> (prefix of its archives, its test archive) (docs/data.md)
_BOP_ARCHIVES = {
    "ycbv": ("ycbv", "ycbv_test_bop19.zip"),
    "tyol": ("tyol", "tyol_test_bop19.zip"),
    "lmo": ("lmo", "lmo_test_bop19.zip"),
    "tless": ("tless", "tless_test_primesense_bop19.zip"),
}


@dataclass
class Report:
    """Problems (the run would fail), warnings (some protocols would) and facts found."""

    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    facts: list[str] = field(default_factory=list)

    def problem(self, text: str) -> None:
        self.problems.append(text)

    def warn(self, text: str) -> None:
        self.warnings.append(text)


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help") or any(a in ("-h", "--help") for a in argv):
        print(_USAGE)
        return 0
    if argv[0] != "check":
        raise ConfigError(f"unknown data command {argv[0]!r}; use: bench data check dataset=NAME dataset.root=PATH")
    overrides = argv[1:]
    if not any(a.split("=", 1)[0].lstrip("+~") == "dataset" for a in overrides):
        raise ConfigError("name the dataset: bench data check dataset=NAME dataset.root=PATH")
    t0 = time.perf_counter()
    name, node = _dataset_config(overrides)
    report = check(name, node)
    for line in report.problems:
        print(f"problem: {line}")
    if report.problems:
        return 2
    for line in report.warnings:
        print(f"warning: {line}")
    for line in report.facts:
        print(f"ok: {line}")
    where = f" root={node.root}" if "root" in list(node.keys()) else ""
    print(f"bench data check: dataset={name}{where} is good ({time.perf_counter() - t0:.1f} s)")
    return 0


def _dataset_config(overrides: list[str]) -> tuple[str, Any]:
    """The composed ``dataset`` node, as ``bench run`` composes it (one-line errors)."""
    from catpose.bench.run.config import compose

    cfg = compose(overrides)
    return str(cfg.dataset.get("name", "dataset")), cfg.dataset


def check(name: str, node: Any) -> Report:
    """Check the dataset of config ``node`` (the composed ``dataset`` group)."""
    from omegaconf import OmegaConf

    from catpose.bench.run.build import build_from_config

    report = Report()
    target = str(node.get("_target_", ""))
    if target.endswith(".SyntheticDataset"):
        report.facts.append(f"dataset={name} is generated (no files, no root to check)")
        return report
    if target.endswith(".Procedural"):
        report.facts.append(f"dataset={name} is generated into the cache on first use (no root to check)")
        return report
    if "root" in list(node.keys()) and OmegaConf.is_missing(node, "root"):
        report.problem(f"dataset.root is not set: bench data check dataset={name} dataset.root=PATH")
        return report
    root = Path(str(node.root))
    if not root.is_dir():
        report.problem(f"{root} is not a folder: set dataset.root to the unpacked dataset (docs/data.md)")
        return report
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, dataset = build_from_config(node, "dataset")
    except CatposeError as e:
        report.problem(f"{e}")
        return report
    walk = {
        "BOP": _check_bop,
        "ModelNet40": _check_modelnet40,
        "ModelNet40Resampled": _check_resampled,
        "Redwood": _check_redwood,
    }.get(type(dataset).__name__)
    if walk is not None:
        walk(name, dataset, report)
    if not report.problems:
        _check_loader(dataset, report)
    return report


def _check_loader(dataset: Any, report: Report) -> None:
    """The loader's own sample list, and its first sample loaded (what ``bench run`` does first)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            ids = dataset.observation_ids()
            obs = dataset.observation(ids[0])
        except CatposeError as e:
            report.problem(str(e))
            return
        except Exception as e:  # noqa: BLE001 - a malformed file surfaces as anything; name it
            report.problem(f"loading the first sample failed: {one_line(e)}")
            return
    report.warnings += [" ".join(str(w.message).split()) for w in caught]
    report.facts.append(f"{len(ids)} samples; the first ({ids[0]}) loads with {len(obs.points_camera)} points")


def _check_templates(dataset: Any, report: Report, instance_exists) -> None:
    """Every configured template resolves: a mesh file, or an instance ``instance_exists`` knows."""
    from catpose.datasets.meshio import MESH_SUFFIXES, template_spec_from_dict

    tset = getattr(dataset, "_templates", None)
    if tset is None:
        return
    for category, entries in tset.entries.items():
        for entry in entries:
            if isinstance(entry, str) and not entry.lower().endswith(MESH_SUFFIXES):
                if not instance_exists(category, entry):
                    report.warn(
                        f"template {entry} of {category} does not exist; protocol=templates needs it: fix "
                        f"dataset.templates.{category}"
                    )
                continue
            try:
                path = Path(template_spec_from_dict(category, entry).path)
            except CatposeError as e:
                report.problem(str(e))
                continue
            full = path if path.is_absolute() or tset.base_dir is None else tset.base_dir / path
            if not full.is_file():
                report.warn(
                    f"template mesh {full} of {category} does not exist; protocol=templates needs it: set "
                    "dataset.templates_root to the folder of the template meshes"
                )


# --------------------------------------------------------------------------- BOP


def _check_bop(name: str, ds: Any, report: Report) -> None:
    from catpose.datasets.bop_layout import camera_K, gt_obj_id, gt_pose, read_json, read_targets, visible_fractions
    from catpose.datasets.depthio import read_depth

    layout = ds.layout
    prefix, test_zip = _BOP_ARCHIVES.get(name, ("<dataset>", "<dataset>_test_bop19.zip"))
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
    scenes = sorted(p for p in split_dir.iterdir() if p.is_dir() and p.name.isdigit())
    if ds.scenes is not None and scenes and not [s for s in scenes if int(s.name) in ds.scenes]:
        have = ", ".join(str(int(s.name)) for s in scenes[:8]) + (", ..." if len(scenes) > 8 else "")
        report.problem(
            f"dataset.scenes={list(ds.scenes)} names none of the {len(scenes)} scenes in {split_dir} ({have})"
        )
        return
    if ds.scenes is not None:
        scenes = [s for s in scenes if int(s.name) in ds.scenes]
    if not scenes:
        report.problem(
            f"{split_dir} has no scene folders (000001, ...): unzip {test_zip} into "
            f"{layout.root}, or check dataset.split and dataset.scenes"
        )
        return
    frames, objects, missing_depth, first_depth, expected = 0, set(), 0, None, None
    size = _camera_size(layout.root)
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
    _check_bop_files(layout, scenes, objects, report)
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

    _check_templates(ds, report, model_exists)


def _camera_size(root: Path) -> tuple[int, int] | None:
    """``(width, height)`` of a BOP dataset's ``camera.json``, None without one."""
    import json

    try:
        cam = json.loads((Path(root) / "camera.json").read_text())
        return int(cam["width"]), int(cam["height"])
    except (OSError, KeyError, TypeError, ValueError):
        return None


def _note_files(report: Report, problems: list[str], kind: str) -> None:
    """The first problems of one kind of file, and how many more."""
    for line in problems[:3]:
        report.problem(line)
    if len(problems) > 3:
        report.problem(f"... and {len(problems) - 3} more {kind} like those")


def _check_bop_files(layout: Any, scenes: list[Path], objects: set[int], report: Report) -> None:
    """Every depth image and visible-object mask (PNG: 16-bit and one channel for depth, whole,
    one size: camera.json's or the first image's) and every model the frames show (PLY: as long as
    its header says), from headers and sizes (:mod:`catpose.bench.run.file_headers`)."""
    from catpose.bench.run.file_headers import ply_problem, png_problem, png_size

    size = _camera_size(layout.root)
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
    _note_files(report, depth_problems, "depth images")
    _note_files(report, mask_problems, "masks")
    models = [layout.model(o) for o in sorted(objects) if layout.model(o).is_file()]
    _note_files(report, [w for w in map(ply_problem, models) if w], "models")
    report.facts.append(
        f"headers: {counts[0]} depth PNGs, {counts[1]} masks and {len(models)} models whole"
        + (f", images {size[0]}x{size[1]}" if size else "")
    )


# --------------------------------------------------------------------------- ModelNet40


def _check_modelnet40(name: str, ds: Any, report: Report) -> None:
    from catpose.datasets.meshio import read_off
    from catpose.resting import solid_hull

    present = {c: ds.instance_ids(c) for c in ds.categories}
    if not any(present.values()):
        report.problem(
            f"no {ds.split}-split OFF files under {ds.root}/<category>/{ds.split}/ for {ds.categories}: set "
            "dataset.root to the unpacked ModelNet40 folder (it holds airplane/, chair/, ...)"
        )
        return
    for c, ids in present.items():
        if not ids:
            report.problem(f"{ds.root / c / ds.split} has no .off files: check dataset.categories and dataset.split")
    if report.problems:
        return
    first = next(ids for ids in present.values() if ids)[0]
    category = next(c for c, ids in present.items() if first in ids)
    path = ds.root / category / ds.split / f"{first}.off"
    try:
        if solid_hull(read_off(path)[0]) is None:
            report.problem(f"{path} is flat (no volume): ours has no resting pose for it; replace it with a solid mesh")
    except CatposeError as e:
        report.problem(str(e))
    report.facts.append(f"{sum(map(len, present.values()))} {ds.split}-split shapes in {len(present)} categories")
    _check_templates(ds, report, lambda c, inst: inst in ds.instance_ids(c, ds.template_split))


def _check_resampled(name: str, ds: Any, report: Report) -> None:
    from catpose.datasets.modelnet40_resampled import read_resampled_txt

    try:
        ids = ds.split_ids()
    except CatposeError as e:
        report.problem(f"{e} (unzip modelnet40_normal_resampled.zip and set dataset.root to its folder)")
        return
    wanted = [i for i in ids if ds.categories is None or ds.category_of_instance(i) in ds.categories]
    if not wanted:
        report.problem(f"modelnet40_{ds.split}.txt lists no shapes of {ds.categories}: check dataset.categories")
        return
    missing = [i for i in wanted if not (ds.root / ds.category_of_instance(i) / f"{i}.txt").is_file()]
    if missing:
        report.problem(
            f"{len(missing)} of {len(wanted)} shapes listed in modelnet40_{ds.split}.txt are missing "
            f"(first: {ds.root / ds.category_of_instance(missing[0]) / (missing[0] + '.txt')}): re-unzip"
        )
        return
    try:
        read_resampled_txt(ds.root / ds.category_of_instance(wanted[0]) / f"{wanted[0]}.txt")
    except CatposeError as e:
        report.problem(str(e))
    report.facts.append(f"{len(wanted)} {ds.split}-split clouds listed and present")
    _check_templates(ds, report, lambda _c, inst: inst in ds.split_ids(ds.template_split))


# --------------------------------------------------------------------------- Redwood


def _check_redwood(name: str, ds: Any, report: Report) -> None:
    from catpose.datasets.depthio import read_depth_png

    try:
        scans = ds.scan_dirs()
    except CatposeError as e:
        report.problem(str(e))
        return
    if not scans:
        report.problem(
            f"no scan folders with depth/ under {ds.root}: unzip each scan <id>.zip into "
            f"{ds.root}/<category>_<id>/ (docs/data.md)"
        )
        return
    no_trajectory = []
    for scan in scans:
        try:
            ds.category_of_scan(scan.name)
            files = ds.frame_files(scan.name)
            poses = ds.poses(scan.name)
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
    try:
        read_depth_png(ds.frame_files(scans[0].name)[0])
    except CatposeError as e:
        report.problem(str(e))
    from catpose.bench.run.file_headers import png_problem, png_size

    files = [f for scan in scans for f in ds.frame_files(scan.name)]
    size = png_size(files[0]) if files else None
    _note_files(report, [w for w in (png_problem(f, size, True) for f in files) if w], "depth images")
    report.facts.append(f"{len(scans)} scans with depth/, {len(files)} depth images whole")
    _check_templates(ds, report, lambda _c, _i: False)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
