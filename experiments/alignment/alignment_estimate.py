"""Estimating a category's alignment table (``align.py``; the table format:
:mod:`catpose.datasets.alignment`).

:func:`estimate_table` searches the multiples of 90 degrees of yaw (optionally with an up-axis
flip), refines every hypothesis by ICP, scores it by symmetric Chamfer against every other
instance and picks a consensus over all pairs (:func:`synchronize`), with a confidence margin per
instance. Chamfer alone cannot tell nose from tail between unlike shapes (with the biplane
airplane_0001 as reference it turned 4 of 6 OFF and 11 of 18 resampled airplanes round; the chairs
were all right, 8/8), so for airplanes (``cues="ends"``, what :func:`resolve_cues` gives airplanes)
the Chamfer costs only decide the main axis and the shape cues of ``alignment_cues.py`` (heights
and spans at the ends) decide which end is the front; chairs keep Chamfer alone (``"none"``).
Measured against the verified tables in ``results/alignment/estimated/``.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

from catpose.datasets.alignment import FLIP, R_COLUMNS
from catpose.errors import DatasetError
from catpose.geometry import apply_R, axis_angle_to_R, matmul3

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling alignment_cues.py

EXTRA_COLUMNS = ["yaw_deg", "flip", "chamfer", "confidence", "verified", "note"]


def write_alignment_table(path: str | Path, rows: list[dict]) -> None:
    """Write rows ``{category, instance_id, R (3, 3)}`` plus any of the optional keys
    ``yaw_deg, flip, chamfer, confidence, verified, note`` (empty cells when missing)."""
    from catpose import atomic

    path = Path(path)

    def cell(v) -> str:
        if v is None:
            return ""
        if isinstance(v, bool):
            return "true" if v else "false"
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    with atomic.atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["category", "instance_id", *R_COLUMNS, *EXTRA_COLUMNS])
        for r in rows:
            R = np.asarray(r["R"], float)
            w.writerow(
                [
                    r["category"],
                    r["instance_id"],
                    *(f"{x:.9g}" for x in R.reshape(-1)),
                    *(cell(r.get(c)) for c in EXTRA_COLUMNS),
                ]
            )


def yaw_rotations(n: int) -> np.ndarray:
    """``n`` rotations about +z by multiples of 360/n degrees, (n, 3, 3)."""
    return np.stack([axis_angle_to_R(np.array([0.0, 0.0, 1.0]), 2 * np.pi * k / n) for k in range(n)])


def chamfer_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Chamfer distance: mean nearest-neighbour distance a->b plus b->a (same unit)."""
    from scipy.spatial import cKDTree

    return float(cKDTree(b).query(a)[0].mean() + cKDTree(a).query(b)[0].mean())


def yaw_flip_hypotheses(flip: bool) -> np.ndarray:
    """The 4 yaws by multiples of 90 deg, then (``flip``) the same composed with an up-axis flip:
    (4 or 8, 3, 3), a group (closed under products and inverses)."""
    yaws = yaw_rotations(4)
    return np.concatenate([yaws, [matmul3(R, FLIP) for R in yaws]]) if flip else yaws


def _index_of(R: np.ndarray, group: np.ndarray) -> int:
    return int(np.argmin(np.abs(group - R).reshape(len(group), -1).max(axis=1)))


def icp_refine(
    source: np.ndarray, target: np.ndarray, R_init: np.ndarray, max_distance: float, iterations: int = 30
) -> np.ndarray:
    """Open3D point-to-point ICP of ``source`` (N, 3) onto ``target`` (M, 3) from rotation
    ``R_init`` (no initial translation); returns the (4, 4) transform that maps ``source`` onto ``target``."""
    from catpose.o3d import o3d

    reg = o3d.pipelines.registration
    T0 = np.eye(4)
    T0[:3, :3] = R_init
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(source, float)))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(target, float)))
    result = reg.registration_icp(
        src,
        tgt,
        max_distance,
        T0,
        reg.TransformationEstimationPointToPoint(),
        reg.ICPConvergenceCriteria(max_iteration=iterations),
    )
    return np.asarray(result.transformation, float)


