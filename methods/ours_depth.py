"""Ours' selection by the occlusion-aware depth check (``method.selection.rule=depth``).

Input: the candidates of every gravity hypothesis (:mod:`catpose.methods.resting_hypotheses`; the
first is the template's own up), each computed by the unchanged pipeline on the turned template.

1. Gravity: each hypothesis keeps its candidates whose tilt (the measured ground normal against
   the hypothesis' up; for a template with a continuous symmetry axis, against the angle of that
   up to the axis: :func:`tilts_deg`) is within ``gravity_max_deg`` (all of them when none is).
2. The ``depth_prescreen`` kept candidates of each hypothesis with the lowest one-directional
   Chamfer distance (input -> template: blind to occlusion, cheap) are scored by the depth check
   (:class:`catpose.methods.depth_check.DepthVerifier`), and the ``depth_top_k`` best of all
   hypotheses go on.
3. Each goes on with its three half turns about the turned frame's axes (a near-symmetric shape
   converges to the true pose or to a half turn of it; a half turn may also rest the object
   another of the allowed ways) and, with ``depth_yaw_turns`` (the caller sets it for the
   escalated pass only), its turns about the up by multiples of ``360 / depth_yaw_turns``
   degrees (not for a template with a symmetry axis); poses that cannot come back within the gravity limit of any
   hypothesis' up are dropped, the others refined by point-to-plane ICP against the turned
   template (compiled, all at once), scored again, filtered by gravity (any hypothesis' up), and
   the ``depth_final_refine`` of lowest depth cost go on.
4. Those are refined on all input points and scored again on the final lattice
   (``depth_final_pixels``); the lowest cost (the depth score plus ``depth_rest_prior`` for a pose
   resting other than on the template's up) wins.
5. With ``depth_final_turns``, the winner meets the one of its three half turns about the
   template's axes that the coarse lattice scores best (of those gravity allows), refined on all
   input points and compared on the final lattice by the same cost: a near-symmetric object's
   half turn explains the image almost as well as the truth, and the coarse lattice of step 3
   often drops the right one of the two before step 4 sees it. The lower cost wins, and its
   depth score is the result's ``score``.

All poses are scored in the original template's frame; ``extras`` say which hypothesis,
candidate and half turn won.
"""

from __future__ import annotations

import time

import numpy as np

from catpose.geometry import compose_T
from catpose.methods.depth_check import DepthVerifier
from catpose.methods.ours_candidates import Candidates, TemplateFeatures
from catpose.methods.ours_selection import chamfer_distances
from catpose.methods.ours_settings import SelectionSettings
from catpose.methods.pose_scores import REACH_DEG, half_turns, yaw_and_half_turns
from catpose.methods.resting_hypotheses import Hypothesis
from catpose.point_to_plane_kernel import refine_many
from catpose.types import RegistrationProblem, RegistrationResult

__all__ = ["depth_verifier", "final_verifier", "refine_last", "select_by_depth"]


