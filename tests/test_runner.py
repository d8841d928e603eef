"""The runner: per-sample table, failures recorded, resume without repeated work."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

from catpose.bench.runner import read_samples, run

TESTS = Path(__file__).resolve().parent


@pytest.fixture(autouse=True)
def _toy_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def make_cfg(tmp_path: Path, special=(), method_kwargs=None, overrides=()):
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(config_name="run", overrides=[f"output_root={tmp_path / 'out'}", "progress=false",
                                                    "print_summary=false", *overrides])
    OmegaConf.set_struct(cfg, False)
    cfg.dataset = OmegaConf.create({"name": "toy", "_target_": "toy_dataset.ToyDataset", "seed": 0,
                                    "num_views": 4, "special": list(special)})
    cfg.method = OmegaConf.create({"name": "oracle", "_target_": "toy_dataset.Oracle",
                                   "count_file": str(tmp_path / "calls.txt"), **(method_kwargs or {})})
    return cfg


def calls(tmp_path: Path) -> list[str]:
    p = tmp_path / "calls.txt"
    return p.read_text().split() if p.exists() else []


def test_run_writes_the_long_table_and_records_failures(tmp_path):
    cfg = make_cfg(tmp_path, special=["load_error", "empty", "nan", "collinear"],
                   method_kwargs={"fail_on": ["v1"], "nan_on": ["v2"]})
    out = run(cfg)
    rows = {r["sample_id"]: r for r in read_samples(out / "samples.jsonl")}
    assert len(rows) == 8
    assert rows["block/0/v0"]["status"] == "ok" and len(rows["block/0/v0"]["T_est"]) == 16
    assert rows["block/0/v0"]["rot_err_deg"] >= 0 and rows["block/0/v0"]["runtime_s"] >= 0
    assert rows["block/0/v1"]["status"] == "failed" and "blew up on purpose" in rows["block/0/v1"]["error"]
    assert rows["block/0/v2"]["status"] == "failed" and "non-finite" in rows["block/0/v2"]["error"]
    assert "malformed on purpose" in rows["block/0/load_error"]["error"]
    assert rows["block/0/load_error"]["stage"] == "load"
    assert "no points" in rows["block/0/empty"]["error"]
    assert "NaN" in rows["block/0/nan"]["error"]
    assert "degenerate" in rows["block/0/collinear"]["error"]
    for r in rows.values():
        assert "\n" not in r["error"] and "Traceback" not in r["error"]
    summary = pd.read_csv(out / "summary.csv").set_index("category")
    assert summary.loc["block", "n"] == 8 and summary.loc["block", "failed"] == 6
    # the two successes (identity estimates) have known errors; the failures count as 180 degrees
    ok_err = rows["block/0/v0"]["err_deg"] + rows["block/0/v3"]["err_deg"]
    assert summary.loc["block", "mean_err_deg"] == pytest.approx((ok_err + 6 * 180.0) / 8)
    assert (out / "config.yaml").exists() and (out / "git_rev.txt").read_text().strip()
    assert (out / "summary.md").read_text().startswith("| category")
    flat = pd.read_csv(out / "samples.csv")
    assert {"sample_id", "category", "method", "status", "error", "err_deg", "runtime_s", "T_est", "T_gt"} <= set(flat)


def test_resume_after_interrupt_gives_the_same_table_without_repeated_work(tmp_path, monkeypatch):
    full = run(make_cfg(tmp_path / "a"))
    reference = pd.read_csv(full / "summary.csv").drop(columns="median_runtime_s")
    assert len(calls(tmp_path / "a")) == 4

    b = tmp_path / "b"
    monkeypatch.setenv("TOY_INTERRUPT_ON", "v2")
    with pytest.raises(KeyboardInterrupt):
        run(make_cfg(b))
    monkeypatch.delenv("TOY_INTERRUPT_ON")
    out = next((b / "out").glob("*/*/*"))
    assert [r["sample_id"] for r in read_samples(out / "samples.jsonl")] == ["block/0/v0", "block/0/v1"]
    with open(out / "samples.jsonl", "a") as f:  # a kill in the middle of writing a line
        f.write('{"sample_id": "block/0/v2", "sta')
    out2 = run(make_cfg(b))
    assert out2 == out
    assert calls(b) == ["block/0/v0", "block/0/v1", "block/0/v2", "block/0/v2", "block/0/v3"]
    resumed = pd.read_csv(out / "summary.csv").drop(columns="median_runtime_s")
    pd.testing.assert_frame_equal(resumed, reference)
    assert len(read_samples(out / "samples.jsonl")) == 4

    run(make_cfg(b))  # a third run has nothing left to do
    assert len(calls(b)) == 5


def test_output_directory_is_named_from_parameters(tmp_path):
    a = run(make_cfg(tmp_path, overrides=["seed=1"]))
    b = run(make_cfg(tmp_path, overrides=["seed=2"]))
    assert a != b and a.name.startswith("seed1") and b.name.startswith("seed2")
    assert a.parent.name == "oracle" and a.parent.parent.name == "toy-gt_model"


def test_same_seed_same_table(tmp_path):
    a = run(make_cfg(tmp_path / "a"))
    b = run(make_cfg(tmp_path / "b"))
    ra, rb = read_samples(a / "samples.jsonl"), read_samples(b / "samples.jsonl")
    assert [r["T_gt"] for r in ra] == [r["T_gt"] for r in rb]
    assert [r["err_deg"] for r in ra] == [r["err_deg"] for r in rb]


def test_templates_protocol_selects_by_score_and_reports_oracle(tmp_path):
    from catpose.bench.protocols import Templates

    df = pd.DataFrame({
        "group_id": ["o1", "o1", "o2", "o2"], "category": ["c"] * 4, "status": ["ok", "ok", "ok", "failed"],
        "score": [2.0, 1.0, 5.0, None], "err_deg": [3.0, 50.0, 7.0, 180.0], "trans_err": [0.1, 0.2, 0.3, None],
        "runtime_s": [1.0, 1.0, 2.0, 2.0]})
    units = Templates().score_units(df).set_index("group_id")
    assert units.loc["o1", "err_deg"] == 50.0 and units.loc["o1", "oracle_err_deg"] == 3.0
    assert units.loc["o2", "err_deg"] == 7.0 and units.loc["o2", "runtime_s"] == 4.0


def test_views_without_absolute_ground_truth_are_not_scored():
    from catpose.bench.protocols import GtModel, Templates

    df = pd.DataFrame({"group_id": ["a", "b"], "category": ["c", "c"], "status": ["ok", "ok"], "score": [1.0, 1.0],
                       "err_deg": [3.0, 100.0], "trans_err": [0.1, 0.1], "runtime_s": [1.0, 1.0],
                       "info": [{}, {"absolute_gt": False}]})
    assert GtModel().score_units(df)["err_deg"].tolist() == [3.0]
    assert Templates().score_units(df)["err_deg"].tolist() == [3.0]


def test_limited_rerun_prints_its_subset_but_files_keep_every_sample(tmp_path):
    from catpose.bench.runner import summarize_run

    out = run(make_cfg(tmp_path))
    sub = summarize_run(out, ["block/0/v0", "block/0/v1"]).set_index("category")
    assert sub.loc["block", "n"] == 2
    assert pd.read_csv(out / "summary.csv").set_index("category").loc["block", "n"] == 4
    limited = run(make_cfg(tmp_path, overrides=["limit=2"]))
    assert limited == out and pd.read_csv(out / "summary.csv").set_index("category").loc["block", "n"] == 4
