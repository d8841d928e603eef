"""The IRLS solver of :mod:`catpose.methods.ours.irls` as one compiled CPU kernel (numba).

Same algorithm, same order of steps and the same stopping rule as :func:`catpose.methods.ours.irls.solve`
(the torch version, which runs on the GPU and is this kernel's reference in the tests), in
float64, one candidate after another on one thread. At ours' sizes (18 candidates, 32 x 64
distances, about ten iterations) the torch version spends its time in ~40 small operations per
iteration, each a few microseconds of dispatch on an idle core and far more on a loaded one; the
kernel is one call per problem. Imported lazily (numba compiles on first use, cached on disk).
"""

from __future__ import annotations

import numba
import numpy as np

from catpose.kabsch import DEGENERATE_RATIO, rank_one_rotation

_D_MIN = 1e-6
_rank_one_rotation = numba.njit(cache=True, nogil=True)(rank_one_rotation)


@numba.njit(cache=True, nogil=True)
def _weighted_kabsch(p, q, W, R, t):  # pragma: no cover - compiled
    """In place: R (3, 3), t (3,) minimising sum_jk W[j,k] ||R p_j + t - q_k||^2."""
    n, k = W.shape
    w = np.zeros(n)
    qbar = np.zeros((n, 3))
    for j in range(n):
        for kk in range(k):
            wjk = W[j, kk]
            w[j] += wjk
            for a in range(3):
                qbar[j, a] += wjk * q[kk, a]
    total = 0.0
    for j in range(n):
        total += w[j]
    total = max(total, 1e-30)
    mp = np.zeros(3)
    mq = np.zeros(3)
    omega = np.zeros(n)
    for j in range(n):
        omega[j] = w[j] / total
        inv = 1.0 / max(w[j], 1e-30)
        for a in range(3):
            qbar[j, a] *= inv
            mp[a] += omega[j] * p[j, a]
            mq[a] += omega[j] * qbar[j, a]
    H = np.zeros((3, 3))
    for j in range(n):
        for a in range(3):
            pa = p[j, a] - mp[a]
            for b in range(3):
                H[a, b] += pa * omega[j] * (qbar[j, b] - mq[b])
    U, S, Vt = np.linalg.svd(H)
    if S[1] <= DEGENERATE_RATIO * S[0]:  # rank one: not LAPACK's arbitrary null space
        Rn = _rank_one_rotation(H)
    else:
        V = Vt.T
        s = np.sign(np.linalg.det(V @ U.T))
        if s == 0:
            s = 1.0
        D = np.eye(3)
        D[2, 2] = s
        Rn = V @ D @ U.T
    for a in range(3):
        R[a, :] = Rn[a, :]
        t[a] = mq[a] - (Rn[a, 0] * mp[0] + Rn[a, 1] * mp[1] + Rn[a, 2] * mp[2])


@numba.njit(cache=True, nogil=True)
def _distances(p, q, R, t, d):  # pragma: no cover - compiled
    n, k = d.shape
    for j in range(n):
        x0 = R[0, 0] * p[j, 0] + R[0, 1] * p[j, 1] + R[0, 2] * p[j, 2] + t[0]
        x1 = R[1, 0] * p[j, 0] + R[1, 1] * p[j, 1] + R[1, 2] * p[j, 2] + t[1]
        x2 = R[2, 0] * p[j, 0] + R[2, 1] * p[j, 1] + R[2, 2] * p[j, 2] + t[2]
        for kk in range(k):
            e0, e1, e2 = x0 - q[kk, 0], x1 - q[kk, 1], x2 - q[kk, 2]
            d[j, kk] = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


@numba.njit(cache=True, nogil=True)
def solve(P, Q, A, R, t, stages, beta, max_iter, tol):  # pragma: no cover - compiled
    """In place on R (B, 3, 3), t (B, 3); returns loss (B,), C (B, n, 2n), iterations (B,).

    P (n, 3) is shared by all B candidates; Q (B, 2n, 3); A (B, n, 2n); stages: int array,
    0 = pose, 1 = joint (see :func:`catpose.methods.ours.irls.solve`).
    """
    B, n, k = A.shape
    loss = np.zeros(B)
    C_out = A.copy()
    iters = np.zeros(B, dtype=np.int64)
    d = np.empty((n, k))
    W = np.empty((n, k))
    logA = np.log(np.maximum(A, 1e-30))
    for b in range(B):
        C = C_out[b]
        for stage in stages:
            prev = np.inf
            for _ in range(max_iter):
                _distances(P, Q[b], R[b], t[b], d)
                obj = 0.0
                if stage == 1:
                    for j in range(n):
                        zmax = -np.inf
                        for kk in range(k):
                            z = logA[b, j, kk] - beta * d[j, kk]
                            W[j, kk] = z
                            zmax = max(zmax, z)
                        s = 0.0
                        for kk in range(k):
                            s += np.exp(W[j, kk] - zmax)
                        lse = zmax + np.log(s)
                        for kk in range(k):
                            C[j, kk] = np.exp(W[j, kk] - lse)
                        obj -= lse / beta
                else:
                    for j in range(n):
                        for kk in range(k):
                            obj += C[j, kk] * d[j, kk]
                if prev - obj <= tol * abs(obj):
                    break
                prev = obj
                for j in range(n):
                    for kk in range(k):
                        W[j, kk] = C[j, kk] / max(d[j, kk], _D_MIN)
                _weighted_kabsch(P, Q[b], W, R[b], t[b])
                iters[b] += 1
        _distances(P, Q[b], R[b], t[b], d)
        acc = 0.0
        for j in range(n):
            for kk in range(k):
                acc += C[j, kk] * d[j, kk]
        loss[b] = acc
    return loss, C_out, iters
