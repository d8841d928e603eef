"""The closed-form solver of ours (catpose.methods.ours.irls) against independent references."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

torch = pytest.importorskip("torch")

from catpose.methods.ours import irls  # noqa: E402


def _random_problem(seed: int, m: int = 4, n: int = 12, noise: float = 0.02):
    """Candidates whose keypoints are noisy rigid copies of the input keypoints with a sharp
    but imperfect affinity; returns p (n, 3), q (m, 2n, 3), A (m, n, 2n), true T (m, 4, 4)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3)) * 0.4
    q, A, T = [], [], []
    for _ in range(m):
        R = Rotation.random(random_state=rng).as_matrix()
        t = rng.normal(size=3) * 0.3
        match = p @ R.T + t + rng.normal(size=(n, 3)) * noise
        extra = rng.normal(size=(n, 3)) * 0.5
        perm = rng.permutation(2 * n)
        qi = np.concatenate([match, extra])[perm]
        Ai = rng.random((n, 2 * n)) * 0.3
        Ai[np.arange(n), np.argsort(perm)[:n]] += 1.0  # the true match carries most mass
        q.append(qi)
        A.append(Ai / Ai.sum(1, keepdims=True))
        Ti = np.eye(4)
        Ti[:3, :3], Ti[:3, 3] = R, t
        T.append(Ti)
    return p, np.stack(q), np.stack(A), np.stack(T)


def _stage1_loss(p, q, A, R, t):
    return float((A * np.linalg.norm((p @ R.T + t)[:, None] - q[None], axis=2)).sum())


def _tens(a):
    return torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float64)


def test_weighted_kabsch_matches_scipy_align_vectors():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(1)
    P, Q, W = rng.normal(size=(1, 10, 3)), rng.normal(size=(1, 7, 3)), rng.random((1, 10, 7))
    R, t = irls.weighted_kabsch(_tens(P), _tens(Q), _tens(W))
    # the same weighted problem written out pairwise, solved by scipy (Markley / SVD)
    src = np.repeat(P[0], 7, axis=0)
    dst = np.tile(Q[0], (10, 1))
    w = W[0].reshape(-1)
    ms, md = np.average(src, axis=0, weights=w), np.average(dst, axis=0, weights=w)
    R_ref, _ = Rotation.align_vectors(dst - md, src - ms, weights=w)
    np.testing.assert_allclose(R[0].numpy(), R_ref.as_matrix(), atol=1e-10)
    np.testing.assert_allclose(t[0].numpy(), md - R_ref.as_matrix() @ ms, atol=1e-10)


@pytest.mark.parametrize("compiled", [False, True], ids=["torch", "kernel"])
def test_exact_correspondences_give_the_exact_pose(compiled):
    p, q, A, T = _random_problem(2, noise=0.0)
    n = len(p)
    # one-hot affinity on the true match: stage 1 is plain Kabsch, exact in one step
    A_hard = (A == A.max(2, keepdims=True)).astype(float)
    T_est, loss, _, _ = irls.solve_numpy(p, q, A_hard, np.tile(np.eye(4), (len(q), 1, 1)), ("pose",), compiled=compiled)
    np.testing.assert_allclose(T_est, T, atol=1e-6)
    assert loss.max() < 1e-6 * n


@pytest.mark.parametrize("compiled", [False, True], ids=["torch", "kernel"])
def test_stage1_reaches_the_minimum_found_by_scipy(compiled):
    from scipy.optimize import minimize
    from scipy.spatial.transform import Rotation

    p, q, A, T = _random_problem(3)
    T0 = np.tile(np.eye(4), (len(q), 1, 1))
    T0[:, :3, 3] = q.mean(1) - p.mean(0)
    T_est, loss, _, iters = irls.solve_numpy(p, q, A, T0, ("pose",), max_iter=500, tol=1e-12, compiled=compiled)
    for i in range(len(q)):

        def f(x):
            return _stage1_loss(p, q[i], A[i], Rotation.from_rotvec(x[:3]).as_matrix(), x[3:])

        start = np.concatenate([Rotation.from_matrix(T[i, :3, :3]).as_rotvec(), T[i, :3, 3]])
        ref = minimize(f, start, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000})
        assert loss[i] * len(p) <= ref.fun + 1e-7, (i, loss[i] * len(p), ref.fun)
        at_estimate = _stage1_loss(p, q[i], A[i], T_est[i, :3, :3], T_est[i, :3, 3])
        assert at_estimate == pytest.approx(loss[i] * len(p), rel=1e-9)


