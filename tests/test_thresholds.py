"""Accuracy at any threshold, n-degree m-cm and the AUC of the accuracy curve
(catpose.bench.scoring.curves), in ``bench table --metrics``."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.bench.scoring import curves
from catpose.bench.scoring.metrics import accuracy
from catpose.geometry import axis_angle_to_R, invert_T, make_T

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trust import write_run  # noqa: E402

GT_MODEL = {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"}


def _units(errors, status=None, info=None):
    n = len(errors)
    return pd.DataFrame(
        {"category": ["a"] * n, "err_deg": errors, "status": status or ["ok"] * n, "info": info or [{}] * n}
    )


def test_auc_is_the_integral_of_the_accuracy_curve():
    rng = np.random.default_rng(1)
    e = np.concatenate([rng.uniform(0, 60, 40), [0.0, 30.0, 180.0]])
    grid = np.linspace(0.0, 30.0, 300001)  # independent reference: the curve on a fine grid, trapezoids
    curve = np.array([(e <= t).mean() for t in grid[::100]])
    reference = np.trapezoid(curve, grid[::100]) / 30.0
    assert curves.auc(e, 30.0) == pytest.approx(reference, abs=2e-4)
    assert curves.auc([0.0, 0.0], 10) == 1.0 and curves.auc([10.0, 50.0], 10) == 0.0
    assert np.isnan(curves.auc([], 10))


def test_accuracy_keys_match_the_summary_and_failures_count_as_wrong():
    units = _units([1.0, 5.0, 7.5, 12.0, 2.0], status=["ok", "ok", "ok", "ok", "failed"])
    assert curves.statistic(units, "acc5") == pytest.approx(2 / 5)  # the failed unit counts 180 degrees
    assert curves.statistic(units, "acc7.5") == pytest.approx(3 / 5)
    assert curves.statistic(units, "acc10") == accuracy([1.0, 5.0, 7.5, 12.0, 180.0], 10.0)
    assert curves.statistic(units, "auc10") == pytest.approx(np.mean([0.9, 0.5, 0.25, 0.0, 0.0]))


def test_n_degree_m_cm_uses_the_object_origin_in_metres():
    """Object 100 mm per unit; the estimate puts the object's origin 0.3 units (3 cm) off."""
    T_gt = make_T(axis_angle_to_R(np.array([0, 1.0, 0]), 0.4), np.array([0.1, -0.2, 2.0]))
    T_camera_object = invert_T(T_gt)
    rows = []
    for err_deg, offset_units in ((4.0, 0.3), (4.0, 0.6), (8.0, 0.3)):
        moved = T_camera_object.copy()
        moved[:3, 3] += np.array([offset_units, 0.0, 0.0])  # origin moved in the camera frame
        R_fix = axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(err_deg))
        T_est = invert_T(moved)
        T_est[:3, :3] = R_fix @ T_est[:3, :3]
        T_est[:3, 3] = -T_est[:3, :3] @ moved[:3, 3]  # keeps the origin where `moved` put it
        rows.append(
            {
                "category": "a",
                "status": "ok",
                "err_deg": err_deg,
                "trans_err": None,
                "T_est": T_est.reshape(-1).tolist(),
                "T_gt": T_gt.reshape(-1).tolist(),
                "info": {"scale_mm": 100.0},
            }
        )
    units = pd.DataFrame(rows)
    np.testing.assert_allclose(curves.translation_cm(units), [3.0, 6.0, 3.0], atol=1e-9)
    assert curves.statistic(units, "5deg5cm") == pytest.approx(1 / 3)
    assert curves.statistic(units, "10deg10cm") == 1.0
    assert curves.statistic(units, "5deg2cm") == 0.0
    no_scale = units.assign(info=[{}] * 3)  # object-normalised units only: no centimetres
    assert np.isnan(curves.statistic(no_scale, "5deg5cm"))


def _run(root: Path, name: str, errors: list[float], scale_mm: float | None = None) -> Path:
    T_gt = make_T(np.eye(3), np.array([0.0, 0.0, 2.0]))
    rows = []
    for i, e in enumerate(errors):
        T_est = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), np.radians(e)), np.array([0.0, 0.0, 2.0]))
        rows.append(
            {
                "sample_id": f"car/i{i}/v0",
                "group_id": f"car/i{i}/v0",
                "obs_id": f"car/i{i}/v0",
                "category": "car",
                "instance_id": f"i{i}",
                "template_id": "own",
                "method": name,
                "status": "ok",
                "error": "",
                "err_deg": e,
                "T_est": T_est.reshape(-1).tolist(),
                "T_gt": T_gt.reshape(-1).tolist(),
                "symmetric": False,
                "symmetry_axis": None,
                "score": 0.0,
                "runtime_s": 0.1,
                "info": {} if scale_mm is None else {"scale_mm": scale_mm},
                "extras": {},
            }
        )
    cfg = {"method": {"name": name, "_target_": "x.Y"}, "dataset": {"name": "toy"}, "protocol": GT_MODEL, "seed": 0}
    return write_run(root / name, rows, cfg)


def test_bench_table_acc_and_auc(tmp_path: Path, capsys):
    from catpose.bench.cli import main

    a = _run(tmp_path, "icp", [1.0, 4.0, 8.0, 20.0])
    assert main(["table", str(a), "--metrics", "mean,median,acc5,acc10,5deg5cm,auc10,trans", "--format", "csv"]) == 0
    frame = pd.read_csv(__import__("io").StringIO(capsys.readouterr().out))
    row = frame.iloc[0]
    # 5deg5cm is left out: these rows have no metric scale
    assert list(frame.columns) == [
        "Methods",
        "Car/Mean° ↓",
        "Car/Med.° ↓",
        "Car/@5 ↑",
        "Car/@10 ↑",
        "Car/AUC@10 ↑",
        "Car/L_T ↓",
        "All/Mean° ↓",
        "All/Med.° ↓",
        "All/@5 ↑",
        "All/@10 ↑",
        "All/AUC@10 ↑",
        "All/L_T ↓",
    ]
    assert row["All/@5 ↑"] == 0.5 and row["All/@10 ↑"] == 0.75
    assert row["All/AUC@10 ↑"] == pytest.approx(np.mean([0.9, 0.6, 0.2, 0.0]))
    assert main(["table", str(a), "--metrics", "mean,median,5deg5cm,trans"]) == 0
    assert "Left out: 5deg5cm (no run here has rows with a metric scale" in capsys.readouterr().out
    b = _run(tmp_path / "metric", "icp", [1.0, 4.0, 8.0, 20.0], scale_mm=100.0)
    assert main(["table", str(b), "--metrics", "mean,5deg5cm,10deg10cm"]) == 0
    text = capsys.readouterr().out
    assert "| ICP | 8.250 | 0.500 | 0.750 |" in text  # the translation is exact: rotation alone decides
    assert main(["table", str(a), "--metrics", "acc5,x"]) == 2
    assert "unknown metric 'x'" in capsys.readouterr().err
