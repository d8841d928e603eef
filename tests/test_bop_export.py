"""BOP export and scoring as the BOP toolkit sees them: its CSV checks, file names, greedy
matching of several instances, and round trips on a rendered scene and on the shared real
TYO-L / YCB-Video frames (ground truth as estimate scores recall 1; a known shift scores the
expected errors)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.bench.interop import score as score_cmd
from catpose.bench.interop.bop_export import export_bop
from catpose.bench.interop.prediction_io import BOP_COLUMNS, read_predictions
from catpose.bench.interop.score import score_predictions
from catpose.bench.scoring import bop_eval
from catpose.datasets.bop import BOP
from catpose.errors import InvalidInputError
from catpose.geometry import make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402
from test_loaders_bop import T_camera_model, bop_root  # noqa: E402, F401  (the rendered scene fixture)

BOP_HEADER = ",".join(BOP_COLUMNS)

CFG = {
    "method": {"name": "ours", "_target_": "x.Y"},
    "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"},
    "seed": 0,
}
ALL_METRICS = [
    "ar",
    "ar_mssd",
    "ar_mspd",
    "ar_vsd",
    "adds@0.1",
    "add@0.1",
    "mssd@0.1",
    "mspd@10",
    "5deg5cm",
    "10deg10cm",
]


def _dataset_cfg(root: Path, categories: dict) -> dict:
    return {
        "name": "bop",
        "_target_": "catpose.datasets.bop.BOP",
        "root": str(root),
        "categories": categories,
        "templates": {},
    }


def _gt_rows(ds: BOP, runtimes: dict[int, float] | None = None) -> list[dict]:
    """Run rows whose estimate is the ground truth, from the dataset itself (gt_model protocol)."""
    from catpose.bench.protocols.absolute import GtModel

    rows = []
    for k, oid in enumerate(ds.observation_ids()):
        sample = GtModel().load(ds, oid)
        T = np.asarray(sample.gt.T_template_camera, float)
        axis = sample.gt.symmetry_axis
        rows.append(
            {
                "sample_id": oid,
                "group_id": oid,
                "obs_id": oid,
                "category": sample.problem.category,
                "instance_id": sample.info.get("instance_id"),
                "status": "ok",
                "error": "",
                "err_deg": 0.0,
                "T_est": T.reshape(-1).tolist(),
                "T_gt": T.reshape(-1).tolist(),
                "symmetry_axis": None if axis is None else np.asarray(axis).tolist(),
                "symmetries": [np.asarray(S).reshape(-1).tolist() for S in sample.gt.symmetries] or None,
                "score": 0.1,
                "runtime_s": (runtimes or {}).get(k, 1.0),
                "info": dict(sample.info),
            }
        )
    return rows


def test_file_name_check_names_the_fix(tmp_path: Path):
    assert bop_eval.check_results_filename("ours_ycbv-test.csv") == ("ours", "ycbv", "test")
    assert bop_eval.check_results_filename(tmp_path / "icp-v2_tyol-test.csv") == ("icp-v2", "tyol", "test")
    for bad in ("preds.csv", "my_method_ycbv-test.csv", "ours_ycbv.csv"):
        with pytest.raises(InvalidInputError, match="METHOD_DATASET-SPLIT.csv") as e:
            bop_eval.check_results_filename(bad)
        assert "\n" not in str(e.value)
    with pytest.raises(InvalidInputError, match="my-method_ycbv-test.csv"):
        bop_eval.check_results_filename("my_method_ycbv-test.csv")


def test_toolkit_csv_checks_reject_what_the_toolkit_rejects(tmp_path: Path):
    R, t = "1 0 0 0 1 0 0 0 1", "0 0 500"
    ok = tmp_path / "a_b-test.csv"
    ok.write_text(f"{BOP_HEADER}\n1,2,3,0.5,{R},{t},1.5\n1,2,4,0.5,{R},{t},1.5\n1,3,3,0.5,{R},{t},0.2\n")
    assert len(read_predictions(ok)) == 3
    cases = {
        f"{BOP_HEADER}\n1,2,3,0.5,{R},{t},1.5\n1,2,4,0.5,{R},{t},0.7\n": "one time per image|different times",
        f"{BOP_HEADER}\n1,2.5,3,0.5,{R},{t},1\n": "integer",
        f"{BOP_HEADER}\n1,2,3,0.5,1 0 0,{t},1\n": "expected 9",
    }
    for text, msg in cases.items():
        ok.write_text(text)
        with pytest.raises(InvalidInputError, match=msg):
            read_predictions(ok)


def test_export_of_a_two_object_image_passes_the_toolkit_checks_and_scores_perfectly(bop_root, tmp_path: Path):
    ds = BOP(str(bop_root), categories={1: "box", 2: "can"})
    rows = _gt_rows(ds, runtimes={0: 1.25, 1: 2.0})
    assert {(r["info"]["scene_id"], r["info"]["im_id"]) for r in rows} == {(1, 0)}  # both objects in one image
    run = write_run(tmp_path / "run", rows, dict(CFG, dataset=_dataset_cfg(bop_root, {1: "box", 2: "can"})))
    out = tmp_path / "catposeOurs_toy-test.csv"
    with pytest.raises(InvalidInputError, match="METHOD_DATASET-SPLIT"):
        export_bop(run, tmp_path / "preds.csv")
    assert export_bop(run, out) == 2
    assert len(read_predictions(out)) == 2
    df = pd.read_csv(out)
    assert df["time"].tolist() == [3.25, 3.25]  # the image's total, on every row
    assert all(df[c].dtype.kind == "i" for c in ("scene_id", "im_id", "obj_id"))
    scored = tmp_path / "scored"
    assert score_cmd.main([str(out), "--gt", str(run), "--out", str(scored)]) == 0
    errs, header = bop_eval.read_errors(scored / bop_eval.ERRORS_FILE)
    assert header["method"] == "catposeOurs" and len(errs) == 2 and errs["matched"].all()
    table = bop_eval.score_table(errs, ALL_METRICS)
    assert (table[ALL_METRICS].to_numpy() == 1.0).all()
    assert errs["mssd"].max() < 1e-3 and errs["mspd"].max() < 1e-3  # mm, px
    # bench table reads the same file: per-object and per-category rows, chosen metrics
    from catpose.bench.report.table_command import main as table_main

    table_out = tmp_path / "t.md"
    assert table_main([str(scored), "--bop-metrics", "ar_mssd,10deg10cm", "--out", str(table_out)]) == 0
    text = table_out.read_text()
    assert "obj_000001 (box)" in text and "| catposeOurs | category | can" in text and "10deg10cm" in text


def test_several_instances_of_one_object_are_matched_greedily_by_score(bop_root):
    scene = bop_root / "test" / "000001"
    gt = json.loads((scene / "scene_gt.json").read_text())
    shifted = T_camera_model(1) @ make_T(np.eye(3), [0.0, 150.0, 0.0])
    gt["0"][2] = {"obj_id": 1, "cam_R_m2c": shifted[:3, :3].ravel().tolist(), "cam_t_m2c": shifted[:3, 3].tolist()}
    (scene / "scene_gt.json").write_text(json.dumps(gt))
    ds = BOP(str(bop_root), categories={1: "box"})
    assert ds.observation_ids() == ["box/000001/000000/0", "box/000001/000000/2"]

    def line(T: np.ndarray, score: float) -> str:
        return (
            f"1,0,1,{score},{' '.join(f'{x:.12g}' for x in T[:3, :3].ravel())},"
            f"{' '.join(f'{x:.12g}' for x in T[:3, 3])},1"
        )

    # the better-scored estimate is the second instance, a third (worst) estimate is extra
    text = (
        "\n".join(
            [
                BOP_HEADER,
                line(shifted, 0.9),
                line(T_camera_model(1), 0.8),
                line(T_camera_model(1) @ make_T(np.eye(3), [0, 0, 300.0]), 0.1),
            ]
        )
        + "\n"
    )
    path = bop_root.parent / "m_toy-test.csv"
    path.write_text(text)
    preds = read_predictions(path)
    errs = bop_eval.compute_errors(preds, ds, vsd=False)
    assert [e["gt_idx"] for e in errs] == [0, 2]
    assert all(e["mssd"] < 1e-6 and e["add"] < 1e-6 for e in errs)
    # the per-sample scorer matches the same way (it used to give the top estimate to both)
    rows = _gt_rows(ds)
    scored = score_predictions(preds, rows, "m")
    assert [r["status"] for r in scored] == ["ok", "ok"]
    assert max(r["err_deg"] for r in scored) < 1e-4 and max(r["trans_err"] for r in scored) < 1e-6


def _gt_csv(ds: BOP, path: Path, shift_mm=(0.0, 0.0, 0.0)) -> Path:
    """Every target's ground truth as an estimate (optionally shifted, camera frame, mm)."""
    lines = [BOP_HEADER]
    for oid in ds.observation_ids():
        _, scene, im, g = oid.split("/")
        e = json.loads(ds.layout.scene_gt(int(scene)).read_text())[str(int(im))][int(g)]
        t = np.asarray(e["cam_t_m2c"], float) + shift_mm
        lines.append(
            f"{int(scene)},{int(im)},{e['obj_id']},1,{' '.join(f'{x:.12g}' for x in e['cam_R_m2c'])},"
            f"{' '.join(f'{x:.12g}' for x in t)},1"
        )
    path.write_text("\n".join(lines) + "\n")
    return path


