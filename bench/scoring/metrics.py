"""Pose error metrics (pure functions) and per-group statistics.

Argument order follows bop_toolkit: estimate first, ground truth second. Rotations are (3, 3)
matrices, translations (3,) vectors in the object-normalised unit (shapes scaled to a unit
bounding sphere), angles in degrees. The definitions are the paper's (Section IV-A):

    L_R = arccos((tr(R_gt^T R_est) - 1) / 2)         (geodesic distance on SO(3))
    L_T = || t_gt - t_est ||_2

For rotationally symmetric objects (bottle, bowl, can, plate) the rotation about the main axis
is unobservable, so they are scored by the angle between the estimated and true main axis as
seen from the camera (the paper's "main axis" error for TYO-L). Their translation error is the
distance between the estimated and true positions of the object's origin in the camera frame,
``-R^T t`` (a spin about the axis moves the camera's position in the template frame, so the
paper's ``|| t_gt - t_est ||`` would charge the unobservable spin to the translation).

Angles are computed as ``atan2(sin, cos)`` of the same angle (the rotation's: half the length of
the antisymmetric part of ``R_gt^T R_est`` and ``(tr - 1) / 2``; two axes': the length of their
cross product and their dot product), in closed form (:mod:`catpose.geometry`) with
:func:`catpose.libm.arctan2`: ``arccos`` of a cosine loses half the digits within a few ulp of 0
and 180 degrees, and a BLAS product rounds per CPU kernel, so an estimate upside down would be
scored differently in the last bits on different machines. These give the same bits on every
x86-64 CPU.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from catpose import libm
from catpose.geometry import compose_T, dot3, norm3

FAILED_ERROR_DEG = 180.0
"""A failed sample (the method raised or returned a non-finite pose) counts as this error."""


def rotation_error_deg(R_est: np.ndarray, R_gt: np.ndarray) -> float:
    """Geodesic angle between two rotations, in degrees, in [0, 180]."""
    return float(_rotation_angles_deg(np.asarray(R_est, float)[None], np.asarray(R_gt, float))[0])


def _rotation_angles_deg(R_est: np.ndarray, R_gt: np.ndarray) -> np.ndarray:
    """(B,) geodesic angles (degrees) between rotations ``R_est`` (B, 3, 3) and one ``R_gt``
    (3, 3): of ``M = R_gt^T R_est``, ``atan2(|vee(M - M^T)| / 2, (tr M - 1) / 2)``."""
    G = np.asarray(R_gt, float)
    # M[b, i, j] = sum_k G[k, i] R_est[b, k, j], the terms added in a fixed order
    M = (
        G[0, :, None] * R_est[:, 0, None, :]
        + G[1, :, None] * R_est[:, 1, None, :]
        + G[2, :, None] * R_est[:, 2, None, :]
    )
    cos = (M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2] - 1.0) / 2.0
    skew = np.stack([M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]], axis=-1)
    return np.degrees(np.asarray(libm.arctan2(norm3(skew) / 2.0, cos), dtype=np.float64).reshape(-1))


def _axis_angles_deg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angles (degrees) between 3-vectors ``u`` and ``v`` along the last axis (broadcast):
    ``atan2(|u x v|, u . v)``, exact near 0 and 180 degrees; no normalisation needed (``np.cross``
    is element-wise products and differences, no BLAS: the same bits on every CPU)."""
    u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
    return np.degrees(np.asarray(libm.arctan2(norm3(np.cross(u, v)), dot3(u, v)), dtype=np.float64))


def translation_error(t_est: np.ndarray, t_gt: np.ndarray) -> float:
    """Euclidean distance between two translations (object-normalised unit)."""
    return float(norm3(np.asarray(t_est, float).reshape(3) - np.asarray(t_gt, float).reshape(3)))


