"""CI regression: reference round trip, readable diffs, skipped methods, committed config."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from catpose.bench import regress


def test_compare_and_format():
    ref = {"icp": {"mug": {"n": 2, "failed": 0, "mean_err_deg": 10.0, "median_err_deg": 5.0, "acc10": 0.5,
                           "acc30": 1.0, "mean_trans_err": float("nan")}}}
    cur = {"icp": {"mug": dict(ref["icp"]["mug"], mean_err_deg=10.5, acc10=1.0)}}
    tol = {"mean_err_deg": 1.0, "acc10": 0.0}
    diffs, notes = regress.compare("s", ref, cur, tol, ["icp", "ours"])
    bad = [d for d in diffs if not d.ok]
    assert [(d.statistic, d.reference, d.current) for d in bad] == [("acc10", 0.5, 1.0)]  # NaN == NaN passes
    assert notes == ["s/ours: no reference yet (run `bench regress --update` and commit it)"]
    text = regress.format_failures(diffs)
    assert "s/icp" in text and "acc10" in text and "+0.5" in text
    # a category that disappeared is a failure, shown as missing
    diffs, _ = regress.compare("s", ref, {"icp": {}}, tol, ["icp"])
    assert all(not d.ok for d in diffs) and "missing" in regress.format_failures(diffs)


def test_default_config_is_valid(repo_root: Path):
    cfg = regress.load_config(repo_root / "configs" / "regress" / "default.yaml")
    assert "synthetic" in cfg["suites"] and set(regress.STATISTICS) <= set(cfg["tolerances"])
    for suite in cfg["suites"].values():
        ref = repo_root / suite["reference"]
        assert ref.is_file(), f"{ref} missing: run `bench regress --update`"
        doc = json.loads(ref.read_text())
        assert doc["dataset"] == suite["dataset"] and doc["metrics"]
        for method, per_cat in doc["metrics"].items():
            assert "all" in per_cat and set(regress.STATISTICS) <= set(per_cat["all"]), method


def test_round_trip_on_tiny_suite(tmp_path: Path, capsys):
    ref = tmp_path / "ref.json"
    cfg = {"tolerances": {"mean_err_deg": 0.5, "median_err_deg": 0.5, "mean_trans_err": 0.01},
           "suites": {"tiny": {"dataset": "synthetic", "protocol": "gt_model", "seed": 0,
                               "overrides": ["dataset.categories=[bowl]", "dataset.instances_per_category=1",
                                             "dataset.views_per_instance=1", "dataset.num_templates=1"],
                               "methods": ["icp", "no_such_method"],
                               "method_overrides": {"icp": ["method.num_starts=2"]},
                               "reference": str(ref)}}}
    cfg_path = tmp_path / "regress.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg))
    assert regress.main(["--config", str(cfg_path)]) == 1  # no reference yet
    assert "no reference file" in capsys.readouterr().err
    assert regress.main(["--config", str(cfg_path), "--update"]) == 0
    out = capsys.readouterr().out
    assert "no_such_method: skipped (no configs/method/no_such_method.yaml)" in out
    doc = json.loads(ref.read_text())
    assert doc["metrics"]["icp"]["bowl"]["n"] == 1.0
    assert regress.main(["--config", str(cfg_path)]) == 0  # deterministic: same numbers
    doc["metrics"]["icp"]["bowl"]["mean_err_deg"] += 5.0
    ref.write_text(json.dumps(doc))
    assert regress.main(["--config", str(cfg_path)]) == 1
    err = capsys.readouterr().err
    assert "REGRESSION" in err and "tiny/icp" in err and "mean_err_deg" in err and "-5" in err
