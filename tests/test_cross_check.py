"""The ``cross`` template choice (issue 25): an estimate's cost on each of the view's templates
(:mod:`catpose.methods.cross_check`), the rule that reads them, and the runner hook that writes them
into the row's ``info``."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from catpose.bench.protocols.absolute import Templates, choose_row
from catpose.bench.run import sample_run
from catpose.bench.run.sample_run import facts_hook
from catpose.errors import ConfigError
from catpose.geometry import axis_angle_to_R
from catpose.methods.choice_rules import CROSS_WEIGHT, TOP_WEIGHT, choose_index, cross_cost
from catpose.methods.cross_check import (
    SILHOUETTE_CELL,
    SILHOUETTE_WEIGHT,
    TOP_FRACTION,
    TRUNC,
    TURNS_DEG,
    CrossCheck,
    silhouette_cells,
    silhouette_iou,
    top_centroid,
    turned,
)
from catpose.methods.template_choice import TemplateChoice

Z = np.array([0.0, 0.0, 1.0])
CHECK = CrossCheck()  # the defaults (configs/choice/score.yaml)
cross_costs, refine_on, top_offset, turn_candidates = (
    CHECK.cross_costs,
    CHECK.refine_on,
    CHECK.top_offset,
    CHECK.turn_candidates,
)


def _box_surface(size, n: int, seed: int):
    """Points (n, 3) and outward normals on an axis-aligned box's surface of side lengths ``size``."""
    rng = np.random.default_rng(seed)
    size = np.asarray(size, float)
    area = np.array([size[1] * size[2], size[0] * size[2], size[0] * size[1]])
    axis = rng.choice(3, n, p=area / area.sum())
    side = rng.choice([-1.0, 1.0], n)
    p = (rng.random((n, 3)) - 0.5) * size
    p[np.arange(n), axis] = side * size[axis] / 2
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), axis] = side
    return p, nrm


def _chair_like(seat_depth: float, back_height: float, seed: int):
    """A seat slab and a back slab at -y: a shape whose quarter turns about z do not fit it."""
    sp, sn = _box_surface([0.8, seat_depth, 0.1], 1500, seed)
    bp, bn = _box_surface([0.8, 0.1, back_height], 1000, seed + 1)
    bp = bp + np.array([0.0, -seat_depth / 2, back_height / 2])
    return SimpleNamespace(template_id=f"chair{seed}", points=np.vstack([sp, bp]), normals=np.vstack([sn, bn]), up=Z)