def axis_error_deg(R_est: np.ndarray, R_gt: np.ndarray, axis: np.ndarray) -> float:
    """Angle in degrees between the main axis as placed by the estimate and by the ground truth.

    ``R_est`` and ``R_gt`` are rotations of ``T_template_camera``; ``axis`` (3,) is the symmetry
    axis in the template frame. The axis in the camera frame is ``R^T axis``; the error is the
    angle between the two, in [0, 180] (an upside-down bottle is 180 degrees off).
    """
    a = np.asarray(axis, float).reshape(3)
    u, v = dot3(np.asarray(R_est, float).T, a), dot3(np.asarray(R_gt, float).T, a)  # R^T a
    return float(_axis_angles_deg(u, v))


def sample_errors(
    T_est: np.ndarray, T_gt: np.ndarray, symmetry_axis: np.ndarray | None = None, symmetries: Iterable[np.ndarray] = ()
) -> dict[str, float]:
    """Every error of one estimate of ``T_template_camera`` (both (4, 4)).

    ``symmetries`` are discrete symmetries ``S`` (4, 4) of the template frame (BOP
    ``symmetries_discrete``): each ``S @ T_gt`` is an equally correct answer, and the errors
    are those of the one closest to the estimate (by ``err_deg``, then ``trans_err``).

    Returns ``rot_err_deg``, ``axis_err_deg`` (NaN unless symmetric), ``trans_err`` (of the
    object's origin in the camera frame when symmetric, see the module docstring) and
    ``err_deg``, the error the statistics use (axis error if symmetric, else rotation error).
    """
    T_est, T_gt = np.asarray(T_est, float), np.asarray(T_gt, float)
    symmetries = [np.asarray(S, float).reshape(4, 4) for S in symmetries]
    if symmetries:
        candidates = [sample_errors(T_est, compose_T(S, T_gt), symmetry_axis) for S in [np.eye(4), *symmetries]]
        return min(candidates, key=lambda e: (round(e["err_deg"], 9), e["trans_err"]))
    rot = rotation_error_deg(T_est[:3, :3], T_gt[:3, :3])
    if symmetry_axis is None:
        axis = float("nan")
        trans = translation_error(T_est[:3, 3], T_gt[:3, 3])
    else:
        axis = axis_error_deg(T_est[:3, :3], T_gt[:3, :3], symmetry_axis)
        trans = translation_error(-dot3(T_est[:3, :3].T, T_est[:3, 3]), -dot3(T_gt[:3, :3].T, T_gt[:3, 3]))
    return {
        "rot_err_deg": rot,
        "axis_err_deg": axis,
        "trans_err": trans,
        "err_deg": rot if symmetry_axis is None else axis,
    }


def pose_errors_deg(
    T_est: np.ndarray, T_gt: np.ndarray, symmetry_axis: np.ndarray | None = None, symmetries: Iterable[np.ndarray] = ()
) -> np.ndarray:
    """``err_deg`` of :func:`sample_errors` for many estimates at once: (B,) degrees for ``T_est``
    (B, 4, 4) against one ``T_gt`` (4, 4), each the smallest over the discrete ``symmetries``.
    Only the angle: the rotation error, or the main-axis error of a symmetric object."""
    T_est = np.asarray(T_est, float).reshape(-1, 4, 4)
    if len(T_est) == 0:
        return np.zeros(0)
    R = T_est[:, :3, :3]
    best = np.full(len(T_est), np.inf)
    for S in [np.eye(4), *[np.asarray(S, float).reshape(4, 4) for S in symmetries]]:
        R_gt = compose_T(S, np.asarray(T_gt, float))[:3, :3]
        if symmetry_axis is None:
            err = _rotation_angles_deg(R, R_gt)
        else:
            a = np.asarray(symmetry_axis, float).reshape(3)
            u = R[:, 0, :] * a[0] + R[:, 1, :] * a[1] + R[:, 2, :] * a[2]  # R^T a, per pose
            err = _axis_angles_deg(u, dot3(R_gt.T, a))
        best = np.minimum(best, err)
    return best


