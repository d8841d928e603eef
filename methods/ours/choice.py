"""Ours' selection by the occlusion-aware depth check (``method.selection.rule=depth``).

Input: a pool of candidate poses ``T_template_camera`` in the template's frame, from two searches
(:meth:`catpose.methods.ours.Ours.register`): the paper's dictionary candidates of the template's
own up (those the gravity filter keeps, the ``depth_prescreen`` of lowest one-directional Chamfer
distance: :func:`dictionary_pool`), and the coarse search over every stable resting pose x yaw
(:mod:`catpose.methods.ours.rest_search`: the ``resting.grid_keep`` of lowest depth cost).

1. Every pose of the pool is scored by the depth check
   (:class:`catpose.methods.ours.check.DepthVerifier`) and the ``depth_top_k`` best go on.
2. Each goes on with its three half turns about the template's axes (a near-symmetric shape
   converges to the true pose or to a half turn of it; a half turn may also rest the object
   another of its ways) and, with ``yaw_turns`` (the escalated pass of the dictionary search
   only), its turns about its resting direction by multiples of ``360 / yaw_turns`` degrees (not
   for a template with a symmetry axis); poses that cannot come back within the gravity limit of
   any resting direction are dropped, the others refined by point-to-plane ICP on the input's
   Chamfer subset (compiled, all at once), scored again, filtered by gravity (any resting
   direction), and the ``depth_final_refine`` of lowest depth cost go on (with
   ``depth_final_distinct_deg`` > 0, each differing from those before it by more than that: the
   pool holds each pose refined and as it was, and its best two are most often one pose twice).
3. Those are refined on all input points and scored again on the final lattice
   (``depth_final_pixels``); the lowest cost (the depth score plus ``depth_rest_prior`` for a pose
   resting other than on the template's up) wins.
4. With ``depth_final_turns``, the winner meets the one of its three half turns about the
   template's axes that the coarse lattice scores best (of those gravity allows), refined on all
   input points and compared on the final lattice by the same cost: a near-symmetric object's
   half turn explains the image almost as well as the truth, and the coarse lattice of step 2
   often drops the right one of the two before step 3 sees it. The lower cost wins, and its
   depth score is the result's ``score``.
5. With ``depth_polish_levels`` (off by default), the winner and its half turns about the
   template's axes (those gravity allows) are each polished on the final lattice's cost itself
   (:func:`catpose.methods.ours.polish.polish`), and the lowest cost wins.

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

import numpy as np

from catpose.geometry import compose_T, norm3
from catpose.methods.ours.candidates import Candidates, TemplateFeatures
from catpose.methods.ours.check import DepthVerifier
from catpose.methods.ours.point_choice import chamfer_distances
from catpose.methods.ours.polish import polish
from catpose.methods.ours.resting import Hypothesis
from catpose.methods.ours.settings import SelectionSettings
from catpose.methods.pose_scores import REACH_DEG, half_turns, yaw_and_half_turns
from catpose.point_to_plane_kernel import refine_many
from catpose.types import RegistrationProblem, RegistrationResult

#: the runner-up differs from the answer by more than this (degrees; the @10 threshold)
RUNNER_UP_DEG = 10.0

__all__ = [
    "RUNNER_UP_DEG",
    "depth_verifier",
    "dictionary_pool",
    "final_verifier",
    "refine_last",
    "runner_up",
    "select_by_depth",
    "stage_lists",
    "tilts_deg",
]


def select_by_depth(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    pool: np.ndarray,
    cands: Candidates,
    feats: TemplateFeatures,
    ups: np.ndarray,
    timings: dict[str, float],
    verifier: DepthVerifier | None = None,
    yaw_turns: int = 0,
) -> RegistrationResult:
    """Steps 1-4 of the module docstring on ``pool`` (P, 4, 4), template frame. ``cands``: the
    own up's candidates (their input points, ``points`` and ``chamfer_src``, are refined);
    ``feats``: the template's features; ``ups`` (H, 3): the resting directions, template frame,
    the template's up first. ``verifier``: the problem's :func:`depth_verifier`, when made already."""
    timings.setdefault("verification", 0.0)
    timings.setdefault("refinement", 0.0)
    t0 = time.perf_counter()
    verifier = depth_verifier(sel, problem) if verifier is None else verifier
    g, axis = problem.ground_normal_camera, problem.template.symmetry_axis
    gravity = (g, ups, axis)
    pre = verifier.scores(pool)
    order = np.argsort(pre, kind="stable")[: sel.depth_top_k]
    timings["verification"] += time.perf_counter() - t0

    # step 2: half (and yaw) turns of the best, refined on the Chamfer subset, scored
    t0 = time.perf_counter()
    yaws = 0 if axis is not None else yaw_turns  # no yaw about a symmetry axis
    rests = tilts_deg(pool[order], g, ups, axis).argmin(axis=1)
    turn_sets = {int(k): _visible(yaw_and_half_turns(ups[k], yaws), axis) for k in sorted(set(rests.tolist()))}
    if not sel.depth_half_turns and not yaws:  # the coarse search has every resting pose and yaw already
        turn_sets = {k: F[:1] for k, F in turn_sets.items()}
    expanded = [(int(o), j) for o, k in zip(order, rests) for j in range(len(turn_sets[int(k)]))]
    T_exp = np.stack([compose_T(F, pool[o]) for o, k in zip(order, rests) for F in turn_sets[int(k)]])
    chosen = np.arange(len(T_exp))
    if sel.gravity_max_deg is not None:
        reachable = tilts_deg(T_exp, g, ups, axis).min(axis=1) <= sel.gravity_max_deg + REACH_DEG
        chosen = chosen[reachable] if reachable.any() else chosen
    if sel.refine:
        T_exp[chosen] = _refine(sel, cands.chamfer_src, feats, problem.template.normals, T_exp[chosen])
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    final = np.full(len(T_exp), np.inf)
    final[chosen] = verifier.scores(T_exp[chosen])
    # the pool's poses as they were go on too: ICP on the few points of a mostly hidden object can
    # slide a right pose into free space
    T_exp, final = np.concatenate([T_exp, pool[order]]), np.concatenate([final, pre[order]])
    expanded += [(int(o), -1) for o in order]
    cost, keep, _ = _costs(sel, final, T_exp, *gravity)
    timings["verification"] += time.perf_counter() - t0

    # step 3: the best few refined on every input point, scored again; the lowest cost wins
    t0 = time.perf_counter()
    ranked = np.argsort(np.where(keep, cost, np.inf), kind="stable")
    top = distinct_best(ranked, T_exp, max(int(sel.depth_final_refine), 1), sel.depth_final_distinct_deg, axis)
    top = top[np.isfinite(cost[top])] if np.isfinite(cost[top]).any() else top[:1]
    T_top = T_exp[top].copy()
    if sel.refine:  # each refined on all points, and as it was (whichever costs less on the final lattice)
        T_top = np.concatenate([refine_last(sel, cands.points, feats.pairing, problem.template.normals, T_top), T_top])
        top = np.concatenate([top, top])
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    coarse, verifier = verifier, final_verifier(sel, problem, verifier)
    top_scores = verifier.scores(T_top)
    top_cost, top_keep, rest_top = _costs(sel, top_scores, T_top, *gravity)
    b = int(np.argmin(np.where(top_keep, top_cost, np.inf))) if top_keep.any() else int(np.argmin(top_cost))
    T_out, score, rest = T_top[b], float(top_scores[b]), int(rest_top[b])
    timings["verification"] += time.perf_counter() - t0

    # step 4: the winner against its own half turns on the final lattice
    final_turn = 0
    compared = (T_top, np.where(top_keep, top_cost, np.inf))  # every pose scored on the final lattice
    if sel.depth_final_turns > 0:
        T_out, score, rest, final_turn, turned = against_half_turns(
            sel, cands, feats, problem, (coarse, verifier), T_out, score, rest, gravity, timings
        )
        compared = (np.concatenate([compared[0], turned[0]]), np.concatenate([compared[1], turned[1]]))
    second = runner_up(T_out, score + sel.depth_rest_prior * (rest != 0), *compared, axis)
    polished = {}
    if sel.depth_polish_levels > 0:
        t0 = time.perf_counter()
        T_out, score, rest, polished["polish_turn"] = _polished(sel, verifier, T_out, score, rest, gravity)
        timings["verification"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    fit = verifier.fits(T_out[None], (verifier.tau,))[0, 0]  # the whole mask
    # the poor-fit test's, depth_fit_erode_px inside the mask's edge (the rendering is kept)
    fit_loose = verifier.fits(T_out[None], (sel.depth_fit_tau,), sel.depth_fit_erode_px)[0, 0]
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
    extras.update(polished)
    # every turned pose scored in step 2 (template frame) with its cost (inf: not kept)
    return RegistrationResult(
        T_template_camera=T_out,
        score=score,
        extras=extras,
        candidates_T=T_exp,
        candidate_scores=np.where(keep, cost, np.inf).astype(float),
    )


def distinct_best(ranked: np.ndarray, T: np.ndarray, k: int, min_deg: float, axis: np.ndarray | None) -> np.ndarray:
    """The first ``k`` of ``ranked`` (indices into poses ``T`` (B, 4, 4), best first) whose
    rotation differs from each one taken before it by more than ``min_deg`` degrees; for a
    template with a continuous symmetry ``axis`` (3,) by the angle between the axis' directions
    in the camera frame (a spin about it is invisible). ``min_deg`` 0: the first ``k``. Fewer
    than ``k`` when fewer differ; never none."""
    ranked = np.asarray(ranked, dtype=np.int64)
    if min_deg <= 0:
        return ranked[:k]
    rows, lim = _orientations(T, axis), _dot_limit(min_deg, axis)
    taken: list[int] = []
    for i in ranked:
        if all(float(np.einsum("i,i->", rows[i], rows[j])) < lim for j in taken):
            taken.append(int(i))
            if len(taken) == k:
                break
    return np.asarray(taken or [int(ranked[0])], dtype=np.int64)


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


def depth_verifier(sel: SelectionSettings, problem: RegistrationProblem) -> DepthVerifier:
    """The depth check of ``problem``'s template against its depth image, with ``sel``'s settings."""
    return DepthVerifier(
        problem.template,
        problem.depth_image,
        sel.depth_tau,
        sel.depth_pixels,
        sel.depth_max_rays,
        sel.depth_free_weight,
    )


def final_verifier(
    sel: SelectionSettings, problem: RegistrationProblem, verifier: DepthVerifier | None = None
) -> DepthVerifier:
    """The depth check of the final comparison: on a finer lattice when ``sel.depth_final_pixels``
    exceeds ``sel.depth_pixels``, else ``verifier`` (the problem's :func:`depth_verifier`)."""
    if sel.depth_final_pixels > sel.depth_pixels:
        return DepthVerifier(
            problem.template,
            problem.depth_image,
            sel.depth_tau,
            sel.depth_final_pixels,
            sel.depth_max_rays * sel.depth_final_pixels // sel.depth_pixels,
            sel.depth_free_weight,
        )
    return depth_verifier(sel, problem) if verifier is None else verifier


def dictionary_pool(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    hyps: list[Hypothesis],
    cands: list[Candidates],
    feats: list[TemplateFeatures],
    ups: np.ndarray,
) -> np.ndarray:
    """(P, 4, 4) template-frame poses of the dictionary candidates of ``hyps`` (parallel lists with
    ``cands`` and ``feats``): per hypothesis, those the gravity filter keeps (tilt against its up;
    all of them when none passes), the ``depth_prescreen`` of lowest one-directional Chamfer
    distance among them."""
    g, axis = problem.ground_normal_camera, problem.template.symmetry_axis
    out = []
    for k, (h, c, f) in enumerate(zip(hyps, cands, feats)):
        allowed = np.zeros(len(c.T), dtype=bool)
        allowed[c.stage2] = True
        keep = allowed.copy()
        if sel.gravity_max_deg is not None:
            keep &= tilts_deg(h.to_template(c.T), g, ups[k : k + 1], axis)[:, 0] <= sel.gravity_max_deg
            keep = keep if keep.any() else allowed
        kept = np.nonzero(keep)[0]
        if 0 < sel.depth_prescreen < len(kept):
            dists = chamfer_distances(f.tree, c.chamfer_src, c.T[kept], f.truncated)
            kept = np.sort(kept[np.argsort(dists, kind="stable")[: sel.depth_prescreen]])
        out.append(h.to_template(c.T[kept]))
    return np.concatenate(out) if out else np.zeros((0, 4, 4))


def against_half_turns(
    sel: SelectionSettings,
    cands: Candidates,
    feats: TemplateFeatures,
    problem: RegistrationProblem,
    verifiers,
    T_win: np.ndarray,
    score: float,
    rest: int,
    gravity,
    timings: dict[str, float],
) -> tuple[np.ndarray, float, int, int, tuple[np.ndarray, np.ndarray]]:
    """Step 4: the winner ``T_win`` (4, 4, template frame) against the one of its three half turns
    about the template's axes that the coarse lattice scores best (of those the gravity filter
    keeps; by the same cost as every comparison, :func:`_costs`), refined on all input points and
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
    best = [int(t) for t in np.argsort(np.where(keep, cost, np.inf), kind="stable")[: int(sel.depth_final_turns)]]
    best = [t for t in best if keep[t]]
    t0 = time.perf_counter()
    T_turn = T_turns[best]
    if sel.refine:  # each refined on all points, and as it was (ICP can make a right pose worse)
        T_turn = np.concatenate(
            [refine_last(sel, cands.points, feats.pairing, problem.template.normals, T_turn), T_turn]
        )
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


def _polished(sel: SelectionSettings, final: DepthVerifier, T_win: np.ndarray, score: float, rest: int, gravity):
    """Step 5: ``T_win`` (4, 4, template frame, its final-lattice ``score``) and its half turns
    about the template's axes (not the spins about a continuous symmetry axis) each polished on
    ``final``'s cost; the one of lowest cost that gravity keeps (:func:`_costs`) wins. Returns it,
    its depth score, its resting direction and which turn it came from (0: the winner itself, 1-3:
    about x, y, z)."""
    F = half_turns()
    turns = [j for j in range(len(F)) if j == 0 or not _spin(F[j], gravity[2])]
    starts = np.stack([compose_T(F[j], T_win) for j in turns])
    scores = np.concatenate([[score], final.scores(starts[1:])])
    out = [
        polish(final, T, s, sel.depth_polish_levels, sel.depth_polish_deg, sel.depth_polish_shift)
        for T, s in zip(starts, scores)
    ]
    T_all, polished = np.stack([T for T, _ in out]), np.array([s for _, s in out])
    cost, keep, rests = _costs(sel, polished, T_all, *gravity)
    if not keep.any():
        return T_win, score, rest, 0
    w = int(np.argmin(np.where(keep, cost, np.inf)))
    return T_all[w], float(polished[w]), int(rests[w]), turns[w]


def _spin(F: np.ndarray, axis: np.ndarray | None) -> bool:
    """Whether the turn ``F`` (4, 4) is a rotation about a continuous symmetry ``axis`` (3,) (it
    changes nothing the depth image shows)."""
    if axis is None:
        return False
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    return bool(np.abs(F[:3, :3] @ a - a).max() < 1e-6 and np.abs(F[:3, :3] - np.eye(3)).max() > 1e-9)


def _visible(turns: np.ndarray, axis: np.ndarray | None) -> np.ndarray:
    """``turns`` (M, 4, 4) less the spins about a continuous symmetry ``axis`` (:func:`_spin`)."""
    return turns[[not _spin(F, axis) for F in turns]]


def refine_last(sel: SelectionSettings, points: np.ndarray, grid, normals: np.ndarray, T: np.ndarray) -> np.ndarray:
    """How ours refines its last poses: point-to-plane ICP of ``points`` (N, 3, camera frame) against
    the template (``grid``: a :class:`~catpose.cell_grid.CellGrid` of its points with reach at least
    ``sel.refine_max_distance``; ``normals`` (M, 3)) from each pose ``T`` (B, 4, 4), within
    ``refine_max_distance``, then (``depth_fine_distance`` > 0) pairing only within that tighter
    distance: bleed and noise let go."""
    T = refine_many(points, grid, normals, T, sel.refine_max_distance, sel.refine_iterations)
    if sel.depth_fine_distance > 0:
        T = refine_many(
            points, grid, normals, T, min(sel.depth_fine_distance, sel.refine_max_distance), sel.refine_iterations
        )
    return T


def _refine(
    sel: SelectionSettings, points: np.ndarray, feats: TemplateFeatures, normals: np.ndarray, T: np.ndarray
) -> np.ndarray:
    """Poses (B, 4, 4), template frame, refined by point-to-plane ICP of ``points`` against the
    template (all at once, compiled)."""
    if len(T) == 0:
        return np.array(T, copy=True)
    return refine_many(points, feats.pairing, normals, T, sel.refine_max_distance, sel.refine_iterations)


def _costs(sel: SelectionSettings, scores: np.ndarray, T_template: np.ndarray, g, ups, axis):
    """Depth scores plus the resting prior, the gravity mask (all finite ones when none passes)
    and each pose's resting direction (index into ``ups``)."""
    tilts = tilts_deg(T_template, g, ups, axis)
    rest = tilts.argmin(axis=1)
    cost = scores + sel.depth_rest_prior * (rest != 0)  # resting other than on the template's up
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
