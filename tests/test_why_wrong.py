"""``python experiments/_lib/why_wrong.py``: each wrong view of a templates run judged at the
step that chose it: ours' registration on the kept template, then the K-template rule."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from catpose.methods.choice_rules import CROSS_WEIGHT, TOP_WEIGHT, ChoiceRule, cross_cost, rotation_angle_deg
from catpose.methods.cross_check import CrossCheck

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import chair_template, partial_problem  # noqa: E402
from _study import study_module  # noqa: E402
from test_cross_check import _chair_like, _pose, _view  # noqa: E402  (the cross check's chair-like slabs)

pytestmark = pytest.mark.experiment

why_wrong = study_module("experiments/_lib/why_wrong.py")


def _quarter_turn(T: np.ndarray) -> np.ndarray:
    """``T`` followed by 90 degrees about the template's up (z)."""
    F = np.eye(4)
    F[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    return F @ T


def test_an_asymmetric_chairs_quarter_turn_scores_worse_than_the_truth_it_could_have_found(why_wrong):
    from catpose.methods.ours import Ours

    template = chair_template()
    problem, T_gt = partial_problem(template, seed=3)
    ours = Ours()
    wrong = _quarter_turn(T_gt)
    costs = why_wrong.registration_costs(ours, problem, wrong, T_gt)
    assert costs["cost_truth_refined"] <= costs["cost_truth"] < costs["cost_estimate"]
    assert why_wrong.registration_verdict(90.0, costs) in ("not kept", "not found")
    # the candidates are ours' own: the nearest is where ours' search went (its answer here is right)
    answer = ours.register(problem).T_template_camera
    assert costs["nearest_candidate_deg"] <= rotation_angle_deg(answer[:3, :3], T_gt[:3, :3]) + 5.0
    same = why_wrong.registration_costs(ours, problem, T_gt, T_gt)
    assert same["cost_estimate"] == same["cost_truth"] and why_wrong.registration_verdict(0.0, same) == "right"


def test_registration_verdicts(why_wrong):
    costs = {"cost_estimate": 0.10, "cost_truth": 0.20, "cost_truth_refined": 0.12, "nearest_candidate_deg": 12.0}
    assert why_wrong.registration_verdict(5.0, costs) == "right"
    assert why_wrong.registration_verdict(20.0, costs) == "imprecise"  # inside the truth's basin
    assert why_wrong.registration_verdict(90.0, costs) == "ambiguous"  # the estimate scores lowest
    lower = dict(costs, cost_truth_refined=0.08)
    assert why_wrong.registration_verdict(90.0, lower) == "not kept"
    assert why_wrong.registration_verdict(90.0, dict(lower, nearest_candidate_deg=45.0)) == "not found"
    assert why_wrong.registration_verdict(90.0, dict(costs, cost_truth_refined=np.inf)) == "ambiguous"


def test_the_truth_costs_less_under_the_rule_than_a_quarter_turned_chair(why_wrong):
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10)]
    P, T = _view(_chair_like(0.65, 0.85, 30), np.array([0.8, 2.0, 1.5]))
    wrong = _pose(90.0) @ T
    check = CrossCheck()
    cross_costs, top_offset = check.cross_costs, check.top_offset

    def rule_cost(pose, k):
        return cross_cost(
            cross_costs(P, pose, templates, k), k, CROSS_WEIGHT, top_offset(P, pose, templates, k), TOP_WEIGHT
        )

    poses = [(rule_cost(wrong, 0), 0, wrong), (rule_cost(_pose(270.0) @ T, 1), 1, _pose(270.0) @ T)]
    c = why_wrong.choice_costs(P, templates, [T, T], poses, ChoiceRule(rule="cross_top_turns"), check)
    assert c["rule_cost_kept"] == min(p[0] for p in poses)
    # the truth's cost is the lowest of both templates, as given and refined: at most the unrefined ones
    assert c["rule_cost_truth"] <= min(rule_cost(T, 0), rule_cost(T, 1)) < c["rule_cost_kept"]
    assert c["rule_truth_template"] in (0, 1) and c["rule_nearest_deg"] == pytest.approx(90.0, abs=1e-6)
    assert why_wrong.choice_verdict(90.0, c) == "missed"
    assert why_wrong.choice_verdict(90.0, dict(c, rule_cost_kept=c["rule_cost_truth"])) == "ambiguous"
    assert why_wrong.choice_verdict(15.0, c) == "imprecise"


