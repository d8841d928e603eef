"""Ours' depth-image verification and gravity hypotheses (``method.selection.rule=depth``)."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _ours_fixtures import CAMERA, chair_template, rotation_error_deg  # noqa: E402

from catpose.datasets.render import depth_to_points, estimate_normals, render_depth  # noqa: E402
from catpose.geometry import compose_T, invert_T, look_at_T_camera_world, make_T  # noqa: E402
from catpose.methods.ours import Ours, RestingSettings, SelectionSettings  # noqa: E402
from catpose.methods.ours.resting import rotation_between  # noqa: E402
from catpose.types import DepthImage, RegistrationProblem  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread", "private_cache_dir")


@pytest.fixture(scope="module")
def template():
    return chair_template()


def scene_problem(template, seed: int, up_object=(0.0, 0.0, 1.0), occlude: bool = False):
    """The template standing on a table with ``up_object`` (object frame) pointing up, seen from a
    seeded viewpoint, optionally half hidden by a box in front; returns the problem (with its depth
    image) and the true ``T_template_camera``."""
    import trimesh

    rng = np.random.default_rng(seed)
    R = rotation_between(np.asarray(up_object, float), np.array([0.0, 0.0, 1.0]))
    v_world = template.vertices @ R.T
    T_world_object = make_T(R, [0.0, 0.0, -v_world[:, 2].min()])
    az, el = rng.uniform(0, 2 * np.pi), np.deg2rad(rng.uniform(25, 55))
    eye = 3.2 * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]) + [0, 0, 0.5]
    T_camera_world = look_at_T_camera_world(eye, np.array([0.0, 0.0, 0.5]), np.array([0.0, 0.0, 1.0]))
    T_camera_object = compose_T(T_camera_world, T_world_object)
    parts = [render_depth(template.vertices, template.triangles, T_camera_object, CAMERA).astype(float)]
    table = trimesh.creation.box(extents=[10.0, 10.0, 0.01], transform=np.diag([1.0, 1, 1, 1]))
    table.apply_translation([0, 0, -0.006])
    parts.append(render_depth(table.vertices, table.faces, T_camera_world, CAMERA).astype(float))
    if occlude:
        box = trimesh.creation.box(extents=[0.5, 0.5, 2.0])
        box.apply_translation(0.45 * eye / np.linalg.norm(eye) * np.array([1, 1, 0]) + [0, 0, 1.0])
        parts.append(render_depth(box.vertices, box.faces, T_camera_world, CAMERA).astype(float))
    stack = np.stack(parts)
    depth = np.where(stack > 0, stack, np.inf).min(axis=0)
    depth = np.where(np.isfinite(depth), depth, 0.0)
    mask = (parts[0] > 0) & (parts[0] <= depth + 1e-9)
    pts, _ = depth_to_points(depth, CAMERA, mask)
    g = T_camera_world[:3, 2]
    problem = RegistrationProblem(
        f"seed{seed}",
        template.category,
        pts,
        estimate_normals(pts, 0.06),
        g,
        template,
        depth_image=DepthImage(depth, CAMERA.K, mask),
    )
    return problem, invert_T(T_camera_object)


def _ours(**sel) -> Ours:
    return Ours(selection=SelectionSettings(rule="depth", **sel), resting=RestingSettings())


def test_upright_views_are_right_and_the_extras_say_how(template):
    method = _ours()
    errs = []
    for seed in range(4):
        p, T = scene_problem(template, seed)
        r = method.register(p)
        errs.append(rotation_error_deg(r.T_template_camera[:3, :3], T[:3, :3]))
        extras = json.loads(json.dumps(r.extras))
        assert {"pool_index", "resting", "depth_score", "depth_inliers", "depth_poor_fit", "final_turn"} <= set(extras)
        assert {"verification", "refinement", "optimization"} <= set(extras["timings"])
        assert r.score == pytest.approx(extras["depth_score"])
        # the candidates it chose among come back (catpose.register and the diagnosis read them)
        C = np.asarray(r.candidates_T)
        assert C.ndim == 3 and C.shape[1:] == (4, 4) and len(r.candidate_scores) == len(C)
        assert min(rotation_error_deg(c[:3, :3], r.T_template_camera[:3, :3]) for c in C) < 10.0
    assert np.median(errs) < 3.0, errs


def test_a_half_hidden_object_is_still_right(template):
    method = _ours()
    errs = [
        rotation_error_deg(method.register(p).T_template_camera[:3, :3], T[:3, :3])
        for p, T in (scene_problem(template, s, occlude=True) for s in range(3))
    ]
    assert np.median(errs) < 5.0, errs


def test_an_object_on_its_back_needs_the_resting_hypotheses(template):
    """The chair lies on its back (the back's outer face, -x, on the table): the coarse search over
    every resting pose finds it, resting on another up than the template's; with the template's
    own up only (``max_poses=0``) ours is wrong."""
    with_rests = _ours()
    without = Ours(selection=SelectionSettings(rule="depth"), resting=RestingSettings(max_poses=0))
    right, other_rest, wrong_without = 0, 0, 0
    for seed in range(3):
        p, T = scene_problem(template, seed, up_object=(1.0, 0.0, 0.0))
        r = with_rests.register(p)
        right += rotation_error_deg(r.T_template_camera[:3, :3], T[:3, :3]) < 10
        other_rest += r.extras["resting"] != 0
        wrong_without += rotation_error_deg(without.register(p).T_template_camera[:3, :3], T[:3, :3]) > 10
    assert right >= 2 and other_rest >= 2 and wrong_without >= 2


def test_the_search_holds_the_truth_at_every_stage_on_an_upside_down_chair(template):
    """Hypothesis recall: the poses ours held at each stage (``extras["hypothesis_stages"]``) come
    back, template frame, and on an upside-down chair the coarse search already holds the truth."""
    p, T = scene_problem(template, 2, up_object=(0.0, 0.0, -1.0))
    r = _ours().register(p)
    stages = {k: np.asarray(v) for k, v in r.extras["hypothesis_stages"].items()}
    assert list(stages)[:3] == ["candidates", "rest_grid", "pool"] and "final_refine" in stages
    assert all(v.ndim == 3 and v.shape[1:] == (4, 4) for v in stages.values())
    best = {k: min(rotation_error_deg(t[:3, :3], T[:3, :3]) for t in v) for k, v in stages.items()}
    assert best["rest_grid"] < 10 and best["pool"] < 10, best
    json.dumps(r.extras)  # still JSON: the runner scores and drops the poses


def test_without_a_depth_image_the_fallback_rule_answers(template):
    p, _ = scene_problem(template, 0)
    plain = replace(p, depth_image=None)
    a = _ours().register(plain)
    b = Ours(selection=SelectionSettings(rule="visibility")).register(plain)
    np.testing.assert_array_equal(a.T_template_camera, b.T_template_camera)
    assert "depth_score" not in a.extras


def test_a_mask_bleeding_over_its_edge_is_not_a_poor_fit(template):
    """The poor-fit test counts the mask's pixels 3 px inside its edge (``depth_fit_erode_px``):
    a segmentation grown by 2 px onto the table leaves the right template's fit whole there, where
    the whole mask's would send the view to the point rule."""
    from scipy.ndimage import binary_dilation

    p, T_true = scene_problem(template, 1)
    img = p.depth_image
    bled = replace(
        p, depth_image=DepthImage(img.depth, img.K, binary_dilation(img.mask, iterations=2) & (img.depth > 0))
    )
    inner = _ours().register(bled)  # the defaults: 3 px inside the edge, 0.95
    whole = _ours(depth_fit_erode_px=0).register(bled)
    assert whole.extras["depth_inliers_loose"] < 0.95 <= inner.extras["depth_inliers_loose"]
    assert whole.extras["depth_poor_fit"] is True and inner.extras["depth_poor_fit"] is False
    assert rotation_error_deg(inner.T_template_camera[:3, :3], T_true[:3, :3]) < 10


def test_a_template_unlike_the_object_falls_back_to_the_point_rule(template):
    p, _ = scene_problem(template, 1)
    r = _ours(depth_min_inliers=1.01).register(p)  # no pose can explain more than every pixel
    assert r.extras["depth_poor_fit"] is True and np.isfinite(r.score)
    c = Ours(selection=SelectionSettings(rule="chamfer"), resting=RestingSettings()).register(p)
    np.testing.assert_allclose(r.T_template_camera, c.T_template_camera, atol=1e-12)


def test_depth_problems_register_one_by_one_in_a_batch(template):
    problems = [scene_problem(template, s)[0] for s in range(2)]
    method = _ours()
    batch = method.register_batch(problems)
    single = [method.register(p) for p in problems]
    for a, b in zip(batch, single):
        np.testing.assert_array_equal(a.T_template_camera, b.T_template_camera)


def test_a_winner_turned_half_way_round_meets_its_half_turn_and_loses(template):
    """Step 4 (the last comparison): a winner that is the truth turned 180 deg about the up meets
    its half turns; the one about the up comes back to the truth after the refinement and costs
    less on the final lattice. The truth itself stays."""
    from catpose.methods.ours import check, choice
    from catpose.methods.ours.refine import final_inputs
    from catpose.methods.ours.resting import ups

    method = _ours()
    sel = method.selection
    p, T_true = scene_problem(template, 1)
    verifiers = (check.depth_verifier(sel, p), check.final_verifier(sel, p))
    fixed = final_inputs(verifiers[1], template)
    gravity = (p.ground_normal_camera, ups(template, RestingSettings(max_poses=0)), None)
    T_flip = compose_T(make_T(np.diag([-1.0, -1.0, 1.0]), np.zeros(3)), T_true)  # 180 deg about the template's z
    timings = {"verification": 0.0, "refinement": 0.0}
    for T_win, turn in ((T_flip, 3), (T_true, 0)):
        score = float(verifiers[1].scores(T_win[None])[0])
        T, s, rest, got, (T_turned, turned_costs) = choice.against_half_turns(
            sel, fixed, verifiers, T_win, score, 0, gravity, timings
        )
        assert got == turn and rest == 0
        assert rotation_error_deg(T[:3, :3], T_true[:3, :3]) < 3.0
        assert s <= score
        # the turned poses it compared come back with their costs, the answer's among them or the winner
        assert len(T_turned) == len(turned_costs) >= 1 and np.isfinite(turned_costs).any()
        assert min(turned_costs) >= s or turn != 0
    assert timings["refinement"] > 0.0 and timings["verification"] > 0.0


def _turned(deg: float, axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) a turn by ``deg`` about ``axis`` (template frame), no shift."""
    from scipy.spatial.transform import Rotation

    return make_T(Rotation.from_rotvec(np.deg2rad(deg) * np.asarray(axis, float)).as_matrix(), [0.0, 0.0, 0.0])


def test_the_runner_up_is_the_cheapest_pose_another_answer_away():
    from catpose.methods.ours.choice import RUNNER_UP_DEG, runner_up

    T_win = _turned(0.0)
    # a copy 2 deg away (cheapest, the same answer), a half turn, a pose 40 deg away, one not eligible
    T = np.stack([_turned(2.0), _turned(180.0, (1.0, 0.0, 0.0)), _turned(40.0), _turned(90.0)])
    costs = np.array([0.10, 0.13, 0.20, np.inf])
    got = runner_up(T_win, 0.11, T, costs, None)
    assert got["cost"] == 0.13 and got["margin"] == pytest.approx(0.02)
    assert np.allclose(got["T_template_camera"], T[1])
    assert rotation_error_deg(np.asarray(got["T_template_camera"])[:3, :3], T_win[:3, :3]) > RUNNER_UP_DEG
    # about a symmetry axis (z) a spin is the same answer: the 40-deg spin is not a runner-up either
    assert runner_up(T_win, 0.11, T[[0, 2]], costs[[0, 2]], np.array([0.0, 0.0, 1.0])) is None
    assert runner_up(T_win, 0.11, T[[0, 2]], costs[[0, 2]], None)["cost"] == 0.20
    # nothing else compared, or nothing eligible: none
    assert runner_up(T_win, 0.11, np.zeros((0, 4, 4)), np.zeros(0), None) is None
    assert runner_up(T_win, 0.11, T[[3]], costs[[3]], None) is None


def test_ours_names_its_runner_up_and_how_nearly_it_won(template):
    """The answer's runner-up is another answer (more than 10 deg off it), compared on the final
    lattice with it: its margin is >= 0 and its cost the answer's plus the margin."""
    from catpose.methods.ours.choice import RUNNER_UP_DEG

    p, _ = scene_problem(template, 0)
    r = _ours().register(p)
    second = json.loads(json.dumps(r.extras))["runner_up"]
    assert second is not None and second["margin"] >= 0.0
    assert second["cost"] == pytest.approx(r.score + second["margin"])
    T2 = np.asarray(second["T_template_camera"])
    assert rotation_error_deg(T2[:3, :3], r.T_template_camera[:3, :3]) > RUNNER_UP_DEG
