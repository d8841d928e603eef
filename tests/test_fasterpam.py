"""The NumPy K-medoids (BUILD + FasterPAM) against an exhaustive search and, where the GPL
``kmedoids`` package is installed (not by ``make setup``), against its Rust FasterPAM."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from catpose.bench.category.fasterpam import build, fasterpam


def _distances(seed: int, n: int, clustered: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 3))
    if clustered:
        X[: n // 3] += 6.0
        X[n // 3 : 2 * n // 3] -= 6.0
    return np.linalg.norm(X[:, None] - X[None], axis=2)


def _loss(D: np.ndarray, medoids) -> float:
    return float(D[:, list(medoids)].min(axis=1).sum())


def _optimum(D: np.ndarray, k: int) -> float:
    return min(_loss(D, m) for m in itertools.combinations(range(len(D)), k))


@pytest.mark.parametrize("seed", range(12))
def test_a_local_optimum_no_single_swap_improves(seed):
    D = _distances(seed, 14, clustered=seed % 2 == 0)
    k = 2 + seed % 3
    medoids, loss = fasterpam(D, k)
    assert len(set(medoids.tolist())) == k and loss == pytest.approx(_loss(D, medoids))
    for slot, j in itertools.product(range(k), range(len(D))):
        if j in medoids:
            continue
        swapped = medoids.copy()
        swapped[slot] = j
        assert _loss(D, swapped) >= loss - 1e-9, (slot, j)


@pytest.mark.parametrize("seed", range(8))
def test_separated_clusters_reach_the_exhaustive_optimum(seed):
    D = _distances(seed, 12, clustered=True)
    medoids, loss = fasterpam(D, 3)
    assert loss == pytest.approx(_optimum(D, 3), rel=1e-12)


def test_build_takes_the_best_first_medoid_and_k_1_and_n():
    D = _distances(0, 9, clustered=False)
    assert build(D, 1).tolist() == [int(np.argmin(D.sum(axis=0)))]
    assert fasterpam(D, 1)[1] == pytest.approx(_optimum(D, 1))
    assert sorted(fasterpam(D, 9)[0].tolist()) == list(range(9)) and fasterpam(D, 9)[1] == 0.0
    with pytest.raises(ValueError, match="between 1 and N"):
        fasterpam(D, 10)
    with pytest.raises(ValueError, match="square"):
        fasterpam(D[:3], 2)


def test_duplicate_points_and_ties_stay_deterministic():
    X = np.repeat(np.array([[0.0, 0, 0], [5, 0, 0], [0, 5, 0]]), 3, axis=0)  # three triples of equal points
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    medoids, loss = fasterpam(D, 3)
    assert loss == 0.0 and sorted(medoids.tolist()) == [0, 3, 6]  # the lowest index of each triple
    assert fasterpam(D, 3)[0].tolist() == medoids.tolist()


@pytest.mark.parametrize("seed", range(40))
def test_same_loss_as_the_kmedoids_package(seed):
    kmedoids = pytest.importorskip("kmedoids")
    rng = np.random.default_rng(1000 + seed)
    n, k = int(rng.integers(6, 40)), int(rng.integers(2, 6))
    D = _distances(1000 + seed, n, clustered=seed % 2 == 1)
    medoids, loss = fasterpam(D, k)
    ref = kmedoids.fasterpam(D, k, max_iter=100, init="build", random_state=None)
    # the same local search from the same start: the same loss (the medoids too, except where two
    # points of a cluster tie and the order of the updates picks the other one: 194 of 200 agree)
    assert loss == pytest.approx(float(ref.loss), rel=1e-12)
    assert _loss(D, [int(m) for m in ref.medoids]) == pytest.approx(loss, rel=1e-12)