def _pose(deg: float, t=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = axis_angle_to_R(Z, np.deg2rad(deg))
    T[:3, 3] = t
    return T


def _view(template, camera_template: np.ndarray):
    """The points of ``template`` facing a camera at ``camera_template``, in a camera frame
    whose pose in the template frame is a pure translation to that centre."""
    vis = np.einsum("ij,ij->i", template.normals, camera_template[None] - template.points) > 0
    T_template_camera = _pose(0.0, camera_template)
    return template.points[vis] - camera_template, T_template_camera


def _cells_reference(points_camera, cell):
    """Independent reference of the silhouette cells: a Python loop over the points."""
    import math

    return {(math.floor(x / z / cell), math.floor(y / z / cell)) for x, y, z in points_camera.tolist() if z > 1e-9}


def test_own_cost_is_the_visibility_chamfer_plus_the_silhouette_term_at_the_estimate():
    tmpl = _chair_like(0.7, 0.8, 0)
    P, T = _view(tmpl, np.array([0.3, 2.5, 1.5]))
    # the camera looks along +z of its frame: turn the view so the object lies in front of it
    R = axis_angle_to_R(np.array([1.0, 0.0, 0.0]), np.deg2rad(-90.0))
    T_turn = np.eye(4)
    T_turn[:3, :3] = R
    P_cam = P @ R.T
    T = T @ np.linalg.inv(T_turn)
    own = cross_costs(P_cam, T, [tmpl], 0)[0]
    # independent reference: brute-force distances, the same truncation, no refinement
    src = P_cam @ T[:3, :3].T + T[:3, 3]
    d_in = np.minimum(np.linalg.norm(src[:, None] - tmpl.points[None], axis=2).min(1), TRUNC).mean()
    vis = tmpl.points[np.einsum("ij,ij->i", tmpl.normals, T[:3, 3][None] - tmpl.points) > 0]
    d_vis = np.minimum(np.linalg.norm(vis[:, None] - src[None], axis=2).min(1), TRUNC).mean()
    cell = SILHOUETTE_CELL / np.median(P_cam[:, 2])
    a = _cells_reference(P_cam, cell)
    b = _cells_reference((tmpl.points - T[:3, 3]) @ T[:3, :3], cell)
    assert 0.5 < len(a & b) / len(a | b) < 1.0  # the hidden side widens the outline a little
    assert own == pytest.approx(d_in + d_vis + SILHOUETTE_WEIGHT * (1 - len(a & b) / len(a | b)), rel=1e-9)


def test_silhouette_cells_and_iou():
    rng = np.random.default_rng(0)
    P = rng.uniform([-0.5, -0.5, 2.0], [0.5, 0.5, 3.0], (500, 3))
    behind = np.vstack([P, [[0.1, 0.1, -1.0], [0.0, 0.0, 0.0]]])  # at or behind the camera: left out
    assert silhouette_cells(behind, 0.02) == _cells_reference(P, 0.02)
    cells = silhouette_cells(P, 0.02)
    assert silhouette_iou(cells, P, 0.02) == 1.0
    shifted = P + [1.0, 0.0, 0.0]  # moved sideways by its own width: the outlines barely meet
    ref = _cells_reference(shifted, 0.02)
    assert silhouette_iou(cells, shifted, 0.02) == pytest.approx(len(cells & ref) / len(cells | ref))
    assert silhouette_iou(cells, shifted, 0.02) < 0.1
    assert silhouette_iou(set(), np.zeros((0, 3)), 0.02) == 0.0


def test_refinement_on_another_template_recovers_a_small_offset():
    tmpl = _chair_like(0.7, 0.8, 0)
    P, T = _view(tmpl, np.array([0.3, 2.5, 1.5]))
    off = _pose(3.0, (0.02, -0.01, 0.0)) @ T
    R = refine_on(P, tmpl, off)[:3, :3]
    angle = np.degrees(np.arccos(np.clip((np.trace(R.T @ T[:3, :3]) - 1) / 2, -1, 1)))
    assert angle < 1.0


def test_a_turned_estimate_costs_more_on_the_other_templates():
    # three templates of one category (different seat depths and back heights, one frame); the
    # view shows another instance; the right pose and a quarter turn, both "from" template 0
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10), _chair_like(0.8, 0.7, 20)]
    inst = _chair_like(0.65, 0.85, 30)
    P, T = _view(inst, np.array([0.8, 2.0, 1.5]))
    right = cross_costs(P, T, templates, 0)
    turned = cross_costs(P, _pose(90.0) @ T, templates, 0)
    assert cross_cost(right, 0, CROSS_WEIGHT) < cross_cost(turned, 0, CROSS_WEIGHT)
    assert np.mean(right[1:]) < np.mean(turned[1:])
    # cross_cost is own + weight x mean of the others
    assert cross_cost([0.1, 0.3, 0.5], 0, 0.75) == pytest.approx(0.1 + 0.75 * 0.4)
    assert cross_cost([0.2], 0, 0.75) == pytest.approx(0.2)


def _rows(costs, scores, errs, status=None, tops=None):
    K = len(scores)
    tops = tops or [0.0] * K
    return pd.DataFrame(
        {
            "group_id": ["chair/a/v00"] * K,
            "sample_id": [f"chair/a/v00|{k}" for k in range(K)],
            "status": status or ["ok"] * K,
            "score": scores,
            "err_deg": errs,
            "runtime_s": [1.0] * K,
            "T_est": [np.eye(4).reshape(-1).tolist()] * K,
            "info": [({"cross_costs": c, "top_offset": t} if c is not None else {}) for c, t in zip(costs, tops)],
        }
    )


def test_cross_rule_takes_the_lowest_cross_cost():
    # template 1 has the lowest own score but fits no other template
    costs = [[0.12, 0.13, 0.12], [0.20, 0.10, 0.30], [0.13, 0.14, 0.11]]
    rows = _rows(costs, [0.12, 0.10, 0.11], [4.0, 85.0, 6.0])
    assert choose_row(rows, "score")["err_deg"] == 85.0
    # own + 0.25 x others: 0.12 + 0.03125, 0.10 + 0.0625, 0.11 + 0.03125
    assert choose_row(rows, "cross")["err_deg"] == 6.0
    assert choose_index([0.1, 0.2], [np.eye(3)] * 2, "cross", cross=[0.3, np.nan]) == 0