def test_rule_poses_are_the_registrations_and_their_turns_under_a_turn_rule(why_wrong):
    T = np.eye(4)
    info = {
        "cross_costs": [0.2, 0.3],
        "top_offset": 0.1,
        "turns": [
            {"turn_deg": 90.0, "cross_costs": [0.1, 0.2], "top_offset": 0.0, "T_template_camera": _pose(90.0).tolist()}
        ],
    }
    group = pd.DataFrame(
        {
            "sample_id": ["v|0", "v|1"],
            "status": ["ok", "ok"],
            "T_est": [T.tolist(), T.tolist()],
            "info": [info, {"cross_costs": [0.4, 0.5], "top_offset": 0.2, "turns": []}],
        }
    )
    turn = why_wrong.rule_poses(group, ChoiceRule(rule="cross_top_turns"))
    assert [own for _, own, _ in turn] == [0, 0, 1] and len(turn) == 3
    np.testing.assert_array_equal(turn[1][2], _pose(90.0))
    assert turn[1][0] == pytest.approx(cross_cost([0.1, 0.2], 0, CROSS_WEIGHT, 0.0, TOP_WEIGHT))
    plain = why_wrong.rule_poses(group, ChoiceRule(rule="cross"))
    assert [own for _, own, _ in plain] == [0, 1]
    assert plain[0][0] == pytest.approx(cross_cost([0.2, 0.3], 0, CROSS_WEIGHT))


@pytest.mark.slow  # > 5 s: make test-slow
def test_a_templates_run_gets_a_row_per_judged_view(why_wrong, tmp_path):
    out = tmp_path / "out"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "catpose.bench.cli",
            "run",
            "method=ours",
            "dataset=synthetic",
            "dataset.categories=[chair]",
            "dataset.instances_per_category=1",
            "dataset.views_per_instance=2",
            "protocol=templates",
            "choice=cross_top_turns",
            "method.selection.rule=visibility",
            f"output_root={out}",
            "progress=false",
            "print_summary=false",
        ],
        check=True,
        capture_output=True,
        timeout=600,
    )
    run = next(out.glob("*/ours/*"))
    md = tmp_path / "why.md"
    # every view judged (a threshold of 0 degrees): each gets its registration's and its choice's costs
    assert why_wrong.main([str(run), "--out", str(md), "--wrong-deg", "0"]) == 0
    rows = pd.read_csv(md.with_suffix(".csv"))
    assert len(rows) == 2 and list(rows.columns) == why_wrong.COLUMNS
    assert np.isfinite(rows[["cost_estimate", "cost_truth", "rule_cost_kept", "rule_cost_truth"]].to_numpy()).all()
    assert set(rows["choice"]) == {"cross_top_turns"}
    for err, verdict in zip(rows["registration_err_deg"], rows["registration"]):
        assert verdict == "imprecise" if err < why_wrong.NEAR_DEG else verdict in ("ambiguous", "not kept", "not found")
    assert "2 of 2 views kept an estimate 0 degrees or more" in md.read_text()


def test_what_is_not_a_run_is_one_line_and_exit_2(why_wrong, tmp_path, capsys):
    assert why_wrong.main([str(tmp_path), "--out", str(tmp_path / "w.md")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(tmp_path) in err[0] and "sweep" in err[0]
    assert not (tmp_path / "w.md").exists()
