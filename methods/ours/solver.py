"""The optimiser stage of ``ours`` (paper Section III-D) on all candidates of one problem at once:
``solver=irls`` (closed form, :mod:`catpose.methods.ours.irls`) or ``solver=adam`` (the paper's Adam,
:mod:`catpose.methods.ours.adam`), chosen by :class:`~catpose.methods.ours.settings.OptimiserSettings`."""

from __future__ import annotations

import numpy as np

from catpose.methods.ours.settings import OptimiserSettings

__all__ = ["IRLS_BETA", "IRLS_STAGES", "IRLS_TOL", "optimise"]

#: the IRLS stages of each optimiser mode
IRLS_STAGES = {"none": (), "pose": ("pose",), "joint": ("pose", "joint")}
#: stage-2 sharpness, 1 / object-normalised unit (the KL trust region to the affinity is 1 / beta),
#: and the relative objective decrease that stops a candidate; chosen with irls_iterations on
#: ModelNet40 train shapes against the paper's Adam (docs/choosing-defaults.md)
IRLS_BETA = 10.0
IRLS_TOL = 1e-4


def optimise(
    opt: OptimiserSettings,
    P_c: np.ndarray,
    P_t: np.ndarray,
    A: np.ndarray,
    T0: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The solver on all candidates at once (``opt.mode``: none, pose or joint). Returns
    poses (m, 4, 4), final losses (m,) as mean correspondence-weighted keypoint distances
    (object-normalised units) and the final soft correspondences C (m, n, 2n)."""
    mode = opt.mode
    if opt.solver == "irls":
        from catpose.methods.ours import irls

        cuda = opt.device.startswith("cuda")
        T, losses, C, _ = irls.solve_numpy(
            P_c,
            P_t,
            A,
            T0,
            IRLS_STAGES[mode],
            IRLS_BETA,
            opt.irls_iterations,
            IRLS_TOL,
            opt.device,
            "float32" if cuda else "float64",
        )
        return T, losses, C
    import torch

    from catpose.methods.ours.adam import BatchedProblem, _rot6d, optimize

    dev = torch.device(opt.device)
    dt = torch.float32

    def tens(a):
        return torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=dev)

    prob = BatchedProblem(tens(P_c), tens(P_t), tens(A))
    n = len(P_c)
    r6 = tens(np.concatenate([T0[:, :3, 0], T0[:, :3, 1]], axis=1))
    t = tens(T0[:, :3, 3])
    stages = []
    if mode in ("pose", "joint"):
        stages.append(("pose", opt.steps_pose))
    if mode == "joint":
        stages.append(("joint", opt.steps_joint))
    final, logits = optimize(prob, r6, t, stages, opt.lr)
    from catpose.methods.ours.irls import to_poses

    with torch.no_grad():
        T = to_poses(_rot6d(r6)[0], t)
        C = A if logits is None else torch.softmax(logits, dim=2).cpu().double().numpy()
    return T, final.detach().cpu().double().numpy() / n, C