def select_by_depth(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    hyps: list[Hypothesis],
    cands: list[Candidates],
    feats: list[TemplateFeatures],
    timings: dict[str, float],
    debug: dict | None = None,
    verifier: DepthVerifier | None = None,
) -> RegistrationResult:
    """Steps 1-5 of the module docstring; ``hyps``, ``cands`` and ``feats`` are parallel lists.
    ``debug``, when given, receives the verifier, the pre-scored pool and every expanded
    hypothesis (template-frame poses and scores) for diagnosis. ``verifier``: the problem's
    :func:`depth_verifier`, when the caller has made it already."""
    timings.setdefault("verification", 0.0)
    timings.setdefault("refinement", 0.0)
    t0 = time.perf_counter()
    verifier = depth_verifier(sel, problem) if verifier is None else verifier
    g = problem.ground_normal_camera
    ups = np.stack([h.up for h in hyps])
    axis = problem.template.symmetry_axis
    pool = _pool(sel, hyps, cands, feats, g, ups, axis)
    pre = verifier.scores(np.stack([hyps[k].to_template(cands[k].T[i]) for k, i in pool]))
    order = np.argsort(pre, kind="stable")[: sel.depth_top_k]
    timings["verification"] += time.perf_counter() - t0

    # step 3: half turns of the best, refined on the Chamfer subset, scored
    t0 = time.perf_counter()
    yaws = 0 if problem.template.symmetry_axis is not None else sel.depth_yaw_turns  # no yaw about a symmetry axis
    turns = yaw_and_half_turns(np.asarray(problem.template.up, dtype=np.float64), yaws)
    expanded = [(pool[o][0], pool[o][1], j) for o in order for j in range(len(turns))]
    T_exp = np.stack([compose_T(turns[j], cands[k].T[i]) for k, i, j in expanded])  # in each hypothesis' frame
    chosen = np.arange(len(expanded))
    if sel.gravity_max_deg is not None:
        reachable = (
            tilts_deg(_in_template(hyps, expanded, T_exp), g, ups, axis).min(axis=1) <= sel.gravity_max_deg + REACH_DEG
        )
        chosen = chosen[reachable] if reachable.any() else chosen
    if sel.refine:
        T_exp[chosen] = _refine(sel, hyps, cands, feats, [expanded[i][0] for i in chosen], T_exp[chosen], "chamfer_src")
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    final = np.full(len(expanded), np.inf)
    final[chosen] = verifier.scores(_in_template(hyps, [expanded[i] for i in chosen], T_exp[chosen]))
    cost, keep, _ = _costs(sel, final, _in_template(hyps, expanded, T_exp), g, ups, axis)
    timings["verification"] += time.perf_counter() - t0

    # step 4: the best few refined on every input point, scored again; the lowest cost wins
    t0 = time.perf_counter()
    top = np.argsort(np.where(keep, cost, np.inf), kind="stable")[: max(int(sel.depth_final_refine), 1)]
    top = top[np.isfinite(cost[top])] if np.isfinite(cost[top]).any() else top[:1]
    T_top = T_exp[top].copy()
    if sel.refine:
        T_top = _refine_points(sel, hyps, cands, feats, [expanded[i][0] for i in top], T_top)
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    T_top_t = _in_template(hyps, [expanded[i] for i in top], T_top)
    coarse, verifier = verifier, final_verifier(sel, problem, verifier)
    top_scores = verifier.scores(T_top_t)
    top_cost, top_keep, rest_top = _costs(sel, top_scores, T_top_t, g, ups, axis)
    b = int(np.argmin(np.where(top_keep, top_cost, np.inf))) if top_keep.any() else int(np.argmin(top_cost))
    best, T_out, score, rest = int(top[b]), T_top_t[b], float(top_scores[b]), int(rest_top[b])
    timings["verification"] += time.perf_counter() - t0

    # step 5: the winner against its own half turns on the final lattice
    final_turn = 0
    if sel.depth_final_turns:
        T_out, score, rest, final_turn = _against_half_turns(
            sel, hyps, cands, feats, (coarse, verifier), T_out, score, rest, (g, ups, axis), timings
        )
    t0 = time.perf_counter()
    fit, fit_loose = verifier.fits(T_out[None], (verifier.tau, sel.depth_fit_tau))[:, 0]
    timings["verification"] += time.perf_counter() - t0
    if debug is not None:
        debug.update(
            verifier=verifier,
            hyps=hyps,
            cands=cands,
            pool=pool,
            prescores=pre,
            order=order,
            expanded=expanded,
            T_expanded=_in_template(hyps, expanded, T_exp),
            final=final,
            cost=cost,
            keep=keep,
            top=top,
            T_top=T_top_t,
            top_scores=top_scores,
            best=best,
        )

    k, i, j = expanded[best]
    extras = {
        "template_index": i,
        "hypothesis": k,
        "half_turn": j,
        "final_turn": final_turn,
        "resting": rest,
        "resting_up": [float(x) for x in hyps[rest].up],
        "num_hypotheses": len(hyps),
        "depth_score": score,
        "depth_inliers": float(fit[0]),
        "depth_free": float(fit[1]),
        "depth_inliers_loose": float(fit_loose[0]),
        "depth_stride": verifier.lattice.stride,
        "depth_mask_pixels": verifier.mask_pixels,
        "prescores": [float(x) for x in np.sort(pre)[:8]],
        "timings": {name: float(v) for name, v in timings.items()},
        "num_input_points": int(len(cands[0].points)),
    }
    # every half-turned candidate scored in step 3 (template frame) with its cost (inf: not kept)
    return RegistrationResult(
        T_template_camera=T_out,
        score=score,
        extras=extras,
        candidates_T=_in_template(hyps, expanded, T_exp),
        candidate_scores=np.where(keep, cost, np.inf).astype(float),
    )


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


