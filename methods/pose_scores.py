"""Scores for choosing among the candidate poses of ours (selection, step 7 of the pipeline):
:func:`visibility_chamfer`, the readable reference of ours' compiled score
(:mod:`catpose.methods.pose_scores_kernel`), and the choice with explicit half turns
(:func:`select_with_half_turns`). Lower is better; lengths object-normalised.
"""

from __future__ import annotations

import numpy as np

from catpose.geometry import compose_T


def transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points`` (N, 3) mapped by the rigid ``T`` (4, 4)."""
    return points @ T[:3, :3].T + T[:3, 3]


def visible_mask(points: np.ndarray, normals: np.ndarray, camera_centre: np.ndarray) -> np.ndarray:
    """(M,) bool: template points whose outward normal faces ``camera_centre`` (template frame)."""
    return np.einsum("ij,ij->i", normals, camera_centre[None] - points) > 0


def visibility_chamfer(
    points_camera: np.ndarray,
    T_template_camera: np.ndarray,
    template_points: np.ndarray,
    template_normals: np.ndarray,
    tree,
    trunc: float,
) -> np.ndarray:
    """(B,) truncated two-directional Chamfer between the input and the template's visible side.

    For pose ``T`` (camera -> template), the camera centre in the template frame is ``T[:3, 3]``;
    the visible template points ``V`` are those facing it. The score is
    ``mean_i min(d(T x_i, template), trunc) + mean_{v in V} min(d(v, T X), trunc)``.
    """
    from scipy.spatial import cKDTree

    out = np.empty(len(T_template_camera))
    for b, T in enumerate(T_template_camera):
        src = transform(T, points_camera)
        d_in = np.minimum(tree.query(src, distance_upper_bound=trunc)[0], trunc).mean()
        vis = template_points[visible_mask(template_points, template_normals, T[:3, 3])]
        if len(vis) == 0:
            out[b] = d_in + trunc
            continue
        d_vis = np.minimum(cKDTree(src).query(vis, distance_upper_bound=trunc)[0], trunc).mean()
        out[b] = d_in + d_vis
    return out


def half_turns() -> np.ndarray:
    """(4, 4, 4): the identity and the 180-degree rotations about the template's x, y and z axes
    (through the template origin), as rigid transforms of the template frame."""
    out = np.tile(np.eye(4), (4, 1, 1))
    out[1:, :3, :3] = 2.0 * np.einsum("ai,aj->aij", np.eye(3), np.eye(3)) - np.eye(3)
    return out


def tilt_deg(T_template_camera: np.ndarray, ground_normal_camera: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(B,) angle (deg) between the ground normal mapped into the template frame and the template up."""
    g = np.einsum("bij,j->bi", T_template_camera[:, :3, :3], ground_normal_camera)
    return np.degrees(np.arccos(np.clip(g @ (up / np.linalg.norm(up)), -1.0, 1.0)))


#: how far (deg) refinement is assumed able to tilt a pose at most: a hypothesis tilted more than
#: ``gravity_max_deg`` + this before refinement cannot pass the gravity filter after it, and is not
#: refined (half turns about a horizontal axis turn a 30-degree tilt into 150 degrees or more; the
#: ICP, pairing within 0.05 of the unit-sphere scale, moves a pose by a few degrees)
REACH_DEG = 90.0


def select_with_half_turns(
    candidates: np.ndarray,
    allowed: np.ndarray,
    score,
    refine,
    ground_normal_camera: np.ndarray,
    up: np.ndarray,
    gravity_max_deg: float | None,
    top_k: int = 1,
) -> tuple[np.ndarray, float, dict]:
    """Visibility-aware selection with explicit 180-degree alternatives (the "flip class").

    Candidates of a near-symmetric shape (an airplane seen from above or below, a mustard
    bottle's front or back) converge to the true pose or to a half turn of it, and the
    one-directional Chamfer distance scores both alike. Here the ``top_k`` allowed candidates by
    ``score`` (the visibility-aware Chamfer, :func:`visibility_chamfer` or its compiled twin) are
    each expanded by the half turns about the template axes (:func:`half_turns`), the expanded
    poses are refined by ``refine``, poses whose tilt exceeds ``gravity_max_deg`` are dropped (all
    kept when none passes) and the lowest ``score`` wins. Only what can matter is computed: scores
    of allowed candidates, refinements of hypotheses within ``gravity_max_deg`` +
    :data:`REACH_DEG` of upright (all of them when none is).

    Args:
        candidates: (m, 4, 4) ``T_template_camera`` candidates.
        allowed: (m,) bool, candidates that may be chosen (e.g. the gravity filter's).
        score: callable, poses (B, 4, 4) -> (B,) scores, lower is better.
        refine: callable, poses (B, 4, 4) -> refined poses (B, 4, 4).
        ground_normal_camera, up: gravity (camera frame) and the template up axis.
        gravity_max_deg: tilt limit in degrees (None: no limit).
        top_k: candidates expanded.

    Returns:
        the chosen pose (4, 4), its score, and ``{"candidate": index into candidates,
        "half_turn": 0 (none) or 1..3 (x, y, z), "scores": (m,) scores of the allowed candidates
        (inf for the others)}``.
    """
    allowed = np.asarray(allowed, dtype=bool)
    scores = np.full(len(candidates), np.inf)
    if allowed.any():
        scores[allowed] = score(candidates[allowed])
    order = np.argsort(scores, kind="stable")[: max(int(top_k), 1)]
    turns = half_turns()
    expanded = np.stack([compose_T(F, candidates[i]) for i in order for F in turns])
    chosen = np.arange(len(expanded))
    if gravity_max_deg is not None:
        reachable = tilt_deg(expanded[chosen], ground_normal_camera, up) <= gravity_max_deg + REACH_DEG
        if reachable.any():
            chosen = chosen[reachable]
    final = np.full(len(expanded), np.inf)
    expanded[chosen] = refine(expanded[chosen])
    final[chosen] = score(expanded[chosen])
    keep = np.isfinite(final)
    if gravity_max_deg is not None:
        keep &= tilt_deg(expanded, ground_normal_camera, up) <= gravity_max_deg
        if not keep.any():
            keep = np.isfinite(final)
    best = int(np.argmin(np.where(keep, final, np.inf)))
    info = {
        "candidate": int(order[best // len(turns)]),
        "half_turn": int(best % len(turns)),
        "scores": [float(s) for s in scores],
    }
    return expanded[best], float(final[best]), info
