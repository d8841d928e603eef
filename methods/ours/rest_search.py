"""The coarse search of ours' depth rule: every stable resting pose x yaw, placed on the observation.

The paper's dictionary finds candidates from local correspondences, and for an object that does not
stand on the template's up it needs the template turned so that it does (one pipeline per resting
direction). Where the ground normal ``g`` is known (a tabletop), the rotation of an object lying
in one of its stable resting poses has one free parameter, the yaw about ``g``. So for every
resting direction ``u`` of the template (:mod:`catpose.methods.ours.resting`, the template's
own up first) and every yaw ``psi = 360 k / yaws`` degrees, the rotation ``R`` maps ``g`` onto
``u`` (the shortest arc, then the yaw about ``u``); a direction along a continuous symmetry axis
(an upright or upside-down can) needs one yaw only.

The translation puts the template's front on the observation: the template points whose normals
face the camera (the viewing direction at the observation's centroid ``m``, in the template frame
``v = -R m / |m|``) have centroid ``f``; ``t = f - R m`` maps ``m`` onto ``f``. Every pose is then
refined by point-to-plane ICP on the input's Chamfer subset (:data:`ITERATIONS` steps, pairs
within :data:`MAX_DISTANCE`; compiled, all at once; ``grid_icp``: turning about the ground normal
only, which keeps the resting pose, every way, or both pooled), scored by the depth check, and the
:data:`KEEP` of lowest cost join the dictionary's candidates (:mod:`catpose.methods.ours.choice`).
Every resting pose gets the same budget on every problem; which of them the object rests in is the
depth check's choice alone.

Angles use the C library's sine and cosine and products :func:`catpose.geometry.small_matmul`, the
same bits on every CPU; the shifted placements' radius is a BLAS product, whose last bits may
vary with the OpenBLAS kernel (the regression gate allows for that).
"""

from __future__ import annotations

import math
import time

import numpy as np

from catpose import cell_grid
from catpose.content_hash import template_hash
from catpose.geometry import norm3, small_matmul, unit3
from catpose.lru import LRUCache
from catpose.methods.keypoints import farthest_point_indices
from catpose.methods.ours.candidates import Candidates, TemplateFeatures
from catpose.methods.ours.check import DepthVerifier
from catpose.methods.ours.resting import rotation_between
from catpose.methods.ours.settings import RestingSettings
from catpose.types import RegistrationProblem

__all__ = ["search", "grid_poses", "grid_rotations"]

# The search's budget, chosen on the clutter dev scenes 0-99 (docs/choosing-defaults.md,
# experiments/search_recall): fewer points or steps lost right poses there, more changed nothing.
#: ICP steps of the full pass (on the input's Chamfer subset)
ITERATIONS = 10
#: ICP pairing distance, object-normalised unit (a yaw step of 45 degrees moves the rim this far)
MAX_DISTANCE = 0.15
#: input points (the head of the Chamfer subset, itself in farthest-point order) of the first pass
FIRST_POINTS = 64
#: ICP steps of the first pass
FIRST_ITERATIONS = 3
#: template points (farthest-point subset) the ICP pairs with
TEMPLATE_POINTS = 2048
#: poses of lowest depth cost that join the dictionary's candidates
KEEP = 8

_GRIDS: LRUCache[tuple, tuple] = LRUCache(16)  # the search's ICP grids, per template


