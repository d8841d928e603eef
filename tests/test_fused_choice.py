"""The ``fused`` template choice (issue 25): the ``cross_top_turns`` choice averaged with the
agreeing poses of the view's other templates."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from catpose.bench.protocols.absolute import Templates, choose_row
from catpose.errors import ConfigError
from catpose.methods.choice_rules import AGREE_DEG, FUSE_RULES, TURN_RULES, ChoiceRule, fuse_agreeing


def _pose(deg: float, t=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(deg) * np.asarray(axis, float) / np.linalg.norm(axis)).as_matrix()
    T[:3, 3] = t
    return T


def _angle(R_a, R_b) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R_a.T @ R_b) - 1) / 2, -1, 1))))


def test_fuse_agreeing_averages_the_cheapest_agreeing_pose_of_each_other_template():
    chosen = _pose(10.0, (0.0, 0.0, 1.0))
    others = [
        (1, 0.3, _pose(20.0, (0.0, 0.0, 3.0))),  # agrees, but template 1 has a cheaper one
        (1, 0.2, _pose(14.0, (0.0, 0.0, 2.0))),
        (2, 0.1, _pose(90.0, (5.0, 0.0, 0.0))),
    ]  # a quarter turn off: left out
    T, n = fuse_agreeing(chosen, others)
    assert n == 2
    # two rotations about one axis: the chordal quaternion mean is the midpoint angle
    assert T[:3, :3] == pytest.approx(_pose(12.0)[:3, :3], abs=1e-12)
    assert T[:3, 3] == pytest.approx([0.0, 0.0, 1.5])
    assert np.array_equal(fuse_agreeing(chosen, others[2:])[0], chosen) and fuse_agreeing(chosen, others[2:])[1] == 1
    assert fuse_agreeing(chosen, [])[1] == 1


def test_fuse_agreeing_is_the_geodesic_midpoint_of_two_rotations():
    # independent reference: R_a exp(log(R_a^T R_b) / 2), the midpoint on the rotation group
    R_a = _pose(8.0, axis=(1.0, 2.0, 0.5))
    R_b = _pose(-7.0, axis=(0.3, -1.0, 2.0))
    assert _angle(R_a[:3, :3], R_b[:3, :3]) <= AGREE_DEG
    half = Rotation.from_matrix(R_a[:3, :3].T @ R_b[:3, :3]).as_rotvec() / 2
    mid = R_a[:3, :3] @ Rotation.from_rotvec(half).as_matrix()
    T, n = fuse_agreeing(R_a, [(1, 0.0, R_b)])
    assert n == 2 and T[:3, :3] == pytest.approx(mid, abs=1e-12)
    # a narrower angle than the two rotations' leaves the chosen pose alone
    assert fuse_agreeing(R_a, [(1, 0.0, R_b)], agree_deg=_angle(R_a[:3, :3], R_b[:3, :3]) - 0.1)[1] == 1


def _rows(ests, costs, turns=None):
    """One view's rows against len(ests) templates, ground truth the identity."""
    K = len(ests)
    turns = turns or [[] for _ in range(K)]
    return pd.DataFrame(
        {
            "group_id": ["chair/a/v00"] * K,
            "sample_id": [f"chair/a/v00|{k}" for k in range(K)],
            "status": ["ok"] * K,
            "score": [0.1] * K,
            "err_deg": [_angle(np.eye(3), T[:3, :3]) for T in ests],
            "runtime_s": [1.0] * K,
            "T_est": [T.tolist() for T in ests],
            "T_gt": [np.eye(4).tolist()] * K,
            "info": [{"cross_costs": c, "top_offset": 0.1, "turns": t} for c, t in zip(costs, turns)],
        }
    )


