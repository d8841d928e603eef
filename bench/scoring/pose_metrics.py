"""Standard 6D pose metrics (BOP and category-level literature) as pure functions.

Argument order follows bop_toolkit: ``R_est, t_est, R_gt, t_gt, ...``. Poses are
``T_camera_model``: ``p_camera = R p_model + t``; ``R`` is (3, 3), ``t`` is (3,) in the model's
length unit (BOP models: millimetres). ``points`` are (N, 3) model points in the same unit.

Symmetries are transforms ``S`` (4, 4) of the model frame that map the model onto itself: the
pose ``T_gt @ S`` is then as correct as ``T_gt``. :func:`symmetry_transforms` builds the list
from BOP's ``symmetries_discrete`` (4x4, row-major, t in model units) and
``symmetries_continuous`` (``{axis, offset}``, every axis, with its offset) the way BOP's
``misc.get_symmetry_transformations`` does (continuous axes discretised so that no model
point moves more than ``max_sym_disc_step`` x diameter between steps).

References:
    ADD, ADD-S (ADI): Hinterstoisser et al., "Model based training, detection and pose
        estimation of texture-less 3D objects in heavily cluttered scenes", ACCV 2012.
    VSD: Hodan et al., "On evaluation of 6D object pose estimation", ECCVW 2016, in its BOP19
        form (Hodan et al., "BOP challenge 2020 on 6D object localization", ECCVW 2020).
    MSSD, MSPD and average recall: Hodan et al., BOP challenge 2019/2020 (same paper).
    n-degree m-cm: Shotton et al., "Scene coordinate regression forests", CVPR 2013; used for
        category-level pose by Wang et al., "NOCS", CVPR 2019.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from catpose.bench.scoring.metrics import rotation_error_deg, translation_error

# BOP19 threshold ranges (bop_toolkit scripts/eval_bop19_pose.py)
BOP19_VSD_DELTA_MM = 15.0
"""Tolerance (mm) of VSD's visibility test."""
BOP19_VSD_TAUS = tuple(np.round(np.arange(0.05, 0.51, 0.05), 2))
"""Misalignment tolerances of VSD, as fractions of the object diameter."""
BOP19_CORRECT_TH = tuple(np.round(np.arange(0.05, 0.51, 0.05), 2))
"""Correctness thresholds of VSD (error) and MSSD (fraction of the diameter)."""
BOP19_MSPD_TH_PX = tuple(float(x) for x in np.arange(5, 51, 5))
"""MSPD thresholds in pixels for a 640-pixel-wide image (scaled by width / 640)."""


