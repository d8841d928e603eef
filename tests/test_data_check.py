"""``bench data check``: a good root passes, a bad one fails in one line per problem, with the fix."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from catpose.bench.run.config import available
from catpose.bench.run.data_check import main

REPO = Path(__file__).resolve().parents[1]
BENCH = [sys.executable, "-m", "catpose.bench.cli"]
ROOTED = [d for d in available("dataset") if d != "synthetic"]  # generated: no root


def _check(capsys, *overrides: str) -> tuple[int, list[str]]:
    code = main(["check", *overrides])
    out = capsys.readouterr()
    return code, [ln for ln in (out.out + out.err).splitlines() if ln.strip()]


@pytest.mark.parametrize("name", ROOTED)
def test_empty_folder_fails_in_at_most_two_lines(name, tmp_path, capsys):
    code, lines = _check(capsys, f"dataset={name}", f"dataset.root={tmp_path}")
    assert code == 2
    assert 1 <= len(lines) <= 2, lines
    assert all(ln.startswith("problem: ") and str(tmp_path) in ln for ln in lines), lines


def test_cli_exit_code_and_lines_on_an_empty_folder(tmp_path):
    env = dict(os.environ, HYDRA_FULL_ERROR="0")
    r = subprocess.run(
        [*BENCH, "data", "check", "dataset=ycbv", f"dataset.root={tmp_path}"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert r.returncode == 2
    lines = (r.stdout + r.stderr).strip().splitlines()
    assert lines == [
        f"problem: {tmp_path}/models does not exist: unzip ycbv_models.zip into {tmp_path}",
        f"problem: {tmp_path}/test does not exist: unzip ycbv_test_bop19.zip into {tmp_path}",
    ]


def test_missing_root_and_synthetic(capsys, tmp_path):
    code, lines = _check(capsys, "dataset=tless")
    assert code == 2 and lines == ["problem: dataset.root is not set: bench data check dataset=tless dataset.root=PATH"]
    code, lines = _check(capsys, "dataset=redwood", f"dataset.root={tmp_path / 'nope'}")
    assert code == 2 and len(lines) == 1 and "is not a folder" in lines[0]
    code, lines = _check(capsys, "dataset=synthetic")
    assert code == 0 and "generated" in lines[0]


@pytest.mark.data
def test_shared_ycbv_passes(shared_data, capsys):
    code, lines = _check(capsys, "dataset=ycbv", f"dataset.root={shared_data / 'bop' / 'ycbv'}")
    assert code == 0, lines
    assert any("2 scenes, 19 frames with depth, objects [1, 5, 9]" in ln for ln in lines), lines
    assert any(ln.startswith("ok: 38 samples") for ln in lines), lines
    assert lines[-1].startswith("bench data check: dataset=ycbv root=") and "is good" in lines[-1]


@pytest.mark.data
@pytest.mark.parametrize(
    "name, folder",
    [
        ("tyol", "bop/tyol"),
        ("modelnet40", "ModelNet40"),
        ("modelnet40_resampled", "modelnet40_normal_resampled"),
        ("redwood", "redwood"),
    ],
)
def test_other_shared_roots_pass(shared_data, capsys, name, folder):
    code, lines = _check(capsys, f"dataset={name}", f"dataset.root={shared_data / folder}")
    assert code == 0, lines


@pytest.mark.data
def test_a_broken_copy_of_ycbv_names_each_problem(shared_data, tmp_path, capsys):
    src = shared_data / "bop" / "ycbv"
    root = tmp_path / "ycbv"
    shutil.copytree(src / "test", root / "test")
    (root / "models").mkdir()
    shutil.copy(src / "models" / "models_info.json", root / "models")
    shutil.copy(src / "models" / "obj_000001.ply", root / "models")
    (root / "test" / "000002" / "scene_camera.json").write_text("{not json")
    code, lines = _check(capsys, "dataset=ycbv", f"dataset.root={root}")
    assert code == 2 and len(lines) == 1
    assert "000002/scene_camera.json is not valid JSON" in lines[0] and "re-download it" in lines[0]
    shutil.copy(src / "test" / "000002" / "scene_camera.json", root / "test" / "000002")
    code, lines = _check(capsys, "dataset=ycbv", f"dataset.root={root}")
    assert code == 2 and lines == [
        f"problem: 2 objects the frames show have no model in {root / 'models'} "
        f"(obj_000005.ply, ...): unzip ycbv_models.zip into {root}"
    ]


def test_bop_split_and_models_dir_hints(tmp_path, capsys):
    (tmp_path / "models_eval").mkdir()
    (tmp_path / "test_primesense").mkdir()
    code, lines = _check(capsys, "dataset=bop", f"dataset.root={tmp_path}")
    assert code == 2
    assert lines == [
        f"problem: {tmp_path}/models does not exist: unzip <dataset>_models.zip into {tmp_path} or set "
        "dataset.models_dir to one of ['models_eval']",
        f"problem: {tmp_path}/test does not exist: unzip <dataset>_test_bop19.zip into {tmp_path} or set "
        "dataset.split to one of ['test_primesense']",
    ]


def test_bop_scene_gt_without_depth(tmp_path, capsys):
    scene = tmp_path / "test" / "000001"
    scene.mkdir(parents=True)
    (tmp_path / "models").mkdir()
    (scene / "scene_gt.json").write_text(
        json.dumps({"0": [{"obj_id": 1, "cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 500]}]})
    )
    (scene / "scene_camera.json").write_text(json.dumps({"0": {"cam_K": [300, 0, 160, 0, 300, 120, 0, 0, 1]}}))
    code, lines = _check(capsys, "dataset=bop", f"dataset.root={tmp_path}")
    assert code == 2 and len(lines) == 1 and "no depth images under" in lines[0] and "000000.png" in lines[0]


def test_a_flat_modelnet40_shape_is_a_problem(tmp_path, capsys):
    """Issue 60 case 23: a two-triangle unit square, on which ours' resting poses never end."""
    shape = tmp_path / "thing/train/thing_0001.off"
    shape.parent.mkdir(parents=True)
    shape.write_text("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    code, lines = _check(capsys, "dataset=modelnet40", f"dataset.root={tmp_path}", "dataset.categories=[thing]")
    assert code == 2 and f"problem: {shape} is flat (no volume)" in lines[0], lines


def test_issue60_bad_ground_truth_and_scenes_are_problems(tmp_path, capsys):
    """Issue 60 cases 6 (a zero cam_R_m2c passed as good), 27 (dataset.scenes=[99] said "no scene
    folders") and a camera behind the object (cam_t_m2c z < 0)."""
    sys.path.insert(0, str(REPO / "tests"))
    from test_loaders_bop import bop_root

    root = bop_root.__wrapped__(tmp_path)
    base = ["dataset=bop", f"dataset.root={root}"]
    shutil.copy(root / "models/obj_000001.ply", root / "models/obj_000004.ply")  # a model for every object
    code, lines = _check(capsys, *base)
    assert code == 0, lines
    assert any("1 scenes have no mask_visib/ (e.g. 000001): their masks are rendered" in ln for ln in lines), lines
    gt_path = root / "test/000001/scene_gt.json"
    good = gt_path.read_text()
    for key, value, said in (
        ("cam_R_m2c", [0.0] * 9, "cam_R_m2c is not a rotation"),
        ("cam_t_m2c", [0.0, 0.0, -500.0], "cam_t_m2c has z <= 0 (behind the camera)"),
    ):
        data = json.loads(good)
        data["0"][0][key] = value
        gt_path.write_text(json.dumps(data))
        code, lines = _check(capsys, *base)
        assert code == 2 and any(said in ln for ln in lines), lines
    gt_path.write_text(good)
    cam_path = root / "test/000001/scene_camera.json"
    cams = json.loads(cam_path.read_text())
    (root / "camera.json").write_text(json.dumps({"width": 640, "height": 480}))
    cam_path.write_text(
        json.dumps({k: {**c, "cam_K": [*c["cam_K"][:2], 1e6, *c["cam_K"][3:]]} for k, c in cams.items()})
    )
    code, lines = _check(capsys, *base)  # "also worth a line": cx = 1e6 passed as good
    assert code == 2 and any("outside the 640x480 image; fix cx, cy" in ln for ln in lines), lines
    cam_path.write_text(json.dumps(cams))
    code, lines = _check(capsys, *base, "dataset.scenes=[99]")
    assert code == 2 and lines == [
        f"problem: dataset.scenes lists [99], which has no folder under {root / 'test'} (its scenes: 1); fix dataset.scenes"
    ]


class _NewDataset:
    """A dataset data_check.py does not name: its own ``check_layout`` is what is asked."""

    def __init__(self, root: str) -> None:
        self.root = Path(root)

    def check_layout(self, name, report):
        report.problem(f"{self.root}/scans is missing ({name})")


class _NewGenerated:
    generated = "made up on the spot (no root to check)"


def test_a_new_dataset_checks_its_own_layout_without_data_check_naming_it(tmp_path):
    from omegaconf import OmegaConf

    from catpose.bench.run.data_check import check

    node = OmegaConf.create({"name": "new", "_target_": f"{__name__}._NewDataset", "root": str(tmp_path)})
    assert check("new", node).problems == [f"{tmp_path}/scans is missing (new)"]
    report = check("gen", OmegaConf.create({"name": "gen", "_target_": f"{__name__}._NewGenerated"}))
    assert report.problems == [] and report.facts == ["dataset=gen is made up on the spot (no root to check)"]