def pair_costs(
    source: np.ndarray, target: np.ndarray, hypotheses: np.ndarray, max_distance: float = 0.05, refine: bool = True
) -> np.ndarray:
    """(H,) symmetric Chamfer distance between ``target`` and ``source`` turned by each hypothesis
    (H, 3, 3), each mapping ``source`` onto ``target``, after ICP refinement from it.

    ``max_distance`` is ICP's correspondence distance (object-normalised unit): two different
    instances are never an exact fit, and a loose one (0.2) let ICP slide 30-50 deg to partial
    overlaps whose costs tie with the right hypothesis's on the shared airplanes; 0.05 keeps
    refinements within 5-20 deg. A refinement that ends nearer another hypothesis scores for
    that one; each hypothesis keeps its lowest cost, so one whose own refinement left it (and
    that no other refinement reached) keeps its unrefined cost.
    """
    raw = np.array([chamfer_distance(apply_R(R, source), target) for R in hypotheses])
    if not refine:
        return raw
    costs = raw.copy()
    for R in hypotheses:
        T = icp_refine(source, target, R, max_distance)
        k = _index_of(T[:3, :3], hypotheses)
        if np.abs(T[:3, :3] - hypotheses[k]).max() < 0.5:  # within ~30 deg of a hypothesis
            costs[k] = min(costs[k], chamfer_distance(apply_R(T[:3, :3], source) + T[:3, 3], target))
    return costs


def pairwise_costs(
    clouds: list[np.ndarray], hypotheses: np.ndarray, refine: bool = True, max_distance: float = 0.05
) -> np.ndarray:
    """(N, N, H) costs ``C[i, j, g]`` of hypothesis ``g`` turning cloud ``i`` onto cloud ``j``
    (:func:`pair_costs`; zero on the diagonal)."""
    N, H = len(clouds), len(hypotheses)
    C = np.zeros((N, N, H))
    for i in range(N):
        for j in range(N):
            if i != j:
                C[i, j] = pair_costs(clouds[i], clouds[j], hypotheses, max_distance, refine)
    return C


CUES = ("auto", "ends", "none")
#: ``cues="auto"``: the cues of each category, chosen on its development shapes (docs/category-level.md):
#: the end cues for airplanes (161 train airplanes); Chamfer alone elsewhere (chairs: right on the
#: development chairs at every point count, where the end cues depended on the sampling)
CATEGORY_CUES = {"airplane": "ends"}


def resolve_cues(cues: str, category: str | None) -> str:
    """``"ends"`` or ``"none"``: ``cues`` itself, or for ``"auto"`` the category's (:data:`CATEGORY_CUES`)."""
    if cues not in CUES:
        raise DatasetError(f"alignment cues {cues!r} are not one of {CUES}")
    return CATEGORY_CUES.get(str(category), "none") if cues == "auto" else cues


def estimate_table(
    clouds: list[np.ndarray],
    hypotheses: np.ndarray,
    reference: int = 0,
    refine: bool = True,
    max_distance: float = 0.05,
    cues: str = "ends",
) -> dict:
    """Per-instance hypothesis that puts every cloud in the reference's frame.

    Args:
        clouds: N centred, unit-sphere-normalised clouds (M_i, 3), each in its own raw frame.
        hypotheses: (H, 3, 3) rotation group (:func:`yaw_flip_hypotheses`).
        reference: index of the instance that defines the frame.
        refine, max_distance: ICP refinement of each hypothesis (:func:`pair_costs`).
        cues: ``"ends"`` (default): the Chamfer costs decide the main axis and the shape cues
            of ``alignment_cues.py`` (heights and spans at the ends) decide which
            end is the front
            (``alignment_cues.combined_costs``); ``"none"``: Chamfer alone
            (before issue 25; it turns nose against tail between unlike airplanes).

    Returns :func:`synchronize` of the pairwise costs.
    """
    if cues not in CUES[1:]:
        raise DatasetError(f"alignment cues {cues!r} are not one of {CUES[1:]} (resolve 'auto' with resolve_cues)")
    C_chamfer = pairwise_costs(clouds, hypotheses, refine, max_distance)
    if cues == "none":
        return synchronize(C_chamfer, hypotheses, reference)
    from alignment_cues import combined_costs, cue_costs  # the sibling script

    out = synchronize(combined_costs(C_chamfer, cue_costs(clouds, hypotheses), hypotheses), hypotheses, reference)
    # ``chamfer`` stays the Chamfer distance to the reference (``cost`` and ``confidence`` are the combined ones)
    out["chamfer"] = np.array(
        [0.0 if i == reference else C_chamfer[i, reference, out["labels"][i]] for i in range(len(clouds))]
    )
    return out


