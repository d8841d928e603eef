"""Least-squares rigid alignment of corresponding points (Kabsch 1976; Umeyama 1991), weighted,
with the reflection fix, batched.

Solves ``min_{R, t} sum_i w_i || R p_i + t - q_i ||^2`` over rotations (det R = +1): with
weighted centroids ``mp, mq`` and ``H = sum_i w_i (p_i - mp)(q_i - mq)^T = U S V^T``,
``R = V diag(1, 1, sign det(V U^T)) U^T`` (Sorkine-Hornung & Rabinovich 2017) and
``t = mq - R mp``.

A cross-covariance of rank one or less (``S[1] <= DEGENERATE_RATIO * S[0]``: two points, or
collinear ones) leaves the rotation about the one measured direction free. LAPACK then returns
whatever null-space vectors its CPU kernel happens to produce, so the answer changes with the
machine. Such an ``H`` is detected and given the shortest-arc rotation instead
(:func:`rank_one_rotation`, closed form, the same on every CPU); callers that would rather fail
read the ``degenerate`` flag of :func:`rotations_from_covariance`.
"""

from __future__ import annotations

import math

import numpy as np

from catpose.geometry import small_matmul

#: ``S[1] / S[0]`` at or below which a cross-covariance counts as rank one (the rotation about
#: its principal direction is not determined by the data).
DEGENERATE_RATIO = 1e-9


def rank_one_rotation(H: np.ndarray) -> np.ndarray:
    """The shortest-arc rotation (3, 3) for a rank-one cross-covariance ``H ~ s u v^T`` (3, 3).

    Every rotation with ``R u = v`` maximises ``trace(R H)``; this one turns ``u`` onto ``v`` about
    ``u x v`` (a half turn about a fixed perpendicular when they are opposite), the identity for
    ``H = 0``. ``u`` is ``H``'s longest column, ``v`` is ``H^T u``; plain arithmetic only (no
    LAPACK, no BLAS), so it is bit-identical on every CPU. Written in scalar code so that numba
    can compile it too (:mod:`catpose.methods.ours.irls_kernel`).
    """
    R = np.eye(3)
    best, j = -1.0, 0
    for c in range(3):
        n2 = H[0, c] * H[0, c] + H[1, c] * H[1, c] + H[2, c] * H[2, c]
        if n2 > best:
            best, j = n2, c
    if best <= 0.0:
        return R
    ln = math.sqrt(best)
    u0, u1, u2 = H[0, j] / ln, H[1, j] / ln, H[2, j] / ln
    v0 = H[0, 0] * u0 + H[1, 0] * u1 + H[2, 0] * u2
    v1 = H[0, 1] * u0 + H[1, 1] * u1 + H[2, 1] * u2
    v2 = H[0, 2] * u0 + H[1, 2] * u1 + H[2, 2] * u2
    lv = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if lv <= 0.0:
        return R
    v0, v1, v2 = v0 / lv, v1 / lv, v2 / lv
    c = u0 * v0 + u1 * v1 + u2 * v2
    if c > -1.0 + 1e-12:
        # R = I + [w]x + [w]x^2 / (1 + c) with w = u x v (Rodrigues without trigonometry)
        w0, w1, w2 = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        k = 1.0 / (1.0 + c)
        R[0, 0] = 1.0 - k * (w1 * w1 + w2 * w2)
        R[1, 1] = 1.0 - k * (w0 * w0 + w2 * w2)
        R[2, 2] = 1.0 - k * (w0 * w0 + w1 * w1)
        R[0, 1] = -w2 + k * w0 * w1
        R[1, 0] = w2 + k * w0 * w1
        R[0, 2] = w1 + k * w0 * w2
        R[2, 0] = -w1 + k * w0 * w2
        R[1, 2] = -w0 + k * w1 * w2
        R[2, 1] = w0 + k * w1 * w2
        return R
    # opposite: a half turn about a ⟂ u, a = unit(u x e) with e the axis least aligned with u
    a0, a1, a2 = 0.0, 0.0, 0.0
    if abs(u0) <= abs(u1) and abs(u0) <= abs(u2):
        a0, a1, a2 = 0.0, u2, -u1
    elif abs(u1) <= abs(u2):
        a0, a1, a2 = -u2, 0.0, u0
    else:
        a0, a1, a2 = u1, -u0, 0.0
    la = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    a0, a1, a2 = a0 / la, a1 / la, a2 / la
    R[0, 0], R[0, 1], R[0, 2] = 2 * a0 * a0 - 1.0, 2 * a0 * a1, 2 * a0 * a2
    R[1, 0], R[1, 1], R[1, 2] = 2 * a1 * a0, 2 * a1 * a1 - 1.0, 2 * a1 * a2
    R[2, 0], R[2, 1], R[2, 2] = 2 * a2 * a0, 2 * a2 * a1, 2 * a2 * a2 - 1.0
    return R


