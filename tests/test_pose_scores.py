"""Selection scores of ours (catpose.methods.pose_scores) on a toy shape with a known pose."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from catpose.geometry import axis_angle_to_R, make_T
from catpose.methods import pose_scores as S

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _clouds import box_cloud  # noqa: E402


def toy_problem():
    rng = np.random.default_rng(0)
    body, nb = box_cloud((1.2, 0.6, 0.3), (0, 0, 0), 3000, rng)
    bump, nu = box_cloud((0.2, 0.2, 0.3), (0.4, 0.0, 0.3), 600, rng)  # breaks the half-turn symmetry
    keep = ~((np.abs(body[:, 0] - 0.4) < 0.1) & (np.abs(body[:, 1]) < 0.1) & (body[:, 2] > 0.14))
    points, normals = np.concatenate([body[keep], bump]), np.concatenate([nb[keep], nu])
    # camera 3 units away, looking down at 45 degrees: T_template_camera
    R = axis_angle_to_R(np.array([1.0, 0.0, 0.0]), np.deg2rad(-135.0))
    T_camera_template = make_T(R, np.array([0.0, 0.0, 3.0]))
    T_template_camera = np.linalg.inv(T_camera_template)
    centre = T_template_camera[:3, 3]
    visible = S.visible_mask(points, normals, centre)
    observed = S.transform(T_camera_template, points[visible])
    return points, normals, observed, T_template_camera


def test_half_turns_are_rotations_and_involutions():
    H = S.half_turns()
    assert H.shape == (4, 4, 4)
    for F in H:
        assert np.allclose(F[:3, :3] @ F[:3, :3].T, np.eye(3)) and np.isclose(np.linalg.det(F[:3, :3]), 1.0)
        assert np.allclose(F @ F, np.eye(4))


def test_visibility_chamfer_prefers_the_true_pose_to_its_half_turn():
    points, normals, observed, T = toy_problem()
    tree = cKDTree(points)
    turned = S.half_turns()[3] @ T
    vis = S.visibility_chamfer(observed, np.stack([T, turned]), points, normals, tree, 0.1)
    assert vis[0] < 0.02 < vis[1]


def _numpy_score(observed, points, normals, tree):
    return lambda T: S.visibility_chamfer(observed, T, points, normals, tree, 0.1)


def test_select_with_half_turns_recovers_a_flipped_candidate():
    points, normals, observed, T = toy_problem()
    tree = cKDTree(points)
    ground = np.linalg.inv(T)[:3, :3] @ np.array([0.0, 0.0, 1.0])
    cands = np.stack([S.half_turns()[3] @ T, S.half_turns()[1] @ T])
    best, score, info = S.select_with_half_turns(
        cands,
        np.array([True, True]),
        _numpy_score(observed, points, normals, tree),
        lambda X: X,
        ground,
        np.array([0.0, 0.0, 1.0]),
        30.0,
    )
    assert np.allclose(best, T, atol=1e-9) and score < 0.02
    assert info["half_turn"] in (1, 3) and len(info["scores"]) == 2
    assert np.allclose(S.tilt_deg(best[None], ground, np.array([0.0, 0.0, 1.0])), 0.0, atol=1e-6)


def test_select_with_half_turns_refines_only_what_can_pass_gravity():
    """Hypotheses tilted beyond gravity_max_deg + REACH_DEG are not refined; disallowed candidates
    are not scored; without gravity every hypothesis is refined."""
    points, normals, observed, T = toy_problem()
    tree = cKDTree(points)
    up = np.array([0.0, 0.0, 1.0])
    ground = np.linalg.inv(T)[:3, :3] @ up
    cands = np.stack([T, S.half_turns()[1] @ T, S.half_turns()[3] @ T])
    numpy_score = _numpy_score(observed, points, normals, tree)
    scored, refined = [], []

    def score(X):
        scored.append(len(X))
        return numpy_score(X)

    def refine(X):
        refined.append(S.tilt_deg(X, ground, up))
        return X

    best, _, info = S.select_with_half_turns(
        cands, np.array([True, False, True]), score, refine, ground, up, 30.0, top_k=2
    )
    assert scored[0] == 2 and np.isinf(info["scores"][1])
    # top 2 allowed candidates x 4 half turns = 8 hypotheses; the turns about x and y of the
    # upright ones are tilted ~180 degrees and are skipped
    tilts = np.concatenate(refined)
    assert len(tilts) == 4 and tilts.max() <= 30.0 + S.REACH_DEG
    assert np.allclose(best, T, atol=1e-9) and info["candidate"] == 0 and info["half_turn"] == 0
    refined.clear()
    S.select_with_half_turns(cands, np.array([True, False, True]), score, refine, ground, up, None, top_k=2)
    assert len(np.concatenate(refined)) == 8