# --------------------------------------------------------------------------------------------
# Symmetries


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation (3, 3) by ``angle`` radians about the unit ``axis`` (Rodrigues)."""
    a = np.asarray(axis, float).reshape(3)
    a = a / np.linalg.norm(a)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def symmetry_transforms(
    discrete: Iterable[Sequence[float]] = (), continuous: Iterable[Mapping] = (), max_sym_disc_step: float = 0.01
) -> list[np.ndarray]:
    """Every symmetry transform (4, 4) of the model frame, identity first.

    ``discrete``: BOP ``symmetries_discrete`` entries (16 numbers, row-major 4x4, t in model
    units). ``continuous``: BOP ``symmetries_continuous`` entries ``{"axis": (3,), "offset":
    (3,)}``: rotations about the line through ``offset`` along ``axis``. A continuous axis is
    sampled every ``2 pi / ceil(pi / max_sym_disc_step)`` radians (BOP's step: a point on the
    diameter moves about ``max_sym_disc_step * diameter`` between samples). The rotations of
    every continuous axis are pooled (as BOP does; composing two axes would give O(n^2)
    transforms) and each is combined with every discrete transform: ``S = S_cont @ S_disc``.
    """
    conts = [np.eye(4)]
    for c in continuous:
        axis = np.asarray(c["axis"], float).reshape(3)
        offset = np.asarray(c.get("offset", (0.0, 0.0, 0.0)), float).reshape(3)
        n = int(math.ceil(math.pi / max_sym_disc_step))
        for k in range(1, n):
            R = _axis_angle(axis, 2.0 * math.pi * k / n)
            S = np.eye(4)
            S[:3, :3], S[:3, 3] = R, offset - R @ offset
            conts.append(S)
    discs = [np.eye(4)] + [np.asarray(d, float).reshape(4, 4) for d in discrete]
    return [C @ D for D in discs for C in conts]


def _symmetric_gt(R_gt: np.ndarray, t_gt: np.ndarray, symmetries: Iterable[np.ndarray] | None):
    """``(R, t)`` of every equally correct ground-truth pose ``T_gt S`` (the identity alone when
    ``symmetries`` is None or empty)."""
    R_gt, t_gt = np.asarray(R_gt, float).reshape(3, 3), np.asarray(t_gt, float).reshape(3)
    syms = [np.asarray(S, float).reshape(4, 4) for S in (symmetries if symmetries is not None else ())]
    return [(R_gt @ S[:3, :3], R_gt @ S[:3, 3] + t_gt) for S in syms or [np.eye(4)]]


def _transform(R: np.ndarray, t: np.ndarray, points: np.ndarray) -> np.ndarray:
    return np.asarray(points, float) @ np.asarray(R, float).reshape(3, 3).T + np.asarray(t, float).reshape(1, 3)


def _project(points_cam: np.ndarray, K: np.ndarray) -> np.ndarray:
    uvw = points_cam @ np.asarray(K, float).reshape(3, 3).T
    return uvw[:, :2] / uvw[:, 2:3]


def _max_symmetric_distance(f, R_est, t_est, R_gt, t_gt, symmetries) -> float:
    """``min_S max_i || f(T_est)_i - f(T_gt S)_i ||`` over the symmetric gt poses, ``f(R, t)`` (N, d)
    the model points placed (MSSD) or projected (MSPD) at a pose."""
    at_est = f(R_est, t_est)
    return min(
        [math.inf]
        + [
            float(np.linalg.norm(at_est - f(R_s, t_s), axis=1).max())
            for R_s, t_s in _symmetric_gt(R_gt, t_gt, symmetries)
        ]
    )


# --------------------------------------------------------------------------------------------
# Point-distance errors


def add(R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray, points: np.ndarray) -> float:
    """ADD: mean distance between corresponding model points, ``mean_i ||T_est p_i - T_gt p_i||``.

    ``points`` (N, 3) in model units; returns model units (mm for BOP).
    """
    return float(np.linalg.norm(_transform(R_est, t_est, points) - _transform(R_gt, t_gt, points), axis=1).mean())


def adi(R_est: np.ndarray, t_est: np.ndarray, R_gt: np.ndarray, t_gt: np.ndarray, points: np.ndarray) -> float:
    """ADD-S (ADI): mean distance from each ground-truth model point to the nearest estimated model
    point, ``mean_i min_j ||T_gt p_i - T_est p_j||`` (model units), as Hinterstoisser et al. (ACCV
    2012) define it and bop_toolkit's ``pose_error.adi`` computes it (a k-d tree over the
    estimated points, queried with the ground-truth points). The direction matters when the
    model points are not spread evenly: the mean runs over the ground-truth points. Nearest
    neighbours by a k-d tree (scipy), exact."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(_transform(R_est, t_est, points)).query(_transform(R_gt, t_gt, points), k=1)
    return float(np.mean(d))


def mssd(
    R_est: np.ndarray,
    t_est: np.ndarray,
    R_gt: np.ndarray,
    t_gt: np.ndarray,
    points: np.ndarray,
    symmetries: Iterable[np.ndarray] | None = None,
) -> float:
    """Maximum Symmetry-Aware Surface Distance (BOP19), model units:

        e = min_{S in symmetries} max_i || T_est p_i - T_gt S p_i ||

    ``symmetries`` (each (4, 4), model frame) from :func:`symmetry_transforms`; None or empty
    means the identity only.
    """
    return _max_symmetric_distance(lambda R, t: _transform(R, t, points), R_est, t_est, R_gt, t_gt, symmetries)