def stage_errors(
    stages: dict[str, np.ndarray],
    T_gt: np.ndarray,
    symmetry_axis: np.ndarray | None = None,
    symmetries: Iterable[np.ndarray] = (),
) -> dict[str, float]:
    """Hypothesis recall of one sample: for each stage of a method's search (name -> the poses
    ``T_template_camera`` (B, 4, 4) it still held there), the error (degrees, as ``err_deg``) of the
    best of them; NaN for a stage that held none. The method names its stages
    (``RegistrationResult.extras["hypothesis_stages"]``); ground truth enters only here."""
    symmetries = list(symmetries)
    out = {}
    for name, T in stages.items():
        e = pose_errors_deg(T, T_gt, symmetry_axis, symmetries)
        out[str(name)] = float(e.min()) if e.size else float("nan")
    return out


FOUND_DEG = 10.0
"""``found10``: a hypothesis within this many degrees of the truth existed at some stage."""


def accuracy(errors_deg: Iterable[float], threshold_deg: float) -> float:
    """Fraction of errors at or below ``threshold_deg`` (NaN for an empty set)."""
    e = np.asarray(list(errors_deg), float)
    return float("nan") if e.size == 0 else float((e <= threshold_deg).mean())


def summarize(df):
    """Per-category statistics of a per-sample (or per-scoring-unit) table.

    ``df`` needs columns ``category``, ``status``, ``err_deg``, ``trans_err`` and ``runtime_s``.
    Failed rows count as :data:`FAILED_ERROR_DEG` in the angle statistics, are counted in
    ``failed`` and are left out of the translation mean (they have no estimate). The last row,
    ``all``, pools every sample. Returns a pandas DataFrame with columns ``category``, ``n``,
    ``failed``, ``mean_err_deg``, ``median_err_deg``, ``acc10``, ``acc30`` (at 10 and 30 degrees),
    ``mean_trans_err`` and ``median_runtime_s``, and ``found10`` after ``acc10`` when the rows
    have a ``found_err_deg`` (hypothesis recall: the fraction of samples where the method held a
    hypothesis within :data:`FOUND_DEG` of the truth at some stage; a row without one is found
    when its own answer is within it, a failed row never).
    """
    import pandas as pd

    from catpose.bench.scoring.curves import scored_errors

    names = ["category", "n", "failed", "mean_err_deg", "median_err_deg", "acc10", "acc30", "mean_trans_err"]
    names.append("median_runtime_s")
    found = "found_err_deg" in df.columns and pd.to_numeric(df["found_err_deg"], errors="coerce").notna().any()
    if found:
        names.insert(names.index("acc10") + 1, f"found{FOUND_DEG:g}")

    def finite(values) -> np.ndarray:
        x = pd.to_numeric(values, errors="coerce").to_numpy(float)
        return x[np.isfinite(x)]

    def stats(key: str, g) -> list:
        failed = (g["status"] != "ok").to_numpy()
        err = scored_errors(g)
        trans = finite(g["trans_err"][~failed])
        runtimes = finite(g["runtime_s"])
        out = [
            key,
            len(g),
            int(failed.sum()),
            float(err.mean()),
            float(np.median(err)),
            accuracy(err, 10.0),
            accuracy(err, 30.0),
            float(trans.mean()) if trans.size else float("nan"),
            float(np.median(runtimes)) if runtimes.size else float("nan"),
        ]
        if found:
            f = pd.to_numeric(g["found_err_deg"], errors="coerce").to_numpy(float)
            out.insert(6, accuracy(np.where(failed, FAILED_ERROR_DEG, np.fmin(f, err)), FOUND_DEG))
        return out

    if len(df) == 0:
        return pd.DataFrame(columns=names)
    rows = [stats(str(k), g) for k, g in df.groupby("category", sort=True)]
    rows.append(stats("all", df))
    return pd.DataFrame(rows, columns=names)
