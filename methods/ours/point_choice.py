"""The selection stage of ``ours`` (steps 7 and 8 of :mod:`catpose.methods.ours`): the gravity
filter and criterion over the candidates, the rule of
:class:`~catpose.methods.ours.settings.SelectionSettings` (``visibility``, ``chamfer`` or the
paper's ``loss``), and the point-to-plane refinement of the chosen pose."""

from __future__ import annotations

import time

import numpy as np

from catpose import cell_grid, kernel_threads
from catpose.cell_grid import CellGrid
from catpose.methods.ours.candidates import Candidates, TemplateFeatures
from catpose.methods.ours.refine import refine_poses
from catpose.methods.ours.settings import SelectionSettings
from catpose.types import RegistrationProblem, RegistrationResult

__all__ = ["VISIBILITY_TRUNC", "chamfer_distances", "criterion", "finish"]

#: truncation of both directions of the visibility-aware Chamfer, object-normalised unit (twice
#: the refinement's pairing distance; docs/choosing-defaults.md)
VISIBILITY_TRUNC = 0.1


def criterion(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    feats: TemplateFeatures,
    chamfer_src: np.ndarray,
    T: np.ndarray,
    losses: np.ndarray,
    allowed: np.ndarray,
):
    """Chamfer distances, tilts (deg), kept mask and criterion (inf where not kept), all (m,)."""
    from catpose.methods.pose_scores import tilt_deg

    dists = chamfer_distances(feats.tree, chamfer_src, T, feats.truncated)
    tilt = tilt_deg(T, problem.ground_normal_camera, np.asarray(problem.template.up, dtype=np.float64))
    keep = allowed.copy()
    if sel.gravity_max_deg is not None:
        keep &= tilt <= sel.gravity_max_deg
        if not keep.any():  # nothing is consistent with gravity: fall back to all allowed
            keep = allowed.copy()
    crit = losses if sel.rule == "loss" else dists
    return dists, tilt, keep, np.where(keep, crit, np.inf)


def finish(
    sel: SelectionSettings,
    problem: RegistrationProblem,
    c: Candidates,
    feats: TemplateFeatures,
    timings: dict[str, float],
) -> RegistrationResult:
    """Selection among the candidates and refinement of the selected one."""
    chamfer_src = c.chamfer_src

    t0 = time.perf_counter()
    allowed = np.ones(len(c.T), dtype=bool)
    dists, tilt_deg, keep, crit = criterion(sel, problem, feats, chamfer_src, c.T, c.losses, allowed)
    best = int(np.argmin(crit))
    score = float(crit[best])
    T_best = c.T[best]
    timings["selection"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    half_turn = None
    template = problem.template
    candidate_scores = crit

    def refine(T: np.ndarray, points: np.ndarray = chamfer_src) -> np.ndarray:
        """Poses (B, 4, 4) refined by point-to-plane ICP on ``points`` (all at once, compiled)."""
        if not sel.refine:
            return T
        return refine_poses(points, feats.pairing, template.normals, T)

    if sel.rule == "visibility":
        from catpose.methods.pose_scores import select_with_half_turns
        from catpose.methods.pose_scores_kernel import visibility_scores

        input_grid = cell_grid.build(chamfer_src, VISIBILITY_TRUNC)

        def score_of(T: np.ndarray) -> np.ndarray:
            return visibility_scores(chamfer_src, input_grid, T, feats.truncated, template.normals, VISIBILITY_TRUNC)

        # scored and refined on the FPS subset of the Chamfer distances (4x fewer points: the
        # 4 top_k alternatives cost about what one full refinement did), the winner on all points
        T_best, score, info = select_with_half_turns(
            c.T,
            keep,
            score_of,
            refine,
            problem.ground_normal_camera,
            np.asarray(template.up, float),
            sel.gravity_max_deg,
            sel.top_k,
        )
        T_best = refine(T_best[None], c.points)[0]
        best, half_turn = info["candidate"], info["half_turn"]
        candidate_scores = np.asarray(info["scores"], dtype=float)
    elif sel.refine:
        T_best = refine(T_best[None], c.points)[0]
        if sel.rule == "chamfer":  # the score of the pose actually returned
            score = float(chamfer_distances(feats.tree, chamfer_src, T_best[None], feats.truncated)[0])
    timings["refinement"] = time.perf_counter() - t0

    extras = {
        "template_index": best,
        "losses": [float(x) if np.isfinite(x) else None for x in c.losses],
        "chamfer": [float(x) for x in dists],
        "tilt_deg": [float(x) for x in tilt_deg],
        "kept": [bool(x) for x in keep],
        "timings": {k: float(v) for k, v in timings.items()},
        "num_input_points": int(len(c.points)),
    }
    extras["hypothesis_stages"] = {"candidates": c.T.tolist(), "kept": c.T[keep].tolist()}
    if half_turn is not None:
        extras["half_turn"] = half_turn  # 0: the candidate itself; 1, 2, 3: turned about x, y, z
    return RegistrationResult(
        T_template_camera=T_best,
        score=score,
        extras=extras,
        candidates_T=c.T.copy(),
        candidate_scores=np.asarray(candidate_scores, dtype=float).copy(),
    )


def chamfer_distances(tree, points: np.ndarray, T: np.ndarray, grid: CellGrid | None = None) -> np.ndarray:
    """One-directional Chamfer distance (mean nearest-template-point distance) of ``points``
    (N, 3) under each pose of ``T`` (B, 4, 4); (B,), object-normalised units. Distances are
    unbounded: ``tree`` (a cKDTree of the template's points) answers them; with ``grid`` (a
    :class:`~catpose.cell_grid.CellGrid` of the same points) the grid answers every point within
    its reach (the same bits as the tree, without a tree walk) and the tree only the rest. Poses are
    split over the run's ``threads`` (:mod:`catpose.kernel_threads`; each point's distance is
    exact, so the same bits on any count)."""
    moved = (np.einsum("bij,nj->bni", T[:, :3, :3], points) + T[:, None, :3, 3]).reshape(-1, 3)
    d = np.empty(len(moved))
    n = len(points)

    def query(lo: int, hi: int) -> None:  # poses lo..hi-1 (both searches release the GIL)
        part = moved[lo * n : hi * n]
        if grid is None:
            d[lo * n : hi * n] = tree.query(part)[0]
            return
        near, j = cell_grid.nearest(grid, part, grid.reach)
        far = j < 0
        if far.any():
            near[far] = tree.query(part[far])[0]
        d[lo * n : hi * n] = near

    kernel_threads.split(query, len(T))
    return d.reshape(len(T), n).mean(axis=1)