def _pool(sel: SelectionSettings, hyps, cands, feats, g, ups, axis) -> list[tuple[int, int]]:
    """Steps 1-2: (hypothesis, candidate) pairs that pass gravity, the ``depth_prescreen`` of
    lowest Chamfer distance per hypothesis."""
    pool: list[tuple[int, int]] = []
    for k, (h, c, f) in enumerate(zip(hyps, cands, feats)):
        allowed = np.zeros(len(c.T), dtype=bool)
        allowed[c.stage2] = True
        keep = allowed.copy()
        if sel.gravity_max_deg is not None:
            keep &= tilts_deg(h.to_template(c.T), g, ups[k : k + 1], axis)[:, 0] <= sel.gravity_max_deg
            keep = keep if keep.any() else allowed
        kept = np.nonzero(keep)[0]
        if 0 < sel.depth_prescreen < len(kept):
            dists = chamfer_distances(f.tree, c.chamfer_src, c.T[kept])
            kept = np.sort(kept[np.argsort(dists, kind="stable")[: sel.depth_prescreen]])
        pool += [(k, int(i)) for i in kept]
    return pool


def _against_half_turns(
    sel: SelectionSettings,
    hyps,
    cands,
    feats,
    verifiers,
    T_win: np.ndarray,
    score: float,
    rest: int,
    gravity,
    timings: dict[str, float],
) -> tuple[np.ndarray, float, int, int]:
    """Step 5: the winner ``T_win`` (4, 4, template frame) against the one of its three half turns
    about the template's axes that the coarse lattice scores best (of those the gravity filter
    keeps; by the same cost as every comparison, :func:`_costs`), refined on all input points and
    scored with the winner on the final lattice. ``verifiers``: (coarse, final); ``gravity``:
    (ground normal, hypotheses' ups, symmetry axis). Returns the pose that costs less, its depth
    score, its resting direction and which turn it is (0: the winner itself, 1-3: about x, y, z)."""
    coarse, final = verifiers
    t0 = time.perf_counter()
    T_turns = np.stack([compose_T(F, T_win) for F in half_turns()[1:]])  # template frame = hypothesis 0's
    cost, keep, _ = _costs(sel, coarse.scores(T_turns), T_turns, *gravity)
    timings["verification"] += time.perf_counter() - t0
    if not keep.any():
        return T_win, score, rest, 0
    t = int(np.argmin(np.where(keep, cost, np.inf)))
    t0 = time.perf_counter()
    T_turn = _refine_points(sel, hyps, cands, feats, [0], T_turns[t : t + 1]) if sel.refine else T_turns[t : t + 1]
    timings["refinement"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    T_two = np.concatenate([T_win[None], T_turn])
    scores = np.array([score, final.scores(T_turn)[0]])
    cost, keep, rests = _costs(sel, scores, T_two, *gravity)
    timings["verification"] += time.perf_counter() - t0
    if keep[1] and (cost[1] < cost[0] or not keep[0]):
        return T_two[1], float(scores[1]), int(rests[1]), t + 1
    return T_win, score, rest, 0


def _refine_points(sel: SelectionSettings, hyps, cands, feats, hyp_of: list[int], T: np.ndarray) -> np.ndarray:
    """Step 4's refinement (:func:`refine_last`) of poses (B, 4, 4) in their hypotheses' frames,
    each against its hypothesis' turned template on all input points."""
    out = np.array(T, copy=True)
    hyp_of = np.asarray(hyp_of)
    for k in sorted(set(hyp_of.tolist())):
        idx = np.nonzero(hyp_of == k)[0]
        out[idx] = refine_last(sel, cands[k].points, feats[k].pairing, hyps[k].template.normals, out[idx])
    return out


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


def _in_template(hyps, expanded, T_hyp: np.ndarray) -> np.ndarray:
    """(B, 4, 4) poses of the hypotheses' turned frames -> poses of the template."""
    return np.stack([hyps[e[0]].to_template(T) for e, T in zip(expanded, T_hyp)]) if len(T_hyp) else T_hyp


def _refine(sel: SelectionSettings, hyps, cands, feats, hyp_of: list[int], T: np.ndarray, points: str) -> np.ndarray:
    """Poses (B, 4, 4) in their hypotheses' frames refined by point-to-plane ICP against each
    hypothesis' turned template, on the input's ``chamfer_src`` or all ``points``."""
    out = np.array(T, copy=True)
    hyp_of = np.asarray(hyp_of)
    for k in sorted(set(hyp_of.tolist())):
        idx = np.nonzero(hyp_of == k)[0]
        out[idx] = refine_many(
            getattr(cands[k], points),
            feats[k].pairing,
            hyps[k].template.normals,
            out[idx],
            sel.refine_max_distance,
            sel.refine_iterations,
        )
    return out


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