@pytest.mark.parametrize("compiled", [False, True], ids=["torch", "kernel"])
def test_each_iteration_lowers_the_objective(compiled):
    p, q, A, _ = _random_problem(4)
    T0 = np.tile(np.eye(4), (len(q), 1, 1))
    prev = None
    for k in range(1, 8):  # k iterations from the same start: a monotone sequence (majorise-minimise)
        _, loss, _, _ = irls.solve_numpy(p, q, A, T0, ("pose",), max_iter=k, tol=0.0, compiled=compiled)
        if prev is not None:
            assert np.all(loss <= prev + 1e-12)
        prev = loss


@pytest.mark.parametrize("compiled", [False, True], ids=["torch", "kernel"])
def test_joint_stage_correspondences_are_the_exact_c_step(compiled):
    p, q, A, _ = _random_problem(5)
    T0 = np.tile(np.eye(4), (len(q), 1, 1))
    beta = 10.0
    T, loss, C, _ = irls.solve_numpy(p, q, A, T0, ("pose", "joint"), beta=beta, max_iter=30, compiled=compiled)
    np.testing.assert_allclose(C.sum(2), 1.0, atol=1e-12)
    # at convergence C is (close to) the softmax of log A - beta d at the returned pose
    d = np.linalg.norm((np.einsum("mij,nj->mni", T[:, :3, :3], p) + T[:, None, :3, 3])[:, :, None] - q[:, None], axis=3)
    z = np.log(A) - beta * d
    C_ref = np.exp(z - z.max(2, keepdims=True))
    C_ref /= C_ref.sum(2, keepdims=True)
    np.testing.assert_allclose(C, C_ref, atol=1e-3)
    np.testing.assert_allclose(loss * len(p), (C * d).sum((1, 2)), rtol=1e-9)


@pytest.mark.parametrize("compiled", [False, True], ids=["torch", "kernel"])
def test_a_candidate_does_not_depend_on_its_batch(compiled):
    p, q, A, _ = _random_problem(6, m=5)
    T0 = np.tile(np.eye(4), (5, 1, 1))
    full = irls.solve_numpy(p, q, A, T0, ("pose", "joint"), compiled=compiled)
    for i in (0, 3):
        one = irls.solve_numpy(p, q[i : i + 1], A[i : i + 1], T0[i : i + 1], ("pose", "joint"), compiled=compiled)
        np.testing.assert_allclose(one[0][0], full[0][i], atol=1e-12)
        assert one[3][0] == full[3][i]


def test_deterministic_and_float32_close_to_float64():
    p, q, A, _ = _random_problem(7)
    T0 = np.tile(np.eye(4), (len(q), 1, 1))
    a = irls.solve_numpy(p, q, A, T0, ("pose", "joint"))
    b = irls.solve_numpy(p, q, A, T0, ("pose", "joint"))
    np.testing.assert_array_equal(a[0], b[0])
    c = irls.solve_numpy(p, q, A, T0, ("pose", "joint"), dtype="float32")
    np.testing.assert_allclose(c[0], a[0], atol=1e-3)


def test_unknown_stage_is_a_clear_error():
    p, q, A, _ = _random_problem(8, m=1)
    with pytest.raises(ValueError, match="unknown stage"):
        irls.solve_numpy(p, q, A, np.eye(4)[None], ("lbfgs",))


