"""``python experiments/_lib/ambiguity.py``: a wrong estimate is a search miss when the truth
explains the depth image better under ours' verifier, ambiguous otherwise."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from catpose.geometry import compose_T, make_T
from catpose.methods.ours.settings import SelectionSettings
from catpose.types import RegistrationProblem

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import study_module  # noqa: E402
from test_depth_check import _template, _view  # noqa: E402  (the depth check's test scene)

pytestmark = pytest.mark.experiment

ambiguity = study_module("experiments/_lib/ambiguity.py")


def _problem(tpl, image):
    """The view's masked depth pixels back-projected (camera frame): the refinement's input."""
    v, u = np.nonzero(image.mask)
    z = image.depth[v, u]
    K = np.asarray(image.K, float)
    pts = np.stack([(u - K[0, 2]) * z / K[0, 0], (v - K[1, 2]) * z / K[1, 1], z], axis=1)
    return RegistrationProblem(
        "s", "box", pts, np.tile([0.0, 0.0, -1.0], (len(pts), 1)), [0.0, -1.0, 0.0], tpl, depth_image=image
    )


def test_truth_costs_less_than_a_half_turn_of_an_asymmetric_object(ambiguity):
    tpl = _template()
    image, T_gt = _view(tpl)
    half_turn = compose_T(make_T(np.diag([-1.0, -1.0, 1.0]), np.zeros(3)), T_gt)  # 180 deg about the template's z
    est, gt, gt_refined = ambiguity.verifier_costs(SelectionSettings(), _problem(tpl, image), half_turn, T_gt)
    assert gt < 0.05 < est and gt_refined < 0.05


def test_an_annotation_a_little_off_is_refined_before_it_is_judged(ambiguity):
    """A truth annotated 4 deg and 2 cm off costs more than the estimate ours refined; the
    refined truth comes back to the depth image and the estimate is no longer called ambiguous."""
    from scipy.spatial.transform import Rotation

    tpl = _template()
    image, T_gt = _view(tpl)
    off = make_T(Rotation.from_rotvec(np.radians(4.0) * np.array([0.0, 0.6, 0.8])).as_matrix(), [0.02, -0.01, 0.0])
    T_annotated = compose_T(off, T_gt)
    problem = _problem(tpl, image)
    est, gt, gt_refined = ambiguity.verifier_costs(SelectionSettings(), problem, T_gt, T_annotated)
    assert gt_refined < gt and gt_refined < 0.05
    R_err = ambiguity.refined_truth(SelectionSettings(), problem, T_annotated)[:3, :3].T @ T_gt[:3, :3]
    assert np.degrees(np.arccos(np.clip((np.trace(R_err) - 1) / 2, -1, 1))) < 1.0
    np.testing.assert_array_equal(
        ambiguity.refined_truth(SelectionSettings(refine=False), problem, T_annotated), T_annotated
    )


def test_an_occluded_truth_still_explains_the_visible_mask(ambiguity):
    tpl = _template()
    image, T_gt = _view(tpl, occluder=True)
    est, gt, _ = ambiguity.verifier_costs(SelectionSettings(), _problem(tpl, image), T_gt, T_gt)
    assert est == gt and gt < 0.05


def test_table_counts_ambiguous_and_search_misses_per_part_and_object(ambiguity):
    rows = [
        {
            "sample_id": "a/1",
            "object": "obj 9",
            "wrong": True,
            "err_deg": 179.0,
            "cost_est": 0.3,
            "cost_gt": 0.4,
            "cost_gt_refined": 0.35,
            "ambiguous": True,
            "found": True,
        },
        {
            "sample_id": "a/2",
            "object": "obj 9",
            "wrong": True,
            "err_deg": 90.0,
            "cost_est": 0.5,
            "cost_gt": 0.2,
            "cost_gt_refined": 0.1,
            "ambiguous": False,
            "found": False,
        },
        {"sample_id": "b/1", "object": "obj 9", "wrong": False},
        {"sample_id": "b/2", "object": "obj 14", "wrong": False},
    ]
    out = ambiguity.table(rows, lambda row: row["sample_id"].split("/")[0])
    by = {(r["part"], r["object"]): r for r in out}
    assert (by["a", "obj 9"]["samples"], by["a", "obj 9"]["wrong"]) == (2, 2)
    assert (by["a", "obj 9"]["ambiguous"], by["a", "obj 9"]["search_miss"]) == (1, 1)
    assert by["a", "obj 9"]["found_not_chosen"] == 1  # the other one was never found
    assert by["a", "obj 9"]["median_cost_gt"] == pytest.approx(0.3)
    assert by["a", "obj 9"]["median_cost_gt_refined"] == pytest.approx(0.225)
    assert by["a", "obj 9"]["flips"] == 1
    assert (
        by["b", "all"]["samples"] == 2 and by["b", "all"]["wrong"] == 0 and np.isnan(by["b", "all"]["median_cost_gt"])
    )
    assert [r["object"] for r in out if r["part"] == "a"][-1] == "all"
    assert "| a | obj 9 | 2 | 2 | 1 | 1 | 1 | 1 | 0.300 | 0.225 | 0.400 |" in ambiguity.markdown("t", out)


def test_a_folder_that_is_not_a_run_is_one_line_and_exit_2(ambiguity, tmp_path, capsys):
    assert ambiguity.main([str(tmp_path), "--out", str(tmp_path / "t.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: run ") and "config.yaml" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "t.md").exists()