def synchronize(C: np.ndarray, hypotheses: np.ndarray, reference: int = 0, max_rounds: int = 50) -> dict:
    """Labels ``l_i`` (``R_frame_i = G[l_i]``) minimising the summed pairwise cost
    ``sum_{i != j} C[i, j, g(l_i, l_j)]`` with ``G[g] = G[l_j]^T G[l_i]``.

    Labels are defined up to a common rotation; coordinate descent is started from each
    instance's single-anchor estimate (every instance in turn as the anchor: an atypical anchor,
    such as a biplane among jets, misleads a single-reference search) and the lowest total wins;
    the labels are then expressed in ``reference``'s frame (its label is identity).

    Returns a dict with ``labels`` (N,), ``labels_reference`` (N,: each instance's best
    hypothesis against the reference alone), ``cost`` (N, H: mean cost of each hypothesis of an
    instance against all others at their labels), ``confidence`` (N,: ``(second - best) / second``
    of that row; 0 is a tie), ``chamfer`` (N,: cost against the reference at the labels) and
    ``total`` (the minimised sum).
    """
    N, H = C.shape[0], len(hypotheses)
    # rel[a, b]: the g turning instance i (label a) onto instance j (label b): G[b]^T G[a]
    rel = np.array(
        [[_index_of(matmul3(hypotheses[b].T, hypotheses[a]), hypotheses) for b in range(H)] for a in range(H)]
    )
    others = [np.array([j for j in range(N) if j != i], dtype=int) for i in range(N)]
    off_i, off_j = np.nonzero(~np.eye(N, dtype=bool))

    def row_cost(labels: np.ndarray, i: int) -> np.ndarray:
        j = others[i]  # (N-1,); C[i, j, rel[a, labels[j]]] for every a: (H, N-1)
        return C[i][j[None, :], rel[:, labels[j]]].mean(axis=1)

    def total(labels: np.ndarray) -> float:
        return float(C[off_i, off_j, rel[labels[off_i], labels[off_j]]].sum())

    best = None
    for anchor in range(N):
        labels = np.array([0 if i == anchor else int(np.argmin(C[i, anchor])) for i in range(N)])
        for _ in range(max_rounds):
            changed = False
            for i in range(N):
                a = int(np.argmin(row_cost(labels, i)))
                if a != labels[i] and row_cost(labels, i)[a] < row_cost(labels, i)[labels[i]] - 1e-12:
                    labels[i], changed = a, True
            if not changed:
                break
        t = total(labels)
        if best is None or t < best[0] - 1e-12:
            best = (t, labels.copy())
    t, labels = best
    # gauge: R_ref_i = G[l_ref]^T G[l_i]
    labels = np.array([rel[labels[i], labels[reference]] for i in range(N)])
    cost = np.stack([row_cost(labels, i) for i in range(N)]) if N > 1 else np.zeros((N, H))
    srt = np.sort(cost, axis=1)
    confidence = ((srt[:, 1] - srt[:, 0]) / np.maximum(srt[:, 1], 1e-12)) if H > 1 else np.ones(N)
    labels_ref = np.array([0 if i == reference else int(np.argmin(C[i, reference])) for i in range(N)])
    chamfer = np.array([0.0 if i == reference else C[i, reference, labels[i]] for i in range(N)])
    return {
        "labels": labels,
        "labels_reference": labels_ref,
        "cost": cost,
        "confidence": confidence,
        "chamfer": chamfer,
        "total": t,
    }
