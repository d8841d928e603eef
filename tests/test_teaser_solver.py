"""The TEASER-style solver against closed-form ground truth (catpose.methods.teaser_solver)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from catpose.errors import ConfigError, InvalidInputError
from catpose.methods import teaser_solver
from catpose.methods.max_clique import max_clique


def _rot_err_deg(R_a: np.ndarray, R_b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R_a.T @ R_b) - 1) / 2, -1, 1))))


def _outlier_problem(seed: int, n: int = 100, n_in: int = 10, noise_bound: float = 0.01):
    """``n`` correspondences in the unit cube, ``n_in`` inliers with noise inside the bound,
    the rest random (90 % outliers by default)."""
    rng = np.random.default_rng(seed)
    R, t = Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3)
    src = rng.uniform(-1, 1, (n, 3))
    dst = src @ R.T + t
    noise = rng.normal(size=(n_in, 3))
    noise *= (rng.uniform(0, noise_bound, n_in) / np.linalg.norm(noise, axis=1))[:, None]
    dst[:n_in] += noise
    dst[n_in:] = rng.uniform(-1.5, 1.5, (n - n_in, 3)) + t
    perm = rng.permutation(n)
    return src[perm], dst[perm], R, t, np.argsort(perm)[:n_in]


@pytest.mark.parametrize("seed", range(5))
def test_recovers_pose_with_90_percent_outliers(seed: int) -> None:
    noise_bound = 0.01
    src, dst, R, t, inliers = _outlier_problem(seed, noise_bound=noise_bound)
    r = teaser_solver.solve(src, dst, noise_bound)
    assert _rot_err_deg(r.R, R) < 1.0
    assert np.linalg.norm(r.t - t) < noise_bound
    assert r.clique_exact
    assert set(inliers.tolist()) <= set(r.clique.tolist())
    assert np.allclose(r.T[:3, :3], r.R) and np.allclose(r.T[:3, 3], r.t)


def test_noise_free_is_exact() -> None:
    rng = np.random.default_rng(3)
    R, t = Rotation.random(random_state=rng).as_matrix(), rng.normal(size=3)
    src = rng.normal(size=(30, 3))
    r = teaser_solver.solve(src, src @ R.T + t, 1e-3)
    assert _rot_err_deg(r.R, R) < 1e-5 and np.linalg.norm(r.t - t) < 1e-6
    assert len(r.clique) == 30


def _brute_force_clique_size(adj: np.ndarray) -> int:
    n = len(adj)
    for k in range(n, 0, -1):
        for c in itertools.combinations(range(n), k):
            if all(adj[i, j] for i, j in itertools.combinations(c, 2)):
                return k
    return 0


@pytest.mark.parametrize("seed", range(6))
def test_max_clique_matches_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 14
    upper = np.triu(rng.random((n, n)) < 0.5, k=1)
    adj = upper | upper.T
    clique, exact = max_clique(adj)
    assert exact
    assert all(adj[i, j] for i, j in itertools.combinations(clique.tolist(), 2))
    assert len(clique) == _brute_force_clique_size(adj)


def test_max_clique_budget_returns_a_clique_flagged_inexact() -> None:
    rng = np.random.default_rng(0)
    n = 120
    upper = np.triu(rng.random((n, n)) < 0.7, k=1)
    adj = upper | upper.T
    clique, exact = max_clique(adj, node_budget=5)
    assert not exact
    assert len(clique) >= 2
    assert all(adj[i, j] for i, j in itertools.combinations(clique.tolist(), 2))


def _random_graph(rng: np.random.Generator, n: int, p: float, planted: int = 0) -> np.ndarray:
    upper = np.triu(rng.random((n, n)) < p, k=1)
    adj = upper | upper.T
    if planted:
        members = rng.choice(n, planted, replace=False)
        adj[np.ix_(members, members)] = True
        np.fill_diagonal(adj, False)
    return adj


@pytest.mark.parametrize(
    "n,p,planted",
    [(40, 0.3, 0), (60, 0.5, 0), (50, 0.7, 0), (70, 0.1, 0), (130, 0.2, 25), (200, 0.1, 60), (150, 0.3, 0)],
)
@pytest.mark.parametrize("seed", range(3))
def test_max_clique_size_equals_networkx(n: int, p: float, planted: int, seed: int) -> None:
    """Against networkx's exact max_weight_clique (unit weights) as the independent reference;
    n > 64 exercises multi-word bitsets."""
    nx = pytest.importorskip("networkx")
    adj = _random_graph(np.random.default_rng(seed), n, p, planted)
    clique, exact = max_clique(adj)
    _, size = nx.max_weight_clique(nx.from_numpy_array(adj.astype(int)), weight=None)
    assert exact and len(clique) == size
    assert len(set(clique.tolist())) == len(clique)
    assert all(adj[i, j] for i, j in itertools.combinations(clique.tolist(), 2))


def test_max_clique_edge_cases() -> None:
    assert max_clique(np.zeros((0, 0), bool))[0].tolist() == []
    assert len(max_clique(np.zeros((5, 5), bool))[0]) == 1  # no edges: one vertex
    full = ~np.eye(9, dtype=bool)
    assert max_clique(full)[0].tolist() == list(range(9))


def test_max_clique_time_budget_falls_back_to_a_clique() -> None:
    """A zero time budget stops after the first chunk of the search: a valid clique, flagged
    inexact, at least as large as the greedy one."""
    from catpose.methods import max_clique as mc

    adj = _random_graph(np.random.default_rng(0), 300, 0.8)
    clique, exact = max_clique(adj, time_budget_s=0.0)
    assert not exact
    greedy = mc.greedy_clique(adj, np.argsort(-adj.sum(axis=1), kind="stable")[: mc.GREEDY_STARTS])
    assert len(clique) >= len(greedy)
    assert all(adj[i, j] for i, j in itertools.combinations(clique.tolist(), 2))


def test_consistency_graph_matches_its_definition() -> None:
    rng = np.random.default_rng(4)
    src, dst = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    adj = teaser_solver.consistency_graph(src, dst, 0.1)
    d_src = np.linalg.norm(src[:, None] - src[None], axis=-1)
    d_dst = np.linalg.norm(dst[:, None] - dst[None], axis=-1)
    expected = np.abs(d_dst - d_src) <= 0.2
    np.fill_diagonal(expected, False)
    assert adj.dtype == bool and np.array_equal(adj, expected)


def test_gnc_tls_rejects_outlier_measurements() -> None:
    rng = np.random.default_rng(1)
    R = Rotation.random(random_state=rng).as_matrix()
    a = rng.normal(size=(60, 3))
    b = a @ R.T
    b[:30] = rng.normal(size=(30, 3)) * 2  # 50 % gross outliers
    R_est, w, _, degenerate = teaser_solver.gnc_tls_rotation(a, b, noise_bound=0.01)
    assert not degenerate
    assert _rot_err_deg(R_est, R) < 1e-3
    assert (w[30:] > 0.5).all() and (w[:30] < 0.5).mean() > 0.9


def test_adaptive_voting_takes_the_max_consensus_mean() -> None:
    x = np.array([0.0, 0.01, 0.02, 0.015, 5.0, -3.0, 5.05])
    est, mask = teaser_solver.adaptive_voting(x, 0.02)
    assert mask.tolist() == [True, True, True, True, False, False, False]
    assert est == pytest.approx(np.mean(x[:4]))


def test_adaptive_voting_breaks_ties_by_the_smaller_spread() -> None:
    # two consensus sets of 3; the second is tighter
    x = np.array([0.0, 0.03, 0.06, 1.0, 1.001, 1.002])
    est, mask = teaser_solver.adaptive_voting(x, 0.035)
    assert mask.tolist() == [False, False, False, True, True, True]
    assert est == pytest.approx(1.001)


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="noise_bound"):
        teaser_solver.solve(np.zeros((5, 3)), np.zeros((5, 3)), -1.0)
    with pytest.raises(InvalidInputError):
        teaser_solver.solve(np.zeros((5, 3)), np.zeros((4, 3)), 0.1)


def test_teaser_method_checks_the_clique_time_budget() -> None:
    from catpose.methods.teaser import TEASER

    with pytest.raises(ConfigError, match="clique_time_budget_s=-1") as info:
        TEASER(clique_time_budget_s=-1)
    assert "\n" not in str(info.value)
    assert TEASER(clique_time_budget_s=0).clique_time_budget_s == 0.0  # 0 = no limit


def test_small_cliques_follow_teaserpp() -> None:
    """TEASER++ (teaser/src/registration.cc, ``RobustRegistrationSolver::solve``) aborts only on a
    max clique of 0 or 1 and solves every larger one; so does the re-implementation."""
    rng = np.random.default_rng(3)
    R, t = Rotation.random(random_state=rng).as_matrix(), np.array([0.2, -0.1, 0.3])
    src = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.7, 0.1]])
    # three exact correspondences, not on a line: a 3-clique fixes the pose
    r = teaser_solver.solve(src, src @ R.T + t, 0.01)
    assert len(r.clique) == 3 and not r.rotation_degenerate
    assert _rot_err_deg(r.R, R) < 1e-6 and np.allclose(r.t, t, atol=1e-9)
    # two: a pose (TEASER++ gives one too) mapping their segment exactly, flagged as not fixing
    # the rotation about it
    r = teaser_solver.solve(src[:2], src[:2] @ R.T + t, 0.01)
    assert len(r.clique) == 2 and r.rotation_degenerate
    assert np.allclose(src[:2] @ r.R.T + r.t, src[:2] @ R.T + t, atol=1e-9)
    # no two pairs agree in length: every max clique is one correspondence, no pose
    dst = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 7.0, 0.0]])
    with pytest.raises(InvalidInputError, match="registration.cc") as info:
        teaser_solver.solve(src, dst, 0.01)
    assert "max clique has 1 of 3" in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(InvalidInputError, match="1 correspondences"):
        teaser_solver.solve(src[:1], dst[:1], 0.01)
