"""Closed-form solver of the paper's two optimisation stages: iteratively reweighted Kabsch.

Stage 1 (pose) minimises, per candidate ``i`` (rotation ``R``, translation ``t``)::

    f(R, t) = sum_jk A[j, k] * || R p_j + t - q_k ||                 (weighted pairwise distance)

with ``p`` (n, 3) input keypoints, ``q`` (2n, 3) partial-template keypoints and ``A`` (n, 2n) the
affinity. With Euclidean (not squared) distances this is a multi-facility Weber problem in (R, t);
iteratively reweighted least squares (Weiszfeld 1937; the majorise-minimise form of
Aftab & Hartley 2015) majorises each distance at the current pose by
``d <= d^2 / (2 d0) + d0 / 2`` and minimises the weighted squared problem in closed form::

    W[j, k] = A[j, k] / d0[j, k]
    sum_jk W[j, k] || R p_j + t - q_k ||^2 = sum_j w_j || R p_j + t - qbar_j ||^2 + const,
    w_j = sum_k W[j, k],   qbar_j = sum_k W[j, k] q_k / w_j,

a weighted Kabsch problem (one 3x3 SVD per candidate, reflection fixed). Each iteration cannot
increase ``f``, so a handful of batched SVDs replaces 300 Adam steps.

Stage 2 (joint) of the paper lets Adam move the correspondences ``C = softmax_rows(L)`` from
``L = log A`` for a fixed number of steps; the unconstrained minimum over ``C`` is the hard
nearest assignment, so the paper's answer is defined by its step budget. The closed-form
counterpart solves the same loss with a KL trust region to the affinity::

    F(R, t, C) = sum_jk C[j, k] d_jk(R, t) + (1 / beta) sum_jk C[j, k] log(C[j, k] / A[j, k])

by block-coordinate descent: the ``C`` step is exact, ``C = softmax_rows(log A - beta d)``
(entropic soft assignment, as in Gold et al. 1998 / Cuturi 2013 without the column constraint),
and the pose step is the IRLS step above with ``C`` in place of ``A``. Both steps decrease ``F``.
``beta`` (1 / object-normalised unit) sets how far ``C`` may move from ``A``.

Every candidate stops on its own convergence (relative decrease of its objective below ``tol``)
and is then frozen, so a candidate's answer does not depend on the others in the batch: a problem
solved alone or inside a batch of problems gives the same poses (tests check this). Everything is
a fixed sequence of batched torch operations; runs are deterministic on one device.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose import kernel_threads
from catpose.kabsch import DEGENERATE_RATIO, rank_one_rotation

#: distances below this are clamped in the IRLS weights (object-normalised units)
_D_MIN = 1e-6


_STAGE_CODES = {"pose": 0, "joint": 1}


@dataclass(frozen=True)
class IRLSResult:
    """Solver output for a batch of ``B`` candidates (torch tensors on the solver's device).

    Attributes:
        R: (B, 3, 3) rotations ``R_template_camera``.
        t: (B, 3) translations (object-normalised units).
        loss: (B,) final ``sum_jk C d`` (the paper's loss, not divided by n).
        C: (B, n, 2n) final soft correspondences (``A`` after stage 1 only).
        iterations: (B,) iterations each candidate ran, both stages together.
    """

    R: object
    t: object
    loss: object
    C: object
    iterations: object


def _distances(P, Q, R, t):
    """d (B, n, 2n) between R p_j + t and q_k, with P (B, n, 3), Q (B, 2n, 3), R (B, 3, 3), t (B, 3)."""
    import torch

    x = torch.baddbmm(t[:, None, :], P, R.transpose(1, 2))  # (B, n, 3)
    return torch.cdist(x, Q, compute_mode="donot_use_mm_for_euclid_dist")


def weighted_kabsch(P, Q, W):
    """Rotation (B, 3, 3) and translation (B, 3) minimising ``sum_jk W[j,k] ||R p_j + t - q_k||^2``.

    Args:
        P: (B, n, 3) source points; Q: (B, k, 3) target points; W: (B, n, k) non-negative weights
            (a row of zeros drops that source point).
    """
    import torch

    w = W.sum(2)  # (B, n)
    qbar = torch.bmm(W, Q) / w.clamp_min(1e-30)[..., None]  # (B, n, 3)
    omega = w / w.sum(1, keepdim=True).clamp_min(1e-30)
    mp = (omega[..., None] * P).sum(1)  # (B, 3)
    mq = (omega[..., None] * qbar).sum(1)
    H = torch.bmm((P - mp[:, None]).transpose(1, 2), omega[..., None] * (qbar - mq[:, None]))
    U, S, Vt = torch.linalg.svd(H)
    V = Vt.transpose(1, 2)
    D = torch.ones_like(mp)
    D[:, 2] = torch.sign(torch.linalg.det(torch.bmm(V, U.transpose(1, 2))))
    D[:, 2][D[:, 2] == 0] = 1.0
    R = torch.bmm(V * D[:, None, :], U.transpose(1, 2))
    degenerate = S[:, 1] <= DEGENERATE_RATIO * S[:, 0]
    if bool(degenerate.any()):  # rank one: the closed form, not LAPACK's arbitrary null space
        idx = torch.nonzero(degenerate)[:, 0]
        fixed = np.stack([rank_one_rotation(h) for h in H[idx].detach().double().cpu().numpy()])
        R = R.clone()
        R[idx] = torch.as_tensor(fixed, dtype=R.dtype, device=R.device)
    t = mq - torch.bmm(R, mp[..., None])[..., 0]
    return R, t


def solve(
    P,
    Q,
    A,
    R0,
    t0,
    stages: tuple[str, ...] = ("pose", "joint"),
    beta: float = 10.0,
    max_iter: int = 50,
    tol: float = 1e-6,
) -> IRLSResult:
    """Run the stages in order on a batch of candidates (tensors on one device, one dtype).

    Args:
        P: (B, n, 3) input keypoints per candidate (camera frame; broadcast views are fine).
        Q: (B, 2n, 3) partial-template keypoints (template frame).
        A: (B, n, 2n) affinities, rows summing to 1.
        R0, t0: (B, 3, 3), (B, 3) initial poses ``T_template_camera``.
        stages: ``"pose"`` (stage 1: C = A) and/or ``"joint"`` (stage 2: C and pose), in order.
        beta: stage-2 sharpness in 1 / object-normalised unit (KL trust region 1 / beta).
        max_iter: iteration cap per stage and candidate.
        tol: a candidate stops when its objective falls by less than ``tol`` times itself.

    Returns:
        :class:`IRLSResult`; ``loss`` is ``sum_jk C d`` at the returned pose and ``C``.
    """
    import torch

    R, t = R0.clone(), t0.clone()
    C = A
    iters = torch.zeros(len(P), dtype=torch.int64, device=P.device)
    logA = torch.log(A.clamp_min(1e-30))
    with torch.no_grad():
        for stage in stages:  # checked by solve_numpy
            active = torch.ones(len(P), dtype=torch.bool, device=P.device)
            prev = torch.full((len(P),), float("inf"), dtype=P.dtype, device=P.device)
            C_stage = C
            for _ in range(max_iter):
                d = _distances(P, Q, R, t)
                if stage == "joint":
                    # exact C step; at it F = -(1/beta) sum_j log sum_k A e^(-beta d) (no log C needed)
                    z = logA - beta * d
                    lse = torch.logsumexp(z, dim=2, keepdim=True)
                    C_stage = torch.where(active[:, None, None], torch.exp(z - lse), C_stage)
                    obj = -lse.sum((1, 2)) / beta
                else:
                    obj = (C_stage * d).sum((1, 2))
                # converged: frozen from here on at the current pose (and C)
                active &= ~(prev - obj <= tol * obj.abs())
                if not bool(active.any()):
                    break
                prev = torch.where(active, obj, prev)
                R_new, t_new = weighted_kabsch(P, Q, C_stage / d.clamp_min(_D_MIN))
                R = torch.where(active[:, None, None], R_new, R)
                t = torch.where(active[:, None], t_new, t)
                iters += active.to(torch.int64)
            C = C_stage
        loss = (C * _distances(P, Q, R, t)).sum((1, 2))
    return IRLSResult(R, t, loss, C, iters)


def solve_numpy(
    P_c: np.ndarray,
    P_t: np.ndarray,
    A: np.ndarray,
    T0: np.ndarray,
    stages: tuple[str, ...],
    beta: float = 10.0,
    max_iter: int = 50,
    tol: float = 1e-6,
    device: str = "cpu",
    dtype: str = "float64",
    compiled: bool | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`solve` for one problem's ``m`` candidates from NumPy arrays (torch: :func:`solve_many`).

    Args:
        P_c: (n, 3) input keypoints (camera frame); P_t: (m, 2n, 3) partial-template keypoints;
        A: (m, n, 2n) affinities; T0: (m, 4, 4) initial ``T_template_camera``.
        compiled: run the compiled CPU kernel (:mod:`catpose.methods.ours.irls_kernel`, the same
            steps in float64) instead of torch; None: it on ``cpu`` in float64, torch
            otherwise. Its candidates are split over the run's ``threads``
            (:mod:`catpose.kernel_threads`; the same bits on any count).

    Returns:
        poses (m, 4, 4) float64 (re-orthonormalised), losses (m,) ``sum C d / n`` (mean
        correspondence-weighted keypoint distance), C (m, n, 2n), iterations (m,).
    """
    for s in stages:
        if s not in _STAGE_CODES:
            raise ValueError(f"unknown stage {s!r}; use 'pose' or 'joint'")
    if compiled is None:
        compiled = device == "cpu" and dtype == "float64"
    if compiled:
        from catpose.methods.ours import irls_kernel

        R = np.ascontiguousarray(T0[:, :3, :3], dtype=np.float64).copy()
        t = np.ascontiguousarray(T0[:, :3, 3], dtype=np.float64).copy()
        codes = np.array([_STAGE_CODES[s] for s in stages], dtype=np.int64)
        P = np.ascontiguousarray(P_c, dtype=np.float64)
        Q, A64 = np.ascontiguousarray(P_t, dtype=np.float64), np.ascontiguousarray(A, dtype=np.float64)

        def run(lo: int, hi: int):  # candidates lo..hi-1 (R, t in place), one by one as in one call
            return irls_kernel.solve(
                P, Q[lo:hi], A64[lo:hi], R[lo:hi], t[lo:hi], codes, float(beta), int(max_iter), float(tol)
            )

        parts = kernel_threads.split(run, len(R))
        loss, C, iters = (np.concatenate([p[k] for p in parts]) for k in range(3))
        return to_poses(R, t), loss / len(P_c), C, iters
    return solve_many([(P_c, P_t, A, T0)], stages, beta, max_iter, tol, device, dtype)[0]


def solve_many(
    problems: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    stages: tuple[str, ...],
    beta: float = 10.0,
    max_iter: int = 50,
    tol: float = 1e-6,
    device: str = "cpu",
    dtype: str = "float64",
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """:func:`solve_numpy` for several problems in one launch per shape: the candidates of all
    problems with the same (m, n) are stacked into one batch (the GPU path; on the CPU it is the
    same code). Each candidate converges and freezes on its own, so every problem gets the answer
    it gets alone (up to the last bits of batched kernels).

    Args:
        problems: ``(P_c (n, 3), P_t (m, 2n, 3), A (m, n, 2n), T0 (m, 4, 4))`` per problem.

    Returns:
        per problem, in order: poses (m, 4, 4), losses (m,) (``sum C d / n``), C (m, n, 2n),
        iterations (m,).
    """
    import torch

    dev, dt = torch.device(device), getattr(torch, dtype)
    groups: dict[tuple[int, ...], list[int]] = {}
    for i, (P_c, P_t, _, _) in enumerate(problems):
        groups.setdefault((len(P_c),) + tuple(P_t.shape), []).append(i)
    out: list = [None] * len(problems)
    for idx in groups.values():
        P = np.concatenate(
            [np.broadcast_to(problems[i][0], (len(problems[i][1]),) + problems[i][0].shape) for i in idx]
        )
        Q, A, T0 = (np.concatenate([problems[i][k] for i in idx]) for k in (1, 2, 3))
        res = solve(
            *(
                torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=dev)
                for a in (P, Q, A, T0[:, :3, :3], T0[:, :3, 3])
            ),
            stages,
            beta,
            max_iter,
            tol,
        )
        T, loss = to_poses(res.R, res.t), res.loss.double().cpu().numpy()
        C, iters = res.C.double().cpu().numpy(), res.iterations.cpu().numpy()
        start = 0
        for i in idx:
            m, n = len(problems[i][1]), len(problems[i][0])
            sl = slice(start, start + m)
            out[i] = (T[sl], loss[sl] / n, C[sl], iters[sl])
            start += m
    return out


def to_poses(R, t) -> np.ndarray:
    """(B, 4, 4) float64 poses from R (B, 3, 3), t (B, 3) (NumPy arrays or torch tensors),
    rotations re-orthonormalised in float64 so pose validation accepts float32 results."""
    R, t = (a.double().cpu().numpy() if hasattr(a, "cpu") else np.asarray(a, dtype=np.float64) for a in (R, t))
    U, _, Vt = np.linalg.svd(R)
    T = np.tile(np.eye(4), (len(R), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = U @ Vt, t
    return T
