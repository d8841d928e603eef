"""The depth check's compiled window costs against the NumPy expressions they replaced, bit for bit."""

from __future__ import annotations

import numpy as np

from catpose.methods.ours.check_kernel import window_cost, window_fit


def numpy_window(o, m, r, tau):
    hit = r > 0
    mask_sum = np.where(hit, np.minimum(np.abs(r - o), tau) / tau, 1.0)[m].sum()
    free = (~m & hit & (o > 0) & (o - r > tau)).sum()
    return mask_sum, int(m.sum()), int(free)


def windows(seed: int, count: int):
    """Random windows like the depth check's: observed depth with holes, a blob mask, renderings
    near the observation, behind it, in front of it or empty; strided views of a larger lattice."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        H, W = rng.integers(1, 70, size=2)
        o = rng.uniform(0.5, 3.0, size=(H, W))
        o[rng.random((H, W)) < 0.1] = 0.0
        yy, xx = np.mgrid[:H, :W]
        m = (yy - H / 2) ** 2 / max(H, 1) + (xx - W / 2) ** 2 / max(W, 1) < rng.uniform(0.5, 20.0)
        r = o + rng.normal(0.0, rng.choice([0.01, 0.1, 0.5]), size=(H, W))
        r[rng.random((H, W)) < 0.2] = 0.0
        r0, c0 = rng.integers(0, max(H // 3, 1)), rng.integers(0, max(W // 3, 1))
        yield o[r0:, c0:], m[r0:, c0:], np.ascontiguousarray(r[r0:, c0:]), float(rng.choice([0.05, 0.1, 0.15]))


def test_window_cost_is_the_numpy_form() -> None:
    for o, m, r, tau in windows(0, 400):
        costs, free = window_cost(o, m, r, tau)
        want = numpy_window(o, m, r, tau)
        assert (costs.sum(), len(costs), free) == want


def test_window_fit_counts() -> None:
    rng = np.random.default_rng(1)
    for o, m, r, tol in windows(2, 200):
        inner = m & (rng.random(m.shape) < 0.7)
        hit = r > 0
        inliers = int((inner & hit & (np.abs(r - o) <= tol)).sum())
        free = int((~m & hit & (o > 0) & (o - r > tol)).sum())
        assert window_fit(o, m, inner, r, tol) == (inliers, free)


def test_nan_depth_costs_like_numpy() -> None:
    o = np.array([[1.0, np.nan], [2.0, 0.0]])
    m = np.array([[True, True], [False, False]])
    r = np.array([[1.05, 1.0], [1.0, 1.0]])
    (costs, free), want = window_cost(o, m, r, 0.1), numpy_window(o, m, r, 0.1)
    assert np.isnan(costs.sum()) and np.isnan(want[0]) and (len(costs), free) == want[1:] == (2, 1)
