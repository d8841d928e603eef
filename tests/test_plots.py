"""Figures and the report folder, from frozen run directories."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.bench import plots
from catpose.bench.predictions import write_run
from catpose.bench.report import build_report, main as report_main, qualitative_picks
from catpose.geometry import axis_angle_to_R, make_T


def _png_ok(path: Path) -> None:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def _units(errors: dict[str, list[float]]) -> pd.DataFrame:
    rows = [{"category": c, "status": "ok" if e is not None else "failed", "err_deg": e, "runtime_s": 0.1 + 0.01 * i}
            for c, es in errors.items() for i, e in enumerate(es)]
    return pd.DataFrame(rows)


def test_scored_errors_counts_failures_as_180():
    e = plots.scored_errors(_units({"a": [5.0, None, 20.0]}))
    assert e.tolist() == [5.0, 180.0, 20.0]


def test_curves_and_runtime(tmp_path: Path):
    units = {"Ours": _units({"chair": [1, 2, 50], "car": [3, None]}), "ICP": _units({"chair": [90, 120, 4]})}
    for fn, name in ((plots.plot_error_cdf, "cdf"), (plots.plot_accuracy, "acc"), (plots.plot_runtime, "rt")):
        paths = fn(units, tmp_path / name)
        assert [p.suffix for p in paths] == [".png", ".pdf"]
        _png_ok(paths[0])
        assert paths[1].read_bytes()[:4] == b"%PDF"


def test_registration_picture(tmp_path: Path):
    rng = np.random.default_rng(0)
    template = rng.normal(size=(500, 3))
    template /= np.linalg.norm(template, axis=1, keepdims=True)
    T_gt = make_T(axis_angle_to_R(np.array([0, 0, 1.0]), 0.5), [0, 0, -3])
    points_camera = (template[:200] - T_gt[:3, 3]) @ T_gt[:3, :3]  # inv(T_gt) applied
    paths = plots.plot_registration(points_camera, template, T_gt, T_gt, tmp_path / "reg", "toy", 0.0)
    assert [p.suffix for p in paths] == [".png", ".pdf"]
    _png_ok(paths[0])


def _synthetic_run(root: Path) -> Path:
    """A frozen run over one rendered view of the embedded synthetic dataset."""
    from catpose.datasets.synthetic import SyntheticDataset

    ds_cfg = {"name": "synthetic", "_target_": "catpose.datasets.synthetic.SyntheticDataset", "seed": 0,
              "categories": ["mug"], "instances_per_category": 1, "views_per_instance": 2, "num_templates": 1,
              "template_points": 512}
    kwargs = {k: v for k, v in ds_cfg.items() if k not in ("name", "_target_")}
    ds = SyntheticDataset(**kwargs)
    rows = []
    for k, obs_id in enumerate(ds.observation_ids()):
        T_gt = np.asarray(ds.observation(obs_id).T_object_camera, float)
        T_est = make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(10 * k)), np.zeros(3)) @ T_gt
        rows.append({"sample_id": obs_id, "group_id": obs_id, "obs_id": obs_id, "category": "mug", "instance_id": "000",
                     "method": "ours", "status": "ok", "error": "", "err_deg": 10.0 * k, "rot_err_deg": 10.0 * k,
                     "trans_err": 0.0, "T_est": T_est.reshape(-1).tolist(), "T_gt": T_gt.reshape(-1).tolist(),
                     "symmetry_axis": None, "score": 0.1, "runtime_s": 0.2, "info": {}, "extras": {}})
    cfg = {"method": {"name": "ours", "_target_": "x.Y"}, "dataset": ds_cfg,
           "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.GtModel"}, "seed": 0}
    return write_run(root / "run_ours", rows, cfg)


def test_report_folder(tmp_path: Path):
    run = _synthetic_run(tmp_path)
    index = build_report([run], tmp_path / "report", layouts=["generic", "optimizer"], qualitative=1)
    text = index.read_text()
    for rel in ("tables/generic.md", "tables/optimizer.tex", "tables/generic.csv", "figures/error_cdf.png",
                "figures/accuracy.pdf", "figures/runtime.png"):
        assert (tmp_path / "report" / rel).is_file(), rel
        assert rel.split("/")[1].split(".")[0] in text
    assert "figures/sample_run0_0.png" in text and "not drawn" not in text
    _png_ok(tmp_path / "report" / "figures" / "sample_run0_0.png")
    html = (tmp_path / "report" / "index.html").read_text()
    assert '<img src="figures/error_cdf.png"' in html and "<pre>" in html
    assert report_main([str(tmp_path / "missing"), "--out", str(tmp_path / "r2")]) == 2


def test_qualitative_picks_median_then_worst():
    units = pd.DataFrame({"sample_id": list("abcde"), "status": ["ok"] * 4 + ["failed"],
                          "err_deg": [1.0, 50.0, 3.0, 9.0, 180.0], "T_est": [[0]] * 4 + [None]})
    assert qualitative_picks(units, 3) == ["d", "b", "c"]  # ok sorted: a1 c3 d9 b50 -> median d, worst b, c
    assert qualitative_picks(units, 0) == []
