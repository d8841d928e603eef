"""Least-squares rigid alignment of corresponding points (Kabsch 1976; Umeyama 1991), weighted,
with the reflection fix, batched.

Solves ``min_{R, t} sum_i w_i || R p_i + t - q_i ||^2`` over rotations (det R = +1): with
weighted centroids ``mp, mq`` and ``H = sum_i w_i (p_i - mp)(q_i - mq)^T = U S V^T``,
``R = V diag(1, 1, sign det(V U^T)) U^T`` (Sorkine-Hornung & Rabinovich 2017) and
``t = mq - R mp``.
"""

from __future__ import annotations

import numpy as np


def kabsch(P: np.ndarray, Q: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Rigid transforms ``T_q_p`` mapping ``P`` onto ``Q``.

    Args:
        P, Q: (B, n, 3) or (n, 3) corresponding points (any one unit).
        weights: (B, n) or (n,) non-negative weights, or None for equal weights.

    Returns:
        (B, 4, 4) transforms, or (4, 4) for unbatched input.
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
    U, _, Vt = np.linalg.svd(H)
    V = np.swapaxes(Vt, 1, 2)
    s = np.sign(np.linalg.det(V @ np.swapaxes(U, 1, 2)))
    s[s == 0] = 1.0
    D = np.zeros_like(H)
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = s
    R = V @ D @ np.swapaxes(U, 1, 2)
    t = mq[:, 0] - np.einsum("bij,bj->bi", R, mp[:, 0])
    T = np.tile(np.eye(4), (len(P), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    return T[0] if single else T