def test_cross_rule_without_costs():
    # a registration whose check failed is chosen only when none has costs
    rows = _rows([[0.3, 0.3], None], [0.2, 0.1], [5.0, 50.0])
    rows.at[1, "info"] = {"estimate_facts_error": "boom"}
    assert choose_row(rows, "cross")["err_deg"] == 5.0
    # rows written before the check existed: one line that says to re-run
    with pytest.raises(ConfigError, match="cross_costs"):
        choose_row(_rows([None, None], [0.2, 0.1], [5.0, 50.0]), "cross")
    # rows written before the top offset existed: cross still reads them, cross_top says to re-run
    old = _rows([[0.3, 0.3], [0.3, 0.2]], [0.2, 0.1], [5.0, 50.0])
    old["info"] = [{"cross_costs": i["cross_costs"]} for i in old["info"]]
    assert choose_row(old, "cross")["err_deg"] == 50.0
    with pytest.raises(ConfigError, match="cross_top needs info.cross_costs and info.top_offset"):
        choose_row(old, "cross_top")
    # one template: nothing to choose, no costs needed
    assert choose_row(_rows([None], [0.2], [5.0]), "cross")["err_deg"] == 5.0


class _Hook:
    def __init__(self, facts=None, error=None):
        self.facts, self.error = facts, error

    def __call__(self, dataset, sample, T):
        assert T.shape == (4, 4)
        if self.error:
            raise self.error
        return self.facts


def test_runner_hook_adds_facts_and_keeps_the_estimate_when_they_fail():
    ok = {"status": "ok", "T_est": np.eye(4).reshape(-1).tolist(), "info": {"view": "v00"}}
    out = sample_run._with_estimate_facts(_Hook({"cross_costs": [0.1, 0.2]}), None, ok, None)
    assert out["info"] == {"view": "v00", "cross_costs": [0.1, 0.2]} and ok["info"] == {"view": "v00"}
    bad = sample_run._with_estimate_facts(_Hook(error=ValueError("no normals\nhere")), None, ok, None)
    assert bad["status"] == "ok" and "ValueError: no normals here" in bad["info"]["estimate_facts_error"]
    failed = {"status": "failed", "T_est": None, "info": {}}
    assert sample_run._with_estimate_facts(_Hook({"x": 1}), None, failed, None) is failed
    with pytest.raises(ImportError):  # not the sample's fault: the run stops
        sample_run._with_estimate_facts(_Hook(error=ImportError("x")), None, ok, None)


def test_costs_do_not_depend_on_the_estimates_last_bits():
    # estimates differ in their last bits between CPUs' BLAS kernels; the ICPs start from the
    # estimate rounded to 1e-9, so such a difference leaves every cost bit for bit the same
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10), _chair_like(0.8, 0.7, 20)]
    inst = _chair_like(0.65, 0.85, 30)
    P, T = _view(inst, np.array([0.8, 2.0, 1.5]))
    T = _pose(7.3, (0.0123, -0.0071, 0.0)) @ T
    nudged = T.copy()
    nudged[:3, :] += np.random.default_rng(0).choice([-1.0, 1.0], (3, 4)) * 4e-16 * np.maximum(np.abs(T[:3, :]), 1.0)
    assert not np.array_equal(nudged, T)
    assert cross_costs(P, nudged, templates, 0)[1:] == cross_costs(P, T, templates, 0)[1:]


def test_top_centroid_against_a_sorted_reference():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(200, 3))
    up = np.array([0.3, -0.5, 0.8])
    u = up / np.linalg.norm(up)
    top = P[np.argsort(P @ u)[-int(round(TOP_FRACTION * 200)) :]].mean(axis=0)  # the 20 highest points
    assert top_centroid(P, up) == pytest.approx(top - (top @ u) * u, abs=1e-12)
    assert abs(top_centroid(P, up) @ u) < 1e-12


def test_top_offset_places_a_turned_chairs_back():
    # the templates' backs stand at -y; the right pose puts the view's back there, a quarter turn
    # about up puts it at the side, a half turn at +y
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10), _chair_like(0.8, 0.7, 20)]
    inst = _chair_like(0.65, 0.85, 30)
    P, T = _view(inst, np.array([0.8, 2.0, 1.5]))
    right = top_offset(P, T, templates, 0)
    quarter, half = top_offset(P, _pose(90.0) @ T, templates, 0), top_offset(P, _pose(180.0) @ T, templates, 0)
    assert right < 0.15 < quarter < half

    # independent reference for the right pose: the 10 % highest posed points against the mean
    # of the templates' 10 % highest, compared across z
    def top_xy(X):
        return X[X[:, 2] >= np.quantile(X[:, 2], 0.9)][:, :2].mean(axis=0)

    X = P @ T[:3, :3].T + T[:3, 3]
    ref = np.linalg.norm(top_xy(X) - np.mean([top_xy(t.points) for t in templates], axis=0))
    assert right == pytest.approx(ref, abs=1e-12)
    # the same shapes in a frame whose up is +y give the same offsets
    R = axis_angle_to_R(np.array([1.0, 0.0, 0.0]), np.deg2rad(-90.0))
    turned = [
        SimpleNamespace(template_id=t.template_id + "y", points=t.points @ R.T, normals=t.normals @ R.T, up=R @ Z)
        for t in templates
    ]
    T_y = np.eye(4)
    T_y[:3, :3] = R
    assert top_offset(P, T_y @ _pose(90.0) @ T, turned, 0) == pytest.approx(quarter, abs=1e-9)