def mspd(
    R_est: np.ndarray,
    t_est: np.ndarray,
    R_gt: np.ndarray,
    t_gt: np.ndarray,
    K: np.ndarray,
    points: np.ndarray,
    symmetries: Iterable[np.ndarray] | None = None,
) -> float:
    """Maximum Symmetry-Aware Projection Distance (BOP19), pixels:

        e = min_{S} max_i || proj(T_est p_i) - proj(T_gt S p_i) ||

    ``K`` (3, 3) camera intrinsics in pixels.
    """
    return _max_symmetric_distance(
        lambda R, t: _project(_transform(R, t, points), K), R_est, t_est, R_gt, t_gt, symmetries
    )


# --------------------------------------------------------------------------------------------
# Rotation / translation errors and n-degree m-cm


def rt_errors(
    R_est: np.ndarray,
    t_est: np.ndarray,
    R_gt: np.ndarray,
    t_gt: np.ndarray,
    symmetries: Iterable[np.ndarray] | None = None,
) -> list[tuple[float, float]]:
    """``(rotation error deg, translation error)`` against every symmetric gt pose ``T_gt S``: BOP's
    ``re`` (:func:`~catpose.bench.scoring.metrics.rotation_error_deg`) and ``te`` (model units)."""
    R_est = np.asarray(R_est, float).reshape(3, 3)
    return [
        (rotation_error_deg(R_est, R), translation_error(t_est, t)) for R, t in _symmetric_gt(R_gt, t_gt, symmetries)
    ]


def n_deg_m_cm(
    R_est: np.ndarray,
    t_est: np.ndarray,
    R_gt: np.ndarray,
    t_gt: np.ndarray,
    n_deg: float,
    m_cm: float,
    unit_mm: float = 1.0,
    symmetries: Iterable[np.ndarray] | None = None,
) -> bool:
    """n-degree m-cm accuracy (Shotton et al. 2013; NOCS 2019): True when some symmetric gt pose
    has rotation error <= ``n_deg`` degrees and translation error <= ``m_cm`` centimetres.

    ``unit_mm``: millimetres per model unit (1 for BOP models; the physical size per unit for
    normalised shapes), so the threshold is metric whatever the model unit.
    """
    return any(r <= n_deg and t * unit_mm / 10.0 <= m_cm for r, t in rt_errors(R_est, t_est, R_gt, t_gt, symmetries))


# --------------------------------------------------------------------------------------------
# VSD