def test_fused_rule_averages_the_chosen_estimate_with_the_agreeing_templates():
    assert "fused" in FUSE_RULES and "fused" in TURN_RULES
    # template 0 is chosen (lowest cost, 6 degrees off); template 1 agrees (-4 degrees); template 2
    # is a quarter turn off; template 2's turned candidate agrees but costs more than 2's own
    turn_back = {
        "turn_deg": 270.0,
        "T_template_camera": _pose(-2.0).tolist(),
        "cross_costs": [0.30, 0.31, 0.32],
        "top_offset": 0.1,
    }
    rows = _rows(
        [_pose(6.0), _pose(-4.0), _pose(90.0)],
        [[0.10, 0.12, 0.12], [0.13, 0.11, 0.13], [0.20, 0.20, 0.20]],
        [[], [], [turn_back]],
    )
    plain = choose_row(rows, "cross_top_turns")
    assert plain["sample_id"] == "chair/a/v00|0" and plain["err_deg"] == pytest.approx(6.0)
    fused = choose_row(rows, "fused")
    assert fused["sample_id"] == "chair/a/v00|0" and fused["info"]["fused_templates"] == 3
    # the mean of 6, -4 and -2 degrees about one axis (three quaternions: close to, not exactly, 0)
    q = Rotation.from_matrix(np.stack([_pose(d)[:3, :3] for d in (6.0, -4.0, -2.0)])).mean().as_matrix()
    assert np.asarray(fused["T_est"])[:3, :3] == pytest.approx(q, abs=1e-12)
    assert fused["err_deg"] == pytest.approx(_angle(np.eye(3), q)) and fused["err_deg"] < 0.1
    assert "fused_templates" not in rows["info"][0]  # the run's rows are not changed
    # within 5 degrees of the chosen 6, neither -4 nor -2 agrees: the chosen pose is kept
    alone = choose_row(rows, ChoiceRule(rule="fused", agree_deg=5.0))
    assert alone["info"]["fused_templates"] == 1 and alone["err_deg"] == pytest.approx(6.0)


def test_templates_protocol_accepts_the_fused_rule_by_name_or_with_its_weights():
    protocol = Templates(choice="fused")
    assert protocol.choice == ChoiceRule(rule="fused") and protocol.choice.offset_weight == 0.075
    assert Templates(choice=ChoiceRule(rule="fused", fused_top_weight=0.2)).choice.offset_weight == 0.2
    rows = _rows([_pose(6.0), _pose(-4.0)], [[0.10, 0.12], [0.13, 0.11]], [[], []])
    rows["info"] = [{"cross_costs": c, "top_offset": 0.1} for c in ([0.10, 0.12], [0.13, 0.11])]  # no turns stored
    with pytest.raises(ConfigError, match="choice=fused needs info.turns"):
        protocol.best_per_view(rows)


def test_fused_weighs_the_top_offset_by_its_own_weight():
    # template 1's quarter-turned estimate fits a little better but puts the back at the side (top
    # offset 0.6 against 0.1): at cross_top_turns' TOP_WEIGHT it wins, at fused's FUSED_TOP_WEIGHT it does not
    from catpose.methods.choice_rules import CROSS_WEIGHT, FUSED_TOP_WEIGHT, TOP_WEIGHT, cross_cost

    assert ChoiceRule(rule="fused").offset_weight == FUSED_TOP_WEIGHT
    assert ChoiceRule(rule="cross_top_turns").offset_weight == TOP_WEIGHT
    assert ChoiceRule(rule="cross").offset_weight is None
    far = {"turn_deg": 90.0, "T_template_camera": _pose(180.0).tolist(), "cross_costs": [1.0, 1.0], "top_offset": 1.0}
    rows = _rows([_pose(2.0), _pose(90.0)], [[0.30, 0.30], [0.30, 0.27]], [[far], [far]])
    rows["info"] = [{**rows["info"][0], "top_offset": 0.1}, {**rows["info"][1], "top_offset": 0.6}]
    costs = {
        w: [cross_cost([0.30, 0.30], 0, CROSS_WEIGHT, 0.1, w), cross_cost([0.30, 0.27], 1, CROSS_WEIGHT, 0.6, w)]
        for w in (TOP_WEIGHT, FUSED_TOP_WEIGHT)
    }
    assert costs[TOP_WEIGHT][1] < costs[TOP_WEIGHT][0] and costs[FUSED_TOP_WEIGHT][0] < costs[FUSED_TOP_WEIGHT][1]
    assert choose_row(rows, "cross_top_turns")["sample_id"] == "chair/a/v00|1"
    kept = choose_row(rows, "fused")
    assert kept["sample_id"] == "chair/a/v00|0" and kept["err_deg"] == pytest.approx(2.0)
    assert choose_row(rows, ChoiceRule(rule="fused").with_offset_weight(TOP_WEIGHT))["sample_id"] == "chair/a/v00|1"
    assert choose_row(rows, ChoiceRule(rule="fused", fused_top_weight=TOP_WEIGHT))["sample_id"] == "chair/a/v00|1"