def search(
    problem: RegistrationProblem,
    ups: np.ndarray,
    cands: Candidates,
    feats: TemplateFeatures,
    verifier: DepthVerifier,
    rs: RestingSettings,
    timings: dict[str, float],
) -> np.ndarray:
    """The :data:`KEEP` poses (template frame, (K, 4, 4)) of lowest depth cost (``verifier``) of
    the coarse search over every resting direction ``ups`` (H, 3) x ``rs.grid_yaws`` yaws, each
    refined by ICP of the own up's Chamfer subset (``cands.chamfer_src``) against the template:
    :data:`FIRST_ITERATIONS` steps on its first :data:`FIRST_POINTS`, then the ``rs.grid_beam``
    of lowest one-directional Chamfer distance (``feats``) :data:`ITERATIONS` steps on all of it;
    (0, 4, 4) when off (``grid_yaws`` 0)."""
    from catpose.methods.ours.point_choice import chamfer_distances
    from catpose.point_to_plane_kernel import refine_many
    from catpose.yaw_icp_kernel import refine_yaw_many

    if rs.grid_yaws <= 0:
        return np.zeros((0, 4, 4))
    t0 = time.perf_counter()
    tpl = problem.template
    T, _ = grid_poses(
        ups,
        problem.ground_normal_camera,
        problem.points_camera,
        tpl.points,
        tpl.normals,
        rs.grid_yaws,
        tpl.symmetry_axis,
        rs.grid_shift,
    )
    key = (tpl.template_id, template_hash(tpl, "points"))
    hit = _GRIDS.get(key)
    if hit is None:  # a farthest-point subset of the template: fewer pairs to search at the long reach
        keep = farthest_point_indices(tpl.points, min(TEMPLATE_POINTS, len(tpl.points)))
        grid = cell_grid.build(tpl.points[keep], MAX_DISTANCE, cell_grid.CACHED_CELLS_PER_REACH)
        hit = (grid, tpl.normals[keep])
        _GRIDS.put(key, hit)
    g = np.asarray(problem.ground_normal_camera, dtype=np.float64)
    g = g / np.linalg.norm(g)

    def icp(points: np.ndarray, T: np.ndarray, iterations: int, yaw: bool) -> np.ndarray:
        if yaw:  # about each pose's up: the ground normal in the template frame
            up = np.einsum("bij,j->bi", T[:, :3, :3], g)
            return refine_yaw_many(points, hit[0], hit[1], T, up, MAX_DISTANCE, iterations)
        return refine_many(points, hit[0], hit[1], T, MAX_DISTANCE, iterations)

    def one(T: np.ndarray, yaw: bool) -> np.ndarray:
        if 0 < rs.grid_beam < len(T):
            # a few steps on the head of the Chamfer subset (farthest-point order: a subset of it
            # too), the grid_beam of lowest one-directional Chamfer distance go on in full
            src = cands.chamfer_src[:FIRST_POINTS]
            T = icp(src, T, FIRST_ITERATIONS, yaw)
            dists = chamfer_distances(feats.tree, src, T, feats.truncated)
            T = T[np.sort(np.argsort(dists, kind="stable")[: rs.grid_beam])]
            return icp(cands.chamfer_src, T, ITERATIONS, yaw)
        return icp(cands.chamfer_src[:FIRST_POINTS], T, ITERATIONS, yaw)

    T = np.concatenate([one(T, yaw) for yaw in {"yaw": (True,), "full": (False,), "union": (True, False)}[rs.grid_icp]])
    timings["rest_grid"] = timings.get("rest_grid", 0.0) + time.perf_counter() - t0
    t0 = time.perf_counter()
    scores = verifier.scores(T)
    timings["verification"] = timings.get("verification", 0.0) + time.perf_counter() - t0
    return T[np.argsort(scores, kind="stable")[:KEEP]]


def _about(axis: np.ndarray, angles: list[float]) -> np.ndarray:
    """(A, 3, 3) rotations by ``angles`` (radians) about unit ``axis`` (Rodrigues, C library sine)."""
    a = unit3(np.asarray(axis, dtype=np.float64))
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    sin, cos = (np.array([f(x) for x in angles])[:, None, None] for f in (math.sin, math.cos))
    return np.eye(3) + sin * K + (1.0 - cos) * small_matmul(K, K)