def test_cross_top_breaks_a_tie_of_the_cross_costs_by_the_top_offset():
    costs = [[0.20, 0.25], [0.25, 0.20]]
    rows = _rows(costs, [0.2, 0.2], [80.0, 5.0], tops=[0.7, 0.05])
    assert choose_row(rows, "cross")["err_deg"] == 80.0  # cross alone: the tie goes to the first
    assert choose_row(rows, "cross_top")["err_deg"] == 5.0
    assert cross_cost(costs[0], 0, CROSS_WEIGHT, 0.7, TOP_WEIGHT) == pytest.approx(
        0.20 + CROSS_WEIGHT * 0.25 + TOP_WEIGHT * 0.7
    )


def test_the_runners_hook_writes_the_costs_and_the_top_offset_on_the_protocols_templates():
    # the protocol gives the view's templates (and the sample's own index), the method side's
    # choice computes the facts; a protocol that lists no view templates, or no choice, gets no hook
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10)]
    P, T = _view(_chair_like(0.65, 0.85, 30), np.array([0.8, 2.0, 1.5]))
    dataset = SimpleNamespace(category_templates=lambda category: templates)
    sample = SimpleNamespace(problem=SimpleNamespace(points_camera=P, category="chair", sample_id="chair/c/v00|1"))
    assert Templates().view_templates(dataset, sample) == (templates, 1)
    hook = facts_hook(Templates(), TemplateChoice(rule="cross"))
    facts = hook(dataset, sample, T)
    assert facts["cross_costs"] == cross_costs(P, T, templates, 1)
    assert facts["top_offset"] == top_offset(P, T, templates, 1)
    assert facts["cross_check_s"] >= 0.0
    one = SimpleNamespace(category_templates=lambda category: templates[:1])
    assert hook(one, sample, T) == {}
    from catpose.bench.protocols.absolute import GtModel

    assert facts_hook(GtModel(), TemplateChoice()) is None and facts_hook(Templates(), None) is None


def test_turned_is_a_turn_about_up_after_the_estimate():
    T = _pose(20.0, (0.1, -0.2, 2.0))
    assert turned(T, Z, 90.0) == pytest.approx(_pose(90.0) @ T, abs=1e-12)
    assert turned(T, 3 * Z, -30.0) == pytest.approx(_pose(-30.0) @ T, abs=1e-12)  # up need not be unit


def test_turn_candidates_recover_a_quarter_turned_estimate():
    # the estimate is the right pose turned a quarter; turning it back (270) and refining finds
    # the right pose again, at a lower cross_top cost than the estimate's own
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10), _chair_like(0.8, 0.7, 20)]
    P, T = _view(_chair_like(0.65, 0.85, 30), np.array([0.8, 2.0, 1.5]))
    wrong = _pose(90.0) @ T
    cands = turn_candidates(P, wrong, templates, 0, (90.0, 270.0))
    assert [c["turn_deg"] for c in cands] == [90.0, 270.0]
    back = np.asarray(cands[1]["T_template_camera"])
    angle = np.degrees(np.arccos(np.clip((np.trace(back[:3, :3].T @ T[:3, :3]) - 1) / 2, -1, 1)))
    assert angle < 2.0
    assert cands[1]["cross_costs"] == cross_costs(P, back, templates, 0)
    assert cands[1]["top_offset"] == top_offset(P, back, templates, 0)
    own = cross_cost(
        cross_costs(P, wrong, templates, 0), 0, CROSS_WEIGHT, top_offset(P, wrong, templates, 0), TOP_WEIGHT
    )
    assert cross_cost(cands[1]["cross_costs"], 0, CROSS_WEIGHT, cands[1]["top_offset"], TOP_WEIGHT) < own


