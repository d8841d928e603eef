"""Hypothesis recall (found@10): the runner scores the poses a method held at each stage of its
search against the truth, so a wrong answer is either never found or found and not chosen."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf
from scipy.spatial.transform import Rotation

from catpose.bench.run.runner import run
from catpose.bench.scoring.metrics import pose_errors_deg, sample_errors, stage_errors, summarize
from catpose.geometry import axis_angle_to_R, make_T

TESTS = Path(__file__).resolve().parent


@pytest.fixture(autouse=True)
def _toy_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(TESTS))


def make_cfg(tmp_path: Path, method: dict):
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(
            config_name="run", overrides=[f"output_root={tmp_path / 'out'}", "progress=false", "print_summary=false"]
        )
    OmegaConf.set_struct(cfg, False)
    cfg.dataset = OmegaConf.create({"name": "toy", "_target_": "toy_dataset.ToyDataset", "seed": 0, "num_views": 4})
    cfg.method = OmegaConf.create(method)
    return cfg


def _run(tmp_path: Path, plant: bool) -> list[dict]:
    cfg = make_cfg(tmp_path, {"name": "planted", "_target_": "toy_dataset.Planted", "seed": 0, "plant": plant})
    out = run(cfg, [f"plant={plant}"])
    return [json.loads(line) for line in (out / "samples.jsonl").read_text().splitlines()], out


def test_a_planted_truth_is_found_though_not_chosen(tmp_path):
    rows, out = _run(tmp_path, plant=True)
    for r in rows:
        assert r["err_deg"] == pytest.approx(90.0, abs=1e-6)
        assert r["found_err_deg"] == pytest.approx(0.0, abs=1e-4)
        assert r["info"]["hypothesis_errors"]["candidates"] == pytest.approx(0.0, abs=1e-4)
        assert r["info"]["hypothesis_errors"]["final"] == pytest.approx(90.0, abs=1e-6)
        assert "hypothesis_stages" not in r["extras"]  # the poses are scored, not stored
        assert r["info"]["runner_up_err_deg"] == pytest.approx(0.0, abs=1e-4)  # the runner-up, scored
    summary = pd.read_csv(out / "summary.csv").set_index("category")
    assert summary.loc["all", "acc10"] == 0.0 and summary.loc["all", "found10"] == 1.0
    assert list(summary.columns).index("found10") == list(summary.columns).index("acc10") + 1


def test_without_the_truth_it_is_never_found(tmp_path):
    rows, out = _run(tmp_path, plant=False)
    assert all(r["found_err_deg"] == pytest.approx(45.0, abs=1e-6) for r in rows)
    assert all(r["info"]["runner_up_err_deg"] == pytest.approx(45.0, abs=1e-6) for r in rows)
    assert pd.read_csv(out / "summary.csv").set_index("category").loc["all", "found10"] == 0.0


def test_methods_without_stages_have_no_found_column(tmp_path):
    out = run(make_cfg(tmp_path, {"name": "oracle", "_target_": "toy_dataset.Oracle"}), [])
    assert "found10" not in pd.read_csv(out / "summary.csv").columns


def test_batch_errors_agree_with_sample_errors_under_symmetries():
    rng = np.random.default_rng(3)
    T_gt = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
    T = np.stack([make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3)) for _ in range(7)])
    S = make_T(axis_angle_to_R(np.array([0.0, 1.0, 0.0]), np.pi), np.zeros(3))
    for axis, syms in ((None, ()), (np.array([0.0, 0.0, 1.0]), ()), (None, (S,))):
        want = [sample_errors(t, T_gt, axis, syms)["err_deg"] for t in T]
        assert pose_errors_deg(T, T_gt, axis, syms) == pytest.approx(want, abs=1e-9)
    found = stage_errors({"a": T, "empty": np.zeros((0, 4, 4))}, T_gt)
    assert found["a"] == pytest.approx(min(want)) and np.isnan(found["empty"])


def test_a_row_without_recall_is_found_when_its_answer_is_right():
    df = pd.DataFrame(
        {
            "category": ["c"] * 3,
            "status": ["ok", "ok", "failed"],
            "err_deg": [50.0, 5.0, 180.0],
            "found_err_deg": [3.0, None, None],
            "trans_err": [0.1, 0.1, None],
            "runtime_s": [1.0, 1.0, 1.0],
        }
    )
    s = summarize(df).set_index("category")
    assert s.loc["all", "found10"] == pytest.approx(2 / 3) and s.loc["all", "acc10"] == pytest.approx(1 / 3)
