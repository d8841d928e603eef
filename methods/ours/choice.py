"""The choice, ours' depth-check stage (``method.selection.rule=depth``): one pose from a pool.

Input: a pool of candidate poses ``T_template_camera`` in the template's frame, from two searches
(:meth:`catpose.methods.ours.Ours.register`): the paper's dictionary candidates of the template's
own up (those the gravity filter keeps, the :data:`PRESCREEN` of lowest one-directional Chamfer
distance: :func:`dictionary_pool`), and the coarse search over every stable resting pose x yaw
(:mod:`catpose.methods.ours.rest_search`).

1. Every pose of the pool is scored by the depth check (:mod:`catpose.methods.ours.check`) and
   the ``depth_top_k`` best go on.
2. Those that can come back within the gravity limit of some resting direction are refined by
   point-to-plane ICP on the input's Chamfer subset (:mod:`catpose.methods.ours.refine`), scored
   again, filtered by gravity (any resting direction), and the ``depth_final_refine`` of lowest
   depth cost go on (the pool's poses as they were compete too).
3. Those are refined on the depth image's mask pixels of the final lattice against a fixed sample
   of the template's mesh (:func:`catpose.methods.ours.refine.final_inputs`: points no seed
   draws) and scored again on the final lattice (``depth_final_pixels``); the lowest cost wins.
4. The winner meets the one of its three half turns about the
   template's axes that the coarse lattice scores best (of those gravity allows), refined as in
   step 3 and compared on the final lattice: a near-symmetric object's half turn explains
   the image almost as well as the truth, and the coarse lattice of step 2 often drops the right
   one of the two before step 3 sees it. The lower cost wins; its depth score is the ``score``.
5. When the winner explains fewer than ``depth_min_inliers`` of the mask's inner pixels (a
   template unlike the object), the ``chamfer`` rule chooses among the own up's candidates
   instead (:func:`poor_fit`).

The result's ``extras["hypothesis_stages"]`` holds the poses held after each step (the runner
scores them against the truth: hypothesis recall), ``extras`` say which resting direction and half
turn won, and ``extras["runner_up"]`` is the best pose of steps 3 and 4 that an answer at 10 degrees
would call another answer (:func:`runner_up`): with its ``margin`` (its cost minus the winner's on
the final lattice) it says how nearly the depth image chose otherwise (a near-symmetric object's
half turn: a margin near 0).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from catpose.geometry import compose_T, norm3
from catpose.methods.ours.candidates import Candidates, TemplateFeatures
from catpose.methods.ours.check import DepthVerifier, final_verifier
from catpose.methods.ours.point_choice import chamfer_distances, finish
from catpose.methods.ours.refine import final_inputs, refine_poses
from catpose.methods.ours.settings import SelectionSettings
from catpose.methods.pose_scores import REACH_DEG, half_turns
from catpose.types import RegistrationProblem, RegistrationResult

__all__ = [
    "FIT_TAU",
    "POOR_FIT_RULE",
    "PRESCREEN",
    "RUNNER_UP_DEG",
    "dictionary_pool",
    "poor_fit",
    "runner_up",
    "select_by_depth",
    "stage_lists",
    "tilts_deg",
]

#: the runner-up differs from the answer by more than this (degrees; the @10 threshold)
RUNNER_UP_DEG = 10.0
#: dictionary candidates of the own up depth-checked, those of lowest one-way Chamfer distance
#: (the pool's share of the dictionary; docs/choosing-defaults.md, the clutter dev scenes)
PRESCREEN = 6
#: tolerance of the poor-fit test, object-normalised unit (docs/choosing-defaults.md)
FIT_TAU = 0.2
#: the rule that chooses when no pose explains the image (docs/choosing-defaults.md: clutter dev
#: scenes with category templates)
POOR_FIT_RULE = "chamfer"


def select_by_depth(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    pool: np.ndarray,
    cands: Candidates,
    feats: TemplateFeatures,
    ups: np.ndarray,
    timings: dict[str, float],
    verifier: DepthVerifier,
) -> RegistrationResult:
    """Steps 1-4 of the module docstring on ``pool`` (P, 4, 4), template frame. ``cands``: the
    own up's candidates (their input points, ``points`` and ``chamfer_src``, are refined);
    ``feats``: the template's features; ``ups`` (H, 3): the resting directions, template frame,
    the template's up first; ``verifier``: the problem's depth check on the coarse lattice
    (:func:`catpose.methods.ours.check.depth_verifier`)."""
    timings.setdefault("verification", 0.0)
    timings.setdefault("refinement", 0.0)
    t0 = time.perf_counter()
    g, axis = problem.ground_normal_camera, problem.template.symmetry_axis
    gravity = (g, ups, axis)
    pre = verifier.scores(pool)
    order = np.argsort(pre, kind="stable")[: sel.depth_top_k]
    timings["verification"] += time.perf_counter() - t0

    # step 2: the best refined on the Chamfer subset, scored
    t0 = time.perf_counter()
    T_exp = pool[order].copy()
    chosen = np.arange(len(T_exp))
    if sel.gravity_max_deg is not None:
        reachable = tilts_deg(T_exp, g, ups, axis).min(axis=1) <= sel.gravity_max_deg + REACH_DEG
        chosen = chosen[reachable] if reachable.any() else chosen
    if sel.refine:
        T_exp[chosen] = refine_poses(cands.chamfer_src, feats.pairing, problem.template.normals, T_exp[chosen])
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    final = np.full(len(T_exp), np.inf)
    final[chosen] = verifier.scores(T_exp[chosen])
    # the pool's poses as they were go on too: ICP on the few points of a mostly hidden object can
    # slide a right pose into free space
    T_exp, final = np.concatenate([T_exp, pool[order]]), np.concatenate([final, pre[order]])
    expanded = [(int(o), 0) for o in order] + [(int(o), -1) for o in order]
    cost, keep, _ = _costs(sel, final, T_exp, *gravity)
    timings["verification"] += time.perf_counter() - t0

    # step 3: the best few refined on every input point, scored again; the lowest cost wins
    t0 = time.perf_counter()
    top = np.argsort(np.where(keep, cost, np.inf), kind="stable")[: sel.depth_final_refine]
    top = top[np.isfinite(cost[top])] if np.isfinite(cost[top]).any() else top[:1]
    T_top = T_exp[top].copy()
    coarse, verifier = verifier, final_verifier(sel, problem, verifier)
    fixed = final_inputs(verifier, problem.template)  # the same under every seed
    if sel.refine:  # each refined on the image's points, and as it was (whichever costs less on the final lattice)
        T_top = np.concatenate([refine_poses(*fixed, T_top), T_top])
        top = np.concatenate([top, top])
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    top_scores = verifier.scores(T_top)
    top_cost, top_keep, rest_top = _costs(sel, top_scores, T_top, *gravity)
    b = int(np.argmin(np.where(top_keep, top_cost, np.inf))) if top_keep.any() else int(np.argmin(top_cost))
    T_out, score, rest = T_top[b], float(top_scores[b]), int(rest_top[b])
    timings["verification"] += time.perf_counter() - t0

    # step 4: the winner against its own half turns on the final lattice
    compared = (T_top, np.where(top_keep, top_cost, np.inf))  # every pose scored on the final lattice
    T_out, score, rest, final_turn, turned = against_half_turns(
        sel, fixed, (coarse, verifier), T_out, score, rest, gravity, timings
    )
    compared = (np.concatenate([compared[0], turned[0]]), np.concatenate([compared[1], turned[1]]))
    second = runner_up(T_out, score, *compared, axis)
    t0 = time.perf_counter()
    fit = verifier.fit(T_out[None])[0]  # the whole mask
    # the poor-fit test's, depth_fit_erode_px inside the mask's edge (the rendering is kept)
    fit_loose = verifier.fit(T_out[None], FIT_TAU, sel.depth_fit_erode_px)[0]
    timings["verification"] += time.perf_counter() - t0

    extras = {
        "pool_index": expanded[int(top[b])][0],
        "half_turn": expanded[int(top[b])][1],
        "final_turn": final_turn,
        "resting": rest,
        "resting_up": [float(x) for x in ups[rest]],
        "num_hypotheses": len(ups),
        "pool_size": len(pool),
        "depth_score": score,
        "depth_inliers": float(fit[0]),
        "depth_free": float(fit[1]),
        "depth_inliers_loose": float(fit_loose[0]),
        "depth_stride": verifier.lattice.stride,
        "depth_mask_pixels": verifier.mask_pixels,
        "prescores": [float(x) for x in np.sort(pre)[:8]],
        "timings": {name: float(v) for name, v in timings.items()},
        "num_input_points": int(len(cands.points)),
        "hypothesis_stages": stage_lists(top_k=pool[order], expanded=T_exp, final_refine=T_top),
        "runner_up": second,
    }
    # every pose scored in step 2 (template frame) with its cost (inf: not kept)
    return RegistrationResult(
        T_template_camera=T_out,
        score=score,
        extras=extras,
        candidates_T=T_exp,
        candidate_scores=np.where(keep, cost, np.inf).astype(float),
    )


def poor_fit(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    result: RegistrationResult,
    cands: Candidates,
    feats: TemplateFeatures,
    verifier: DepthVerifier,
    timings: dict[str, float],
) -> RegistrationResult:
    """Step 5: ``result`` (of :func:`select_by_depth`) when its winner explains at least
    ``depth_min_inliers`` of the mask's inner pixels; otherwise no hypothesis explains the image
    (the template is unlike the object, category level) and :data:`POOR_FIT_RULE` chooses among
    the own up's candidates ``cands``, scored by ``verifier`` (the pool's lattice) like the rest.
    ``extras["depth_poor_fit"]`` says which."""
    extras = dict(result.extras)
    if extras["depth_inliers_loose"] >= sel.depth_min_inliers:
        return replace(result, extras=dict(extras, depth_poor_fit=False))
    fallback = finish(replace(sel, rule=POOR_FIT_RULE), problem, cands, feats, timings)
    score = float(verifier.scores(fallback.T_template_camera[None])[0])
    extras.update(
        {k: v for k, v in fallback.extras.items() if k != "hypothesis_stages"},
        depth_poor_fit=True,
        depth_score=score,
        timings={k: float(v) for k, v in timings.items()},
    )
    return RegistrationResult(
        T_template_camera=fallback.T_template_camera,
        score=score,
        extras=extras,
        candidates_T=fallback.candidates_T,
        candidate_scores=fallback.candidate_scores,
    )


def runner_up(
    T_win: np.ndarray, cost_win: float, T: np.ndarray, costs: np.ndarray, axis: np.ndarray | None
) -> dict | None:
    """The best of the poses ``T`` (B, 4, 4; their ``costs`` (B,), lower is better, inf: not
    eligible) whose rotation differs from the answer ``T_win`` (4, 4) by more than
    :data:`RUNNER_UP_DEG` (for a template with a continuous symmetry ``axis`` (3,), the angle
    between the axis' directions in the camera frame: a spin about it is no other answer), as
    ``{"T_template_camera": 4 x 4 nested list, "cost": float, "margin": float}`` with ``margin`` its
    cost minus the answer's ``cost_win`` (>= 0 when both were compared on one lattice); None when
    no finite-cost pose differs."""
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)
    costs = np.asarray(costs, dtype=np.float64)
    if len(T) == 0:
        return None
    dots = np.einsum("bi,i->b", _orientations(T, axis), _orientations(np.asarray(T_win)[None], axis)[0])
    other = np.isfinite(costs) & (dots < _dot_limit(RUNNER_UP_DEG, axis))
    if not other.any():
        return None
    i = int(np.argmin(np.where(other, costs, np.inf)))
    return {"T_template_camera": T[i].tolist(), "cost": float(costs[i]), "margin": float(costs[i] - cost_win)}


def _orientations(T: np.ndarray, axis: np.ndarray | None) -> np.ndarray:
    """Per pose (B, 4, 4) the row whose dot product with another pose's tells how far apart their
    orientations are (:func:`_dot_limit`): the 9 entries of R ((B, 9): the dot is trace(R_i^T
    R_j)), or, for a template with a continuous symmetry ``axis`` (3,), that axis in the camera
    frame ((B, 3): a spin about it changes nothing). einsum, not BLAS: the same bits on any CPU."""
    R = np.asarray(T, dtype=np.float64)[:, :3, :3]
    if axis is None:
        return R.reshape(len(R), 9)
    a = np.asarray(axis, dtype=np.float64) / norm3(np.asarray(axis, dtype=np.float64))
    return np.einsum("bji,j->bi", R, a)


def _dot_limit(min_deg: float, axis: np.ndarray | None) -> float:
    """The dot product of two :func:`_orientations` rows below which the orientations differ by
    more than ``min_deg`` degrees (the trace 2 cos + 1; between axes, cos)."""
    c = math.cos(math.radians(min_deg))
    return c if axis is not None else 2.0 * c + 1.0


def stage_lists(**stages: np.ndarray) -> dict[str, list]:
    """``extras["hypothesis_stages"]``: each stage's poses (B, 4, 4) as nested lists (JSON), in
    the order given (the search's order)."""
    return {name: np.asarray(T, dtype=np.float64).reshape(-1, 4, 4).tolist() for name, T in stages.items()}


def dictionary_pool(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    cands: Candidates,
    feats: TemplateFeatures,
    up: np.ndarray,
) -> np.ndarray:
    """(P, 4, 4) template-frame poses of the dictionary candidates ``cands``: those the gravity
    filter keeps (tilt against the template's up ``up`` (3,); all of them when none passes), the
    :data:`PRESCREEN` of lowest one-directional Chamfer distance (``feats``) among them."""
    keep = np.ones(len(cands.T), dtype=bool)
    if sel.gravity_max_deg is not None:
        g, axis = problem.ground_normal_camera, problem.template.symmetry_axis
        keep &= tilts_deg(cands.T, g, up[None], axis)[:, 0] <= sel.gravity_max_deg
        keep = keep if keep.any() else np.ones(len(cands.T), dtype=bool)
    kept = np.nonzero(keep)[0]
    if 0 < PRESCREEN < len(kept):
        dists = chamfer_distances(feats.tree, cands.chamfer_src, cands.T[kept], feats.truncated)
        kept = np.sort(kept[np.argsort(dists, kind="stable")[:PRESCREEN]])
    return cands.T[kept]


def against_half_turns(
    sel: SelectionSettings,
    fixed: tuple,
    verifiers,
    T_win: np.ndarray,
    score: float,
    rest: int,
    gravity,
    timings: dict[str, float],
) -> tuple[np.ndarray, float, int, int, tuple[np.ndarray, np.ndarray]]:
    """Step 4: the winner ``T_win`` (4, 4, template frame) against the one of its three half turns
    about the template's axes that the coarse lattice scores best (of those the gravity filter
    keeps; by the same cost as every comparison, :func:`_costs`), refined on ``fixed`` (the
    points, template grid and normals of :func:`catpose.methods.ours.refine.final_inputs`) and
    scored with the winner on the final lattice. ``verifiers``: (coarse, final); ``gravity``:
    (ground normal, resting directions, symmetry axis). Returns the pose that costs less, its
    depth score, its resting direction, which turn it is (0: the winner itself, 1-3: about x,
    y, z) and the turned poses scored on the final lattice with their costs ((M, 4, 4), (M,); inf:
    gravity does not keep it)."""
    coarse, final = verifiers
    t0 = time.perf_counter()
    turns = [(j, F) for j, F in enumerate(half_turns()) if j > 0 and not _spin(F, gravity[2])]
    T_turns = np.stack([compose_T(F, T_win) for _, F in turns])
    cost, keep, _ = _costs(sel, coarse.scores(T_turns), T_turns, *gravity)
    timings["verification"] += time.perf_counter() - t0
    none = (np.zeros((0, 4, 4)), np.zeros(0))
    if not keep.any():
        return T_win, score, rest, 0, none
    # one turn: three measured the same (docs/choosing-defaults.md); the gravity filter mostly keeps one
    best = [int(np.argmin(np.where(keep, cost, np.inf)))]
    t0 = time.perf_counter()
    T_turn = T_turns[best]
    if sel.refine:  # each refined on the fixed points, and as it was (ICP can make a right pose worse)
        T_turn = np.concatenate([refine_poses(*fixed, T_turn), T_turn])
        best = best + best
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    T_all = np.concatenate([T_win[None], T_turn])
    scores = np.concatenate([[score], final.scores(T_turn)])
    cost, keep, rests = _costs(sel, scores, T_all, *gravity)
    timings["verification"] += time.perf_counter() - t0
    if not keep.any():
        return T_win, score, rest, 0, none
    turned = (T_turn, np.where(keep, cost, np.inf)[1:])
    w = int(np.argmin(np.where(keep, cost, np.inf)))
    if w == 0:
        return T_win, score, rest, 0, turned
    return T_all[w], float(scores[w]), int(rests[w]), turns[best[w - 1]][0], turned


def _spin(F: np.ndarray, axis: np.ndarray | None) -> bool:
    """Whether the turn ``F`` (4, 4) is a rotation about a continuous symmetry ``axis`` (3,) (it
    changes nothing the depth image shows)."""
    if axis is None:
        return False
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    return bool(np.abs(F[:3, :3] @ a - a).max() < 1e-6 and np.abs(F[:3, :3] - np.eye(3)).max() > 1e-9)


def _costs(sel: SelectionSettings, scores: np.ndarray, T_template: np.ndarray, g, ups, axis):
    """Depth scores as costs, the gravity mask (all finite ones when none passes) and each pose's
    resting direction (index into ``ups``)."""
    tilts = tilts_deg(T_template, g, ups, axis)
    rest = tilts.argmin(axis=1)
    cost = np.asarray(scores, dtype=np.float64)
    keep = np.isfinite(cost)
    if sel.gravity_max_deg is not None:
        upright = keep & (tilts.min(axis=1) <= sel.gravity_max_deg)
        keep = upright if upright.any() else keep
    return cost, keep, rest


def tilts_deg(
    T_template_camera: np.ndarray,
    ground_normal_camera: np.ndarray,
    ups: np.ndarray,
    symmetry_axis: np.ndarray | None = None,
) -> np.ndarray:
    """(B, H) degrees between the ground normal mapped into the template frame by each pose and
    each gravity hypothesis' up direction ``ups`` (H, 3). With a continuous ``symmetry_axis`` a
    spin about it is invisible, so the angle is that between the two directions' angles to the
    axis (a can on its side rests on any of its side lines)."""
    gt = np.einsum("bij,j->bi", np.asarray(T_template_camera)[:, :3, :3], ground_normal_camera)
    gt /= np.linalg.norm(gt, axis=1, keepdims=True)
    u = ups / np.linalg.norm(ups, axis=1, keepdims=True)
    if symmetry_axis is None:
        return np.degrees(np.arccos(np.clip(gt @ u.T, -1.0, 1.0)))
    a = np.asarray(symmetry_axis, float) / np.linalg.norm(symmetry_axis)
    ga = np.degrees(np.arccos(np.clip(gt @ a, -1.0, 1.0)))
    ua = np.degrees(np.arccos(np.clip(u @ a, -1.0, 1.0)))
    return np.abs(ga[:, None] - ua[None, :])