YCBV = {1: "can", 5: "bottle", 9: "can"}


@pytest.mark.slow  # > 5 s: make test-slow
@pytest.mark.data
def test_ycbv_ground_truth_scores_recall_one_and_a_shift_scores_its_errors(shared_data: Path, tmp_path: Path):
    root = shared_data / "bop" / "ycbv"
    ds = BOP(str(root), categories=YCBV)
    ids = ds.observation_ids()
    targets = json.loads((root / "test_targets_bop19.json").read_text())
    assert len(ids) == sum(t["inst_count"] for t in targets if t["obj_id"] in YCBV)  # the official targets
    assert any("test_targets_bop19.json" in f for f in ds.filters) and any("visib_fract" in f for f in ds.filters)
    errs = pd.DataFrame(bop_eval.compute_errors(read_predictions(_gt_csv(ds, tmp_path / "gt_ycbv-test.csv")), ds))
    assert len(errs) == len(ids) and errs["matched"].all()
    table = bop_eval.score_table(errs, ALL_METRICS)
    assert (table[ALL_METRICS].to_numpy() == 1.0).all(), table.to_string()

    shift = np.array([10.0, 0.0, 0.0])  # 1 cm sideways
    errs = pd.DataFrame(
        bop_eval.compute_errors(read_predictions(_gt_csv(ds, tmp_path / "s_ycbv-test.csv", shift)), ds, vsd=False)
    )
    assert (errs["im_width"] == 640).all()  # from the depth header, also without VSD
    np.testing.assert_allclose(errs["add"], 10.0, atol=1e-4)  # R in scene_gt is rounded
    np.testing.assert_allclose(errs["te_mm"], 10.0, atol=1e-4)
    np.testing.assert_allclose(errs["re_deg"], 0.0, atol=0.1)  # arccos near 1 amplifies the rounding
    assert (errs["adds"] <= 10.0 + 1e-4).all()
    assert np.allclose(errs["mssd"], 10.0, atol=0.5)  # symmetric spins cannot undo a shift
    info = json.loads((root / "models" / "models_info.json").read_text())
    for obj, g in errs.groupby("obj_id"):
        d = info[str(obj)]["diameter"]
        expected = np.mean([float(g["mssd"].max() < f * d) for f in np.arange(0.05, 0.51, 0.05)])
        assert bop_eval.metric_value(g, "ar_mssd") == pytest.approx(expected)
        assert 0.8 <= expected < 1.0  # 10 mm is beyond 5 % of these diameters (172-196 mm) only
    assert bop_eval.metric_value(errs, "5deg5cm") == 1.0 and bop_eval.metric_value(errs, "0.5deg0.5cm") == 0.0