def test_many_problems_in_one_launch_give_each_problem_its_own_answer():
    probs = []
    for seed, n in ((10, 12), (11, 12), (12, 9)):  # two shapes: two launches
        p, q, A, _ = _random_problem(seed, m=3, n=n)
        probs.append((p, q, A, np.tile(np.eye(4), (3, 1, 1))))
    many = irls.solve_many(probs, ("pose", "joint"))
    for prob, got in zip(probs, many):
        alone = irls.solve_numpy(*prob, ("pose", "joint"), compiled=False)
        np.testing.assert_allclose(got[0], alone[0], atol=1e-12)
        np.testing.assert_allclose(got[1], alone[1], atol=1e-12)
        np.testing.assert_array_equal(got[3], alone[3])


def test_compiled_kernel_matches_the_torch_solver():
    for seed in (20, 21):
        p, q, A, _ = _random_problem(seed, m=6)
        T0 = np.tile(np.eye(4), (6, 1, 1))
        for stages in (("pose",), ("pose", "joint"), ("joint",)):
            a = irls.solve_numpy(p, q, A, T0, stages, max_iter=8, tol=1e-4, compiled=False)
            b = irls.solve_numpy(p, q, A, T0, stages, max_iter=8, tol=1e-4, compiled=True)
            np.testing.assert_allclose(b[0], a[0], atol=1e-9)
            np.testing.assert_allclose(b[1], a[1], rtol=1e-9)
            np.testing.assert_allclose(b[2], a[2], atol=1e-9)
            np.testing.assert_array_equal(b[3], a[3])


# ------------------------------------------------------------------ wiring into ours


@pytest.fixture(scope="module")
def chair_problems(tmp_path_factory):
    from _ours_fixtures import chair_template, partial_problem

    mp = pytest.MonkeyPatch()
    mp.setenv("CATPOSE_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    t = chair_template()
    yield [partial_problem(t, s) for s in (0, 1)]
    mp.undo()


def test_ours_register_batch_gives_what_register_gives(chair_problems):
    from catpose.methods.ours import Ours

    method = Ours()
    problems = [p for p, _ in chair_problems]
    single = [method.register(p) for p in problems]
    batch = method.register_batch(problems)  # torch solver, all candidates in one launch
    for a, b in zip(single, batch):
        assert a.extras["template_index"] == b.extras["template_index"]
        np.testing.assert_allclose(b.T_template_camera, a.T_template_camera, atol=1e-6)
        assert set(b.extras["timings"]) == set(a.extras["timings"])


def test_both_solvers_recover_the_known_pose(chair_problems):
    from _ours_fixtures import rotation_error_deg

    from catpose.methods.ours import OptimiserSettings, Ours

    for solver in ("irls", "adam"):
        method = Ours(optimiser=OptimiserSettings(solver=solver, steps_pose=100, steps_joint=100, lr=2e-2))
        for p, T in chair_problems:
            R = method.register(p).T_template_camera[:3, :3]
            assert rotation_error_deg(R, T[:3, :3]) < 10.0, solver


def test_solver_options_are_checked_and_compose():
    from hydra import compose, initialize_config_module

    from catpose.bench.run.build import build_from_config
    from catpose.errors import ConfigError
    from catpose.methods.ours import OptimiserSettings

    with pytest.raises(ConfigError, match="method.optimiser.solver='lbfgs' is unknown"):
        OptimiserSettings(solver="lbfgs")
    with pytest.raises(ConfigError, match="irls_iterations"):
        OptimiserSettings(irls_iterations=0)
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose("run", overrides=["method=ours", "method.optimiser.solver=adam"])
    assert build_from_config(cfg.method, "method")[1].optimiser.solver == "adam"
    with initialize_config_module(config_module="catpose.configs", version_base="1.3"):
        cfg = compose("run", overrides=["method=ours"])
    assert build_from_config(cfg.method, "method")[1].optimiser.solver == "irls"