def grid_rotations(
    ups: np.ndarray, ground_normal_camera: np.ndarray, yaws: int, symmetry_axis: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Rotations ``R_template_camera`` (B, 3, 3) resting the template on each of ``ups`` (H, 3,
    template frame) at ``yaws`` yaws each (one for an up along ``symmetry_axis``), and the index
    of each one's up (B,)."""
    g = unit3(np.asarray(ground_normal_camera, dtype=np.float64))
    axis = None if symmetry_axis is None else unit3(np.asarray(symmetry_axis, dtype=np.float64))
    out, rest = [], []
    for k, u in enumerate(np.asarray(ups, dtype=np.float64)):
        u = unit3(u)
        R0 = rotation_between(g, u)  # R0 g = u
        n = max(int(yaws), 1)
        if axis is not None and abs(float(u @ axis)) > math.cos(math.radians(10.0)):
            n = 1  # a spin about the symmetry axis is invisible
        out.extend(small_matmul(_about(u, [2.0 * math.pi * j / n for j in range(n)]), R0))
        rest += [k] * n
    return np.stack(out), np.asarray(rest, dtype=np.int64)


def grid_poses(
    ups: np.ndarray,
    ground_normal_camera: np.ndarray,
    points_camera: np.ndarray,
    template_points: np.ndarray,
    template_normals: np.ndarray,
    yaws: int,
    symmetry_axis: np.ndarray | None = None,
    shift: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``T_template_camera`` (B, 4, 4) of :func:`grid_rotations`, each translated so the
    template's camera-facing points (``template_points`` (M, 3) with unit ``template_normals``)
    have the centroid of ``points_camera`` (N, 3) (see the module docstring); and each pose's up
    index (B,).

    ``shift`` > 0 gives an up along the symmetry axis (one yaw) the budget of the others: beside
    its pose, ``yaws - 1`` copies moved along the ground by ``shift`` times the template's radius
    about that up, at evenly spaced directions (where occlusion moved the visible centroid off the
    object's front, one of them starts nearer)."""
    R, rest = grid_rotations(ups, ground_normal_camera, yaws, symmetry_axis)
    moves = None
    if shift > 0.0 and yaws > 1:
        R, rest, moves = _shifted(
            R, rest, np.asarray(ups, dtype=np.float64), ground_normal_camera, template_points, yaws, shift
        )
    m = np.asarray(points_camera, dtype=np.float64).mean(axis=0)
    view = -m / max(norm3(m), 1e-12)  # towards the camera, camera frame
    P = np.asarray(template_points, dtype=np.float64)
    v = np.einsum("bij,j->bi", R, view)  # towards the camera, template frame, per pose
    facing = (np.einsum("mj,bj->mb", np.asarray(template_normals, dtype=np.float64), v) > 0.0).astype(np.float64)
    count = facing.sum(axis=0)
    front = np.einsum("mb,mj->bj", facing, P) / np.maximum(count, 1.0)[:, None]  # einsum's loops: no BLAS
    T = np.tile(np.eye(4), (len(R), 1, 1))
    T[:, :3, :3] = R
    if moves is None:
        T[:, :3, 3] = front - np.einsum("bij,j->bi", R, m)
    else:
        T[:, :3, 3] = front - np.einsum("bij,bj->bi", R, m + moves)
    return T, rest


def _shifted(R, rest, ups, ground_normal_camera, template_points, yaws, shift):
    """Each single-yaw up's rotation repeated ``yaws`` times with camera-frame moves (K, 3): zero,
    then ``yaws - 1`` ground-plane directions at radius ``shift`` x the template's radius about
    the up (through the template's centroid). Moves None: no up along a symmetry axis (nothing
    moved)."""
    counts = np.bincount(rest, minlength=len(ups))
    if not np.any(counts == 1):
        return R, rest, None
    g = unit3(np.asarray(ground_normal_camera, dtype=np.float64))
    a = unit3(np.cross(g, [1.0, 0.0, 0.0]) if abs(g[0]) < 0.9 else np.cross(g, [0.0, 1.0, 0.0]))
    b = np.cross(g, a)
    P = np.asarray(template_points, dtype=np.float64)
    centred = P - P.mean(axis=0)
    out_R, out_rest, out_move = [], [], []
    for i, k in enumerate(rest):
        out_R.append(R[i])
        out_rest.append(k)
        out_move.append(np.zeros(3))
        if counts[k] != 1:
            continue
        u = unit3(ups[k])
        along = centred @ u  # a BLAS matrix-vector product: its last bits may vary with the OpenBLAS kernel
        radius = float(np.sqrt(np.max(np.einsum("mj,mj->m", centred, centred) - along * along)))
        for j in range(1, yaws):
            angle = 2.0 * math.pi * (j - 1) / (yaws - 1)
            out_R.append(R[i])
            out_rest.append(k)
            out_move.append(shift * radius * (math.cos(angle) * a + math.sin(angle) * b))
    return np.stack(out_R), np.asarray(out_rest, dtype=np.int64), np.stack(out_move)
