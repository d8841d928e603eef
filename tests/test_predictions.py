"""BOP export and scoring of external predictions: a round trip gives the run's own errors."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from catpose.bench.interop import score as score_cmd
from catpose.bench.interop.bop_export import export_bop
from catpose.bench.interop.prediction_io import read_predictions
from catpose.bench.interop.score import score_predictions
from catpose.errors import InvalidInputError
from catpose.geometry import axis_angle_to_R, make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402


def _rows(info_fn=lambda i: {}) -> list[dict]:
    rng = np.random.default_rng(0)
    rows = []
    for i, (cat, err) in enumerate([("mug", 5.0), ("mug", 25.0), ("can", None), ("can", 70.0)]):
        T_gt = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3) + [0, 0, 3])
        row = {
            "sample_id": f"{cat}/i{i}/v0",
            "group_id": f"{cat}/i{i}/v0",
            "obs_id": f"{cat}/i{i}/v0",
            "category": cat,
            "instance_id": f"i{i}",
            "template_id": "own",
            "method": "ours",
            "dataset": "toy",
            "protocol": "gt_model",
            "seed": 0,
            "symmetric": False,
            "symmetry_axis": None,
            "T_gt": T_gt.reshape(-1).tolist(),
            "runtime_s": 0.25,
            "info": info_fn(i),
            "extras": {},
        }
        if err is None:
            row.update(status="failed", error="boom", err_deg=180.0, T_est=None, score=None)
        else:
            T_est = make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(err)), [0.01, 0, 0]) @ T_gt
            row.update(
                status="ok",
                error="",
                T_est=T_est.reshape(-1).tolist(),
                score=0.5,
                err_deg=err,
                rot_err_deg=err,
                trans_err=None,
            )
        rows.append(row)
    return rows


CFG = {
    "method": {"name": "ours", "_target_": "x.Y"},
    "dataset": {"name": "toy"},
    "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"},
    "seed": 0,
}


def _bop_info(i: int) -> dict:
    return {
        "scene_id": 19,
        "im_id": 10 + i,
        "obj_id": 1 + i,
        "scale_mm": 120.0,
        "centre_mm": [1.0, 2.0, 3.0],
        "R_object_model": axis_angle_to_R(np.array([1.0, 2, 3]), 0.4).ravel().tolist(),
    }


def test_bop_round_trip(tmp_path: Path):
    run = write_run(tmp_path / "run", _rows(_bop_info), CFG)
    out = tmp_path / "ours_toy-test.csv"
    assert export_bop(run, out) == 3  # the failed sample has no estimate
    lines = out.read_text().splitlines()
    assert lines[0] == "scene_id,im_id,obj_id,score,R,t,time"
    fields = lines[1].split(",")
    assert len(fields[4].split()) == 9 and len(fields[5].split()) == 3 and float(fields[6]) == pytest.approx(0.25)
    assert [int(x.split(",")[1]) for x in lines[1:]] == [10, 11, 13]
    scored = tmp_path / "scored"
    assert score_cmd.main([str(out), "--gt", str(run), "--method", "ours_again", "--out", str(scored)]) == 0
    back = [json.loads(x) for x in (scored / "samples.jsonl").read_text().splitlines()]
    errs = {r["sample_id"]: r["err_deg"] for r in back}
    assert errs["mug/i0/v0"] == pytest.approx(5.0, abs=1e-3) and errs["can/i3/v0"] == pytest.approx(70.0, abs=1e-3)
    assert errs["can/i2/v0"] == 180.0 and back[2]["error"] == "no prediction"
    trans = {r["sample_id"]: r["trans_err"] for r in back if r["status"] == "ok"}
    from catpose.bench.scoring.metrics import sample_errors

    r0 = _rows()[0]
    expected = sample_errors(np.reshape(r0["T_est"], (4, 4)), np.reshape(r0["T_gt"], (4, 4)))["trans_err"]
    assert trans["mug/i0/v0"] == pytest.approx(expected, abs=1e-5)
    summary = pd.read_csv(scored / "summary.csv").set_index("category")
    assert summary.loc["mug", "mean_err_deg"] == pytest.approx(15.0, abs=1e-3)
    assert json.loads((scored / "run.json").read_text())["method"] == "ours_again"


def test_per_sample_csv_and_best_score(tmp_path: Path):
    rows = _rows()
    run = write_run(tmp_path / "run", rows, CFG)
    lines = ["sample_id,R,t,score,time"]
    for r in rows[:2]:  # by sample id; T_template_camera convention; ground truth -> zero error
        T = np.asarray(r["T_gt"]).reshape(4, 4)
        lines.append(f"{r['obs_id']},{' '.join(map(str, T[:3, :3].ravel()))},{' '.join(map(str, T[:3, 3]))},0.1,2.0")
    (tmp_path / "p.csv").write_text("\n".join(lines) + "\n")
    preds = read_predictions(tmp_path / "p.csv")
    assert preds.attrs["kind"] == "sample"
    gt_rows, _ = score_cmd.gt_rows_from_run(run)
    out = score_predictions(preds, gt_rows, "ext")
    assert [r["status"] for r in out] == ["ok", "ok", "failed", "failed"]
    assert out[0]["err_deg"] < 1e-3 and out[0]["runtime_s"] == 2.0 and out[0]["score"] == 0.1


def test_bad_prediction_files(tmp_path: Path):
    (tmp_path / "a.csv").write_text("foo,bar\n1,2\n")
    with pytest.raises(InvalidInputError, match="neither BOP"):
        read_predictions(tmp_path / "a.csv")
    (tmp_path / "m_toy-test.csv").write_text("sample_id,R,t\nx,1 0 0 0 1 0 0 0,0 0 0\n")
    with pytest.raises(InvalidInputError, match="m_toy-test.csv:2 R"):
        read_predictions(tmp_path / "m_toy-test.csv")
    from catpose.bench.cli import main

    assert main(["score", str(tmp_path / "m_toy-test.csv"), "--method", "m", "--out", str(tmp_path / "o")]) == 2


def test_bop_export_matches_bop_pose_convention(tmp_path: Path):
    """An exact estimate exports as BOP's own cam_R_m2c / cam_t_m2c (the bop loader's normalisation)."""
    rng = np.random.default_rng(5)
    R_cm, t_cm = Rotation.random(random_state=rng).as_matrix(), np.array([30.0, -20.0, 800.0])
    R_om, centre, scale = axis_angle_to_R(np.array([0, 1.0, 0]), 0.3), np.array([5.0, -4.0, 2.0]), 90.0
    R_oc = R_om @ R_cm.T  # as datasets/bop.py builds T_object_camera
    T_object_camera = make_T(R_oc, -(R_oc @ t_cm + centre) / scale)
    row = {
        "sample_id": "mug/000001/000002/0",
        "group_id": "mug/000001/000002/0",
        "obs_id": "mug/000001/000002/0",
        "category": "mug",
        "instance_id": "obj_000003",
        "status": "ok",
        "error": "",
        "err_deg": 0.0,
        "T_est": T_object_camera.reshape(-1).tolist(),
        "T_gt": T_object_camera.reshape(-1).tolist(),
        "symmetry_axis": None,
        "score": None,
        "runtime_s": 1.0,
        "info": {
            "scene_id": 1,
            "im_id": 2,
            "obj_id": 3,
            "scale_mm": scale,
            "centre_mm": centre.tolist(),
            "R_object_model": R_om.ravel().tolist(),
        },
    }
    run = write_run(tmp_path / "run", [row], CFG)
    export_bop(run, tmp_path / "m_toy-test.csv")
    p = read_predictions(tmp_path / "m_toy-test.csv").iloc[0]
    assert (int(p["scene_id"]), int(p["im_id"]), int(p["obj_id"])) == (1, 2, 3)
    np.testing.assert_allclose(p["T"][:3, :3], R_cm, atol=1e-6)
    np.testing.assert_allclose(p["T"][:3, 3], t_cm, atol=1e-4)


def test_a_run_without_bop_ids_is_neither_exported_nor_scored_from_a_bop_csv(tmp_path: Path):
    """BOP ids come from the samples' info (BOP-layout data); other runs take a per-sample CSV."""
    run = write_run(tmp_path / "run", _rows(), CFG)
    with pytest.raises(InvalidInputError, match="is not on BOP-layout data"):
        export_bop(run, tmp_path / "ours_toy-test.csv")
    bop = tmp_path / "ours_toy-test.csv"
    bop.write_text("scene_id,im_id,obj_id,score,R,t,time\n1,0,1,1,1 0 0 0 1 0 0 0 1,0 0 0,1\n")
    with pytest.raises(InvalidInputError, match="have no BOP ids"):
        score_cmd.main([str(bop), "--gt", str(run), "--out", str(tmp_path / "o")])