def test_cross_top_turns_keeps_the_best_candidate_with_its_pose_and_errors():
    costs = [[0.20, 0.25], [0.22, 0.24]]
    rows = _rows(costs, [0.2, 0.2], [90.0, 88.0], tops=[0.5, 0.5])
    T_gt = np.eye(4)
    rows["T_gt"] = [T_gt.tolist()] * 2
    rows["T_est"] = [_pose(90.0).tolist(), _pose(88.0).tolist()]
    back = _pose(4.0)  # row 1's estimate turned back, 4 degrees from the truth
    rows["info"] = [
        {
            **rows["info"][0],
            "turns": [
                {
                    "turn_deg": 90.0,
                    "T_template_camera": _pose(180.0).tolist(),
                    "cross_costs": [0.4, 0.4],
                    "top_offset": 0.9,
                }
            ],
        },
        {
            **rows["info"][1],
            "turns": [
                {"turn_deg": 270.0, "T_template_camera": back.tolist(), "cross_costs": [0.19, 0.20], "top_offset": 0.05}
            ],
        },
    ]
    before = [dict(i) for i in rows["info"]]
    chosen = choose_row(rows, "cross_top_turns")
    assert chosen["sample_id"] == "chair/a/v00|1" and chosen["info"]["turn_deg"] == 270.0
    assert np.asarray(chosen["T_est"]) == pytest.approx(back)
    assert chosen["err_deg"] == pytest.approx(4.0) and chosen["rot_err_deg"] == pytest.approx(4.0)
    assert list(rows["info"]) == before  # the run's rows are not changed
    assert choose_row(rows, "cross_top")["err_deg"] == 90.0  # without the turns: the registrations only
    # candidates that cost more than the registration's own estimate leave it as it is
    rows["info"] = [{**before[0], "turns": [{**before[0]["turns"][0]}]}, {**before[1], "turns": []}]
    kept = choose_row(rows, "cross_top_turns")
    assert kept["info"]["turn_deg"] == 0.0 and kept["err_deg"] == 90.0
    # rows written without turns
    rows["info"] = [{"cross_costs": c, "top_offset": 0.5} for c in costs]
    with pytest.raises(ConfigError, match="choice=cross_top_turns needs info.turns"):
        choose_row(rows, "cross_top_turns")


def test_the_choice_writes_the_turns_unless_told_not_to():
    templates = [_chair_like(0.7, 0.8, 0), _chair_like(0.6, 0.9, 10)]
    P, T = _view(_chair_like(0.65, 0.85, 30), np.array([0.8, 2.0, 1.5]))
    facts = TemplateChoice(rule="cross_top_turns").estimate_facts(P, templates, 1, T)
    assert facts["turns"] == turn_candidates(P, T, templates, 1, TURNS_DEG) and facts["turns_s"] >= 0.0
    assert "turns" not in TemplateChoice(turns_deg=[]).estimate_facts(P, templates, 1, T)
    assert [c["turn_deg"] for c in TemplateChoice(turns_deg=[180]).estimate_facts(P, templates, 1, T)["turns"]] == [
        180.0
    ]
    for bad in ("90", None, ["a"]):
        with pytest.raises(ConfigError, match="choice.turns_deg"):
            TemplateChoice(turns_deg=bad)


def test_one_template_cross_top_turns_chooses_among_the_estimate_and_its_turns():
    # K = 1: the choice computes the facts only when asked, for the turn rule, and the rule keeps the turn
    # whose own cost and top offset are lowest; a K = 1 row without turns is simply kept
    templates = [_chair_like(0.7, 0.8, 0)]
    P, T = _view(_chair_like(0.65, 0.85, 30), np.array([0.8, 2.0, 1.5]))
    assert TemplateChoice(rule="cross_top", one_template_turns=True).estimate_facts(P, templates, 0, T) == {}
    assert TemplateChoice(rule="cross_top_turns").estimate_facts(P, templates, 0, T) == {}  # not asked for
    wrong = _pose(90.0) @ T
    facts = TemplateChoice(rule="cross_top_turns", turns_deg=[90, 180, 270], one_template_turns=True).estimate_facts(
        P, templates, 0, wrong
    )
    assert facts["cross_costs"] == cross_costs(P, wrong, templates, 0) and len(facts["cross_costs"]) == 1
    assert [t["turn_deg"] for t in facts["turns"]] == [90.0, 180.0, 270.0]
    rows = _rows([facts["cross_costs"]], [0.1], [90.0])
    rows["info"] = [facts]
    rows["T_gt"] = [T.tolist()]
    rows["T_est"] = [wrong.tolist()]
    chosen = choose_row(rows, "cross_top_turns")
    assert chosen["info"]["turn_deg"] == 270.0 and chosen["err_deg"] < 2.0
    assert choose_row(rows, "score")["err_deg"] == 90.0
    plain = _rows([None], [0.1], [90.0])
    assert choose_row(plain, "cross_top_turns")["err_deg"] == 90.0