def _pixel_rays(K: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """``x, y`` (H, W) of the ray ``(x, y, 1)`` through each pixel centre of the camera ``K`` (3, 3)."""
    K = np.asarray(K, float).reshape(3, 3)
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    return (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]


def depth_to_distance(depth: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Distance of each pixel's 3D point from the camera centre (H, W), from a z-depth image."""
    depth = np.asarray(depth, float)
    x, y = _pixel_rays(K, depth.shape[1], depth.shape[0])
    return depth * np.sqrt(x * x + y * y + 1.0)


def _visible(d_test: np.ndarray, d_model: np.ndarray, delta: float) -> np.ndarray:
    """BOP19 visibility: model pixels not behind the measured surface by more than ``delta``
    (pixels without a measurement count as visible)."""
    return (d_model > 0) & ((d_model - d_test <= delta) | (d_test == 0))


def vsd_from_depths(
    dist_est: np.ndarray,
    dist_gt: np.ndarray,
    dist_test: np.ndarray,
    delta: float,
    taus: Sequence[float],
    diameter: float | None = None,
) -> list[float]:
    """Visible Surface Discrepancy from rendered distance images (BOP19 variant), one per tau.

    ``dist_*`` (H, W): distance from the camera centre (0 = no surface) of the model rendered
    at the estimate, at the ground truth, and of the test image. ``delta`` and ``taus`` in the
    distance unit, or, when ``diameter`` is given, ``taus`` are fractions of it (BOP19: the
    pixel misalignment is divided by the diameter).

        V_gt  = visible(test, gt);  V_est = visible(test, est) | (V_gt & est > 0)
        e_tau = (|V_gt u V_est| - |{p in V_gt n V_est : |d_est - d_gt| < tau}|) / |V_gt u V_est|

    (1 when the union is empty).
    """
    v_gt = _visible(dist_test, dist_gt, delta)
    v_est = _visible(dist_test, dist_est, delta) | (v_gt & (dist_est > 0))
    inter, union = v_gt & v_est, v_gt | v_est
    n_union = int(union.sum())
    diff = np.abs(dist_gt[inter] - dist_est[inter])
    if diameter is not None:
        diff = diff / float(diameter)
    if n_union == 0:
        return [1.0 for _ in taus]
    return [float(n_union - int((diff < tau).sum())) / n_union for tau in taus]


def render_depth(
    vertices: np.ndarray, triangles: np.ndarray, R: np.ndarray, t: np.ndarray, K: np.ndarray, width: int, height: int
) -> np.ndarray:
    """z-depth (H, W) float64 of a mesh (vertices (V, 3), triangles (F, 3)) at pose ``R, t``, one
    ray per pixel centre cast by :meth:`catpose.raycast.RayCaster.cast` (the renderer of the
    datasets: Embree finds the hit triangle, the depth is recomputed from it in float64, the same
    bits on every CPU); 0 where no surface. Units of the vertices."""
    from catpose.raycast import RayCaster

    x, y = _pixel_rays(K, width, height)
    dirs = np.stack([x, y, np.ones_like(x)], axis=-1)
    z = RayCaster(_transform(R, t, vertices), triangles).cast(np.zeros(3), dirs)  # along dirs with z = 1: s = depth
    return np.where(np.isfinite(z), z, 0.0)


def vsd(
    R_est: np.ndarray,
    t_est: np.ndarray,
    R_gt: np.ndarray,
    t_gt: np.ndarray,
    depth_test: np.ndarray,
    K: np.ndarray,
    vertices: np.ndarray,
    triangles: np.ndarray,
    delta: float = BOP19_VSD_DELTA_MM,
    taus: Sequence[float] = BOP19_VSD_TAUS,
    diameter: float | None = None,
) -> list[float]:
    """VSD (BOP19) of an estimate against a measured depth image, one error per tau.

    ``depth_test`` (H, W) z-depth in model units (mm), 0 = missing; ``K`` (3, 3); the model
    mesh in model units. With ``diameter`` the taus are fractions of it (BOP19 default), else
    in model units. The model is rendered at both poses by :func:`render_depth`.
    """
    h, w = np.asarray(depth_test).shape
    d_est = render_depth(vertices, triangles, R_est, t_est, K, w, h)
    d_gt = render_depth(vertices, triangles, R_gt, t_gt, K, w, h)
    return vsd_from_depths(
        depth_to_distance(d_est, K), depth_to_distance(d_gt, K), depth_to_distance(depth_test, K), delta, taus, diameter
    )


# --------------------------------------------------------------------------------------------
# Recalls


def recall(errors: Iterable[float], threshold: float) -> float:
    """Fraction of errors strictly below ``threshold`` (BOP's ``e < th``); NaN (missing
    estimate) and inf count as wrong; NaN for an empty set."""
    e = np.asarray(list(errors), float)
    if e.size == 0:
        return float("nan")
    return float((np.nan_to_num(e, nan=np.inf) < threshold).mean())


def average_recall_vsd(vsd_errors: Iterable[Sequence[float]], correct_th: Sequence[float] = BOP19_CORRECT_TH) -> float:
    """AR_VSD: mean recall over every (tau, threshold) pair; ``vsd_errors`` one sequence of
    per-tau errors per gt instance (NaN for a missing estimate)."""
    arr = np.asarray([list(v) for v in vsd_errors], float)
    if arr.size == 0:
        return float("nan")
    return float(np.mean([recall(arr[:, k], th) for k in range(arr.shape[1]) for th in correct_th]))