@pytest.mark.data
def test_bop_export_reproduces_scene_gt_on_real_tyol_frame(shared_data: Path, tmp_path: Path):
    """Exporting the ground truth of the shared TYO-L frame gives back BOP's own cam_R_m2c / cam_t_m2c."""
    from catpose.bench.protocols.absolute import GtModel
    from catpose.datasets.bop import BOP
    from catpose.datasets.templates import TemplateOptions

    root = shared_data / "bop" / "tyol"
    ds = BOP(root=str(root), categories={19: "basket"}, template=TemplateOptions(templates={"basket": ["obj_000019"]}))
    obs_id = ds.observation_ids()[0]
    sample = GtModel().load(ds, obs_id)
    info = dict(sample.info)
    R_om, centre, scale = ds.normalisation(int(info["obj_id"]))
    info.setdefault("centre_mm", np.asarray(centre).tolist())
    info.setdefault("R_object_model", np.asarray(R_om).ravel().tolist())
    T = np.asarray(sample.gt.T_template_camera, float)
    row = {
        "sample_id": obs_id,
        "group_id": obs_id,
        "obs_id": obs_id,
        "category": "basket",
        "instance_id": "obj_000019",
        "status": "ok",
        "error": "",
        "err_deg": 0.0,
        "T_est": T.reshape(-1).tolist(),
        "T_gt": T.reshape(-1).tolist(),
        "symmetry_axis": None,
        "score": None,
        "runtime_s": 1.0,
        "info": info,
    }
    run = write_run(tmp_path / "run", [row], CFG)
    export_bop(run, tmp_path / "m_toy-test.csv")
    p = read_predictions(tmp_path / "m_toy-test.csv").iloc[0]
    gt = json.loads((root / "test" / f"{int(info['scene_id']):06d}" / "scene_gt.json").read_text())
    entry = gt[str(int(info["im_id"]))][int(info["gt_idx"])]
    np.testing.assert_allclose(p["T"][:3, :3], np.reshape(entry["cam_R_m2c"], (3, 3)), atol=1e-5)
    np.testing.assert_allclose(p["T"][:3, 3], np.asarray(entry["cam_t_m2c"], float), atol=1e-2)