@pytest.mark.data
def test_tyol_frame_export_then_score_gives_recall_one(shared_data: Path, tmp_path: Path):
    root = shared_data / "bop" / "tyol"
    ds = BOP(str(root), categories={19: "basket"})
    rows = _gt_rows(ds)
    run = write_run(tmp_path / "run", rows, dict(CFG, dataset=_dataset_cfg(root, {19: "basket"})))
    out = tmp_path / "gt_tyol-test.csv"
    assert export_bop(run, out) == 1 and len(read_predictions(out)) == 1
    scored = tmp_path / "scored"
    assert score_cmd.main([str(out), "--gt", str(run), "--out", str(scored)]) == 0
    errs, _ = bop_eval.read_errors(scored / bop_eval.ERRORS_FILE)
    assert (bop_eval.score_table(errs, ALL_METRICS)[ALL_METRICS].to_numpy() == 1.0).all()
    samples = [json.loads(x) for x in (scored / "samples.jsonl").read_text().splitlines()]
    assert samples[0]["err_deg"] < 1e-3 and not math.isnan(samples[0]["trans_err"])


@pytest.mark.data
@pytest.mark.slow
def test_ycbv_bench_export_then_bench_score_reproduces_the_ground_truth(shared_data: Path, tmp_path: Path):
    root = shared_data / "bop" / "ycbv"
    ds = BOP(str(root), categories=YCBV)
    run = write_run(tmp_path / "run", _gt_rows(ds), dict(CFG, dataset=_dataset_cfg(root, YCBV)))
    out = tmp_path / "gt_ycbv-test.csv"
    assert export_bop(run, out) == 38 and len(read_predictions(out)) == 38
    scored = tmp_path / "scored"
    assert score_cmd.main([str(out), "--gt", str(run), "--out", str(scored)]) == 0
    errs, header = bop_eval.read_errors(scored / bop_eval.ERRORS_FILE)
    assert header["targets"] == 38 and header["matched"] == 38
    assert (bop_eval.score_table(errs, ALL_METRICS)[ALL_METRICS].to_numpy() == 1.0).all()
    samples = [json.loads(x) for x in (scored / "samples.jsonl").read_text().splitlines()]
    assert max(s["err_deg"] for s in samples) < 0.1  # the run's own error: rounding of the written R only
