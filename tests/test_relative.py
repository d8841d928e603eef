"""The relative protocol: pair formation and relative-pose errors on frozen per-view rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from catpose.bench.protocols.relative import Relative, pair_indices, relative_errors
from catpose.datasets.dataset import ObjectDataset, Observation
from catpose.errors import ConfigError
from catpose.geometry import axis_angle_to_R, make_T
from catpose.types import Template


def _row(
    obs_id: str,
    instance: str,
    T_gt: np.ndarray,
    T_est: np.ndarray | None,
    *,
    status: str = "ok",
    axis=None,
    category: str = "chair",
    score: float = 1.0,
    template: str = "0",
) -> dict:
    return {
        "sample_id": f"{obs_id}|{template}",
        "group_id": obs_id,
        "obs_id": obs_id,
        "category": category,
        "instance_id": instance,
        "status": status,
        "error": "" if status == "ok" else "boom",
        "T_est": None if T_est is None else T_est.reshape(-1).tolist(),
        "T_gt": T_gt.reshape(-1).tolist(),
        "symmetry_axis": axis,
        "runtime_s": 0.5,
        "score": score,
        "err_deg": 0.0,
        "trans_err": 0.0,
    }


def test_pair_indices():
    assert pair_indices(4, "consecutive", None) == [(0, 1), (1, 2), (2, 3)]
    assert pair_indices(3, "all", None) == [(0, 1), (0, 2), (1, 2)]
    assert pair_indices(5, "all", 2) == [(0, 1), (3, 4)]
    assert pair_indices(1, "all", None) == []
    with pytest.raises(ConfigError):
        pair_indices(3, "random", None)


def test_relative_error_ignores_unknown_absolute_frame():
    rng = np.random.default_rng(0)
    T_gt1 = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
    T_gt2 = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
    # Estimates in another frame (template != the trajectory's frame): relative pose is exact.
    T_template_object = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3))
    e = relative_errors(T_template_object @ T_gt1, T_template_object @ T_gt2, T_gt1, T_gt2)
    assert e["rot_err_deg"] < 1e-4 and e["trans_err"] < 1e-9 and e["err_deg"] == e["rot_err_deg"]
    # A 20 degree error in view 2's rotation about the camera z axis gives 20 degrees.
    T_est2 = T_gt2 @ make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(20)), np.zeros(3))
    e = relative_errors(T_gt1, T_est2, T_gt1, T_gt2)
    assert e["rot_err_deg"] == pytest.approx(20.0, abs=1e-4)


def test_symmetric_relative_error_ignores_spin_about_axis():
    rng = np.random.default_rng(1)
    axis = np.array([0.0, 0.0, 1.0])
    T_gt1, T_gt2 = (
        make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3)),
        make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3)),
    )
    spin1 = make_T(axis_angle_to_R(axis, 0.7), np.zeros(3))  # template-frame spin: unobservable
    spin2 = make_T(axis_angle_to_R(axis, -1.9), np.zeros(3))
    e = relative_errors(spin1 @ T_gt1, spin2 @ T_gt2, T_gt1, T_gt2, axis)
    assert e["axis_err_deg"] < 1e-4 and e["err_deg"] == e["axis_err_deg"] and e["rot_err_deg"] > 1.0
    tilt = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), np.radians(15)), np.zeros(3))
    e = relative_errors(T_gt1, tilt @ T_gt2, T_gt1, T_gt2, axis)
    assert e["axis_err_deg"] == pytest.approx(15.0, abs=1e-4)


def test_score_units_pairs_and_failures():
    rng = np.random.default_rng(2)
    gts = [make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3)) for _ in range(3)]
    off = make_T(axis_angle_to_R(np.array([0, 1.0, 0]), np.radians(30)), np.zeros(3))
    rows = [
        _row("chair/a/v0", "a", gts[0], gts[0]),
        _row("chair/a/v1", "a", gts[1], gts[1] @ off),
        _row("chair/a/v2", "a", gts[2], gts[2]),
        _row("chair/b/v0", "b", gts[0], None, status="failed"),
        _row("chair/b/v1", "b", gts[1], gts[1]),
    ]
    df = pd.DataFrame(rows).sample(frac=1.0, random_state=0)  # order of the file does not matter
    units = Relative(template_source="own", pairs="consecutive").score_units(df)
    units = units.set_index("sample_id")
    assert list(units.index) == ["chair/a/v0~chair/a/v1", "chair/a/v1~chair/a/v2", "chair/b/v0~chair/b/v1"]
    assert units.loc["chair/a/v0~chair/a/v1", "err_deg"] == pytest.approx(30.0, abs=1e-4)
    assert units.loc["chair/a/v1~chair/a/v2", "err_deg"] == pytest.approx(30.0, abs=1e-4)
    failed = units.loc["chair/b/v0~chair/b/v1"]
    assert failed["status"] == "failed" and failed["err_deg"] == 180.0
    assert units.loc["chair/a/v0~chair/a/v1", "runtime_s"] == pytest.approx(1.0)
    all_pairs = Relative(template_source="own", pairs="all", max_pairs_per_instance=2).score_units(df)
    assert len(all_pairs) == 3  # 2 kept of instance a's 3, and b's single pair
    # a view that failed to load has no instance id: recovered from its id, its pair fails
    df.loc[df["obs_id"] == "chair/b/v0", "instance_id"] = None
    units = Relative(template_source="own").score_units(df).set_index("sample_id")
    assert units.loc["chair/b/v0~chair/b/v1", "status"] == "failed"


def test_score_units_category_templates_picks_lowest_score():
    rng = np.random.default_rng(3)
    g1, g2 = (
        make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3)),
        make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3)),
    )
    bad = make_T(axis_angle_to_R(np.array([1.0, 0, 0]), np.radians(90)), np.zeros(3))
    rows = [
        _row("car/x/v0", "x", g1, g1, category="car", score=0.1, template="0"),
        _row("car/x/v0", "x", g1, g1 @ bad, category="car", score=0.9, template="1"),
        _row("car/x/v1", "x", g2, g2 @ bad, category="car", score=0.5, template="0"),
        _row("car/x/v1", "x", g2, g2, category="car", score=0.2, template="1"),
    ]
    # rows without the cross check's facts: only their scores can choose
    units = Relative(template_source="category", choice="score").score_units(pd.DataFrame(rows))
    assert len(units) == 1 and units.iloc[0]["err_deg"] == pytest.approx(0.0, abs=1e-4)


class _TinyDataset(ObjectDataset):
    name = "tiny"

    def __init__(self) -> None:
        rng = np.random.default_rng(4)
        self._pts = rng.normal(size=(50, 3))
        self._T = {f"mug/i0/v{k}": make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3)) for k in range(3)}

    def observation_ids(self) -> list[str]:
        return list(self._T)

    def observation(self, obs_id: str) -> Observation:
        n = self._pts / np.linalg.norm(self._pts, axis=1, keepdims=True)
        return Observation(
            obs_id, "mug", "i0", self._pts, n, np.array([0, -1.0, 0]), self._T[obs_id], info={"absolute_gt": False}
        )

    def _template(self, tid: str) -> Template:
        n = self._pts / np.linalg.norm(self._pts, axis=1, keepdims=True)
        return Template(tid, "mug", self._pts, n)

    def instance_model(self, category: str, instance_id: str) -> Template:
        return self._template("own")

    def category_templates(self, category: str) -> list[Template]:
        return [self._template("t0"), self._template("t1")]


def test_load_samples_from_dataset():
    ds = _TinyDataset()
    rel = Relative(template_source="category")
    ids = rel.sample_ids(ds)
    assert ids == [f"mug/i0/v{k}|{t}" for k in range(3) for t in range(2)]
    s = rel.load(ds, ids[1])
    assert s.group_id == "mug/i0/v0" and s.problem.template.template_id == "t1"
    assert s.info["absolute_gt"] is False
    own = Relative(template_source="own")
    assert own.sample_ids(ds) == ["mug/i0/v0", "mug/i0/v1", "mug/i0/v2"]
    assert own.load(ds, "mug/i0/v2").problem.template.template_id == "own"


def test_config_instantiates(repo_root: Path):
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    cfg = OmegaConf.load(repo_root / "configs" / "protocol" / "relative.yaml")
    assert cfg.name == "relative"
    cfg.pop("name")
    proto = instantiate(cfg)
    assert isinstance(proto, Relative) and proto.pairs == "consecutive"
    with pytest.raises(ConfigError):
        Relative(template_source="nearest")


def test_runner_end_to_end(tmp_path: Path):
    """The runner writes per-view rows; the summary counts view pairs of each instance."""
    from hydra import compose, initialize_config_module

    from catpose.bench.run.runner import run

    overrides = [
        "method=icp",
        "method.num_starts=2",
        "dataset=synthetic",
        "dataset.categories=[car]",
        "dataset.instances_per_category=1",
        "dataset.views_per_instance=3",
        "protocol=relative",
        "protocol.template_source=own",
        "protocol.pairs=all",
        f"output_root={tmp_path}",
        "progress=false",
        "print_summary=false",
    ]
    with initialize_config_module("catpose.configs", version_base=None):
        cfg = compose("run", overrides=overrides)
    run_dir = run(cfg, overrides)
    summary = pd.read_csv(run_dir / "summary.csv").set_index("category")
    assert summary.loc["car", "n"] == 3  # pairs (v00, v01), (v00, v02), (v01, v02)
    from catpose.bench.report.runs import load_run, scored_units

    units = scored_units(load_run(run_dir))
    assert sorted(units["sample_id"]) == [
        "car/000/v00~car/000/v01",
        "car/000/v00~car/000/v02",
        "car/000/v01~car/000/v02",
    ]
    assert np.isfinite(units["err_deg"]).all()


def test_max_relative_angle_keeps_small_motions():
    rng = np.random.default_rng(7)
    T0 = make_T(Rotation.random(random_state=rng).as_matrix(), np.zeros(3))
    small = T0 @ make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(20)), np.zeros(3))
    large = T0 @ make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(120)), np.zeros(3))
    rows = [_row("cup/a/v0", "a", T0, T0), _row("cup/a/v1", "a", small, small), _row("cup/a/v2", "a", large, large)]
    units = Relative(template_source="own", pairs="all", max_relative_angle_deg=45).score_units(pd.DataFrame(rows))
    assert list(units["sample_id"]) == ["cup/a/v0~cup/a/v1"]


def test_views_without_relative_ground_truth_are_not_scored():
    import pandas as pd

    from catpose.bench.protocols.relative import Relative

    T = np.eye(4).reshape(-1).tolist()
    rows = [
        dict(
            sample_id=f"chair/s1/v{k}",
            group_id=f"chair/s1/v{k}",
            obs_id=f"chair/s1/v{k}",
            category="chair",
            instance_id="s1",
            status="ok",
            T_est=T,
            T_gt=T,
            symmetry_axis=None,
            runtime_s=1.0,
            score=0.0,
            err_deg=0.0,
            trans_err=0.0,
            info={"relative_gt": False},
        )
        for k in range(3)
    ]
    assert len(Relative(template_source="own").score_units(pd.DataFrame(rows))) == 0
    for r in rows:  # a Redwood scan with a trajectory: relative but no absolute ground truth
        r["info"] = {"relative_gt": True, "absolute_gt": False}
    assert len(Relative(template_source="own").score_units(pd.DataFrame(rows))) == 2
    assert len(Relative(template_source="category").score_units(pd.DataFrame(rows))) == 2


def test_symmetric_relative_errors_ignore_each_views_spin():
    rng = np.random.default_rng(3)
    axis = np.array([0.0, 0.0, 1.0])
    T_gt1 = make_T(Rotation.random(random_state=rng).as_matrix(), [0.2, -0.1, 3.0])
    T_gt2 = make_T(Rotation.random(random_state=rng).as_matrix(), [-0.3, 0.4, 2.5])
    spin = make_T(axis_angle_to_R(axis, 1.1), np.zeros(3))  # unobservable for a can
    e = relative_errors(T_gt1, spin @ T_gt2, T_gt1, T_gt2, axis)
    assert e["err_deg"] == pytest.approx(0.0, abs=1e-6) and e["trans_err"] == pytest.approx(0.0, abs=1e-9)
    assert relative_errors(T_gt1, spin @ T_gt2, T_gt1, T_gt2, None)["trans_err"] > 0.1


def test_a_relative_run_on_category_templates_stores_the_facts_its_default_choice_reads(tmp_path):
    """`fused` (the default) reads the cross check's facts: a relative run computes them as a
    templates run does, and keeps each view's row by them."""
    from hydra import compose, initialize_config_module

    from catpose.bench.run.rundir import read_rows
    from catpose.bench.run.runner import run

    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose(
            config_name="run",
            overrides=[
                f"output_root={tmp_path}",
                "progress=false",
                "print_summary=false",
                "method=icp",
                "protocol=relative",
                "dataset.categories=[bowl]",
                "dataset.instances_per_category=1",
                "limit=6",  # two views x three templates
            ],
        )
    assert cfg.choice.rule == "fused"
    out = run(cfg)
    rows = read_rows(out / "samples.jsonl")
    assert len(rows) == 6 and all(len(r["info"]["cross_costs"]) == 3 and r["info"]["turns"] for r in rows)
    from catpose.bench.run.build import build_protocol

    protocol = build_protocol(cfg)
    views = protocol.view_rows(pd.DataFrame(rows))
    assert len(views) == 2 and all(i["fused_templates"] >= 1 for i in views["info"])  # kept by fused, from the facts
    pairs = protocol.score_units(pd.DataFrame(rows))
    assert len(pairs) == 1 and np.isfinite(pairs["err_deg"]).all()