def _det3(M: np.ndarray) -> np.ndarray:
    """Determinants (B,) of (B, 3, 3) matrices by cofactor expansion (no LAPACK)."""
    return (
        M[:, 0, 0] * (M[:, 1, 1] * M[:, 2, 2] - M[:, 1, 2] * M[:, 2, 1])
        - M[:, 0, 1] * (M[:, 1, 0] * M[:, 2, 2] - M[:, 1, 2] * M[:, 2, 0])
        + M[:, 0, 2] * (M[:, 1, 0] * M[:, 2, 1] - M[:, 1, 1] * M[:, 2, 0])
    )


def rotations_from_covariance(H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Kabsch rotations of cross-covariances ``H`` (B, 3, 3), and which were degenerate.

    Returns:
        (B, 3, 3) rotations maximising ``trace(R H)``, and (B,) bool: ``H`` of rank one or less,
        whose rotation came from :func:`rank_one_rotation`.
    """
    H = np.asarray(H, dtype=np.float64)
    U, S, Vt = np.linalg.svd(H)
    V = np.swapaxes(Vt, 1, 2)
    Ut = np.swapaxes(U, 1, 2)
    s = np.sign(_det3(small_matmul(V, Ut)))
    s[s == 0] = 1.0
    D = np.ones((len(H), 3))
    D[:, 2] = s
    R = small_matmul(V * D[:, None, :], Ut)
    degenerate = S[:, 1] <= DEGENERATE_RATIO * S[:, 0]
    for b in np.flatnonzero(degenerate):
        R[b] = rank_one_rotation(H[b])
    return R, degenerate


def kabsch(P: np.ndarray, Q: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Rigid transforms ``T_q_p`` mapping ``P`` onto ``Q``.

    Args:
        P, Q: (B, n, 3) or (n, 3) corresponding points (any one unit).
        weights: (B, n) or (n,) non-negative weights, or None for equal weights.

    Returns:
        (B, 4, 4) transforms, or (4, 4) for unbatched input. A degenerate problem (fewer than
        two distinct points, or all on one line) gets :func:`rank_one_rotation`.
    """
    P, Q = np.asarray(P, dtype=np.float64), np.asarray(Q, dtype=np.float64)
    single = P.ndim == 2
    if single:
        P, Q = P[None], Q[None]
        weights = None if weights is None else np.asarray(weights, dtype=np.float64)[None]
    if weights is None:
        mp, mq = P.mean(1, keepdims=True), Q.mean(1, keepdims=True)
        H = np.einsum("bni,bnj->bij", P - mp, Q - mq)
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=np.float64), P.shape[:2])
        w = w / w.sum(1, keepdims=True)
        mp, mq = np.einsum("bn,bni->bi", w, P)[:, None], np.einsum("bn,bni->bi", w, Q)[:, None]
        H = np.einsum("bn,bni,bnj->bij", w, P - mp, Q - mq)
    R, _ = rotations_from_covariance(H)
    t = mq[:, 0] - np.einsum("bij,bj->bi", R, mp[:, 0])
    T = np.tile(np.eye(4), (len(P), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    return T[0] if single else T
