"""A TEASER-style robust registration solver from putative correspondences (NumPy, numba).

Re-implements the pipeline of TEASER (Yang, Shi, Carlone, "TEASER: Fast and Certifiable Point
Cloud Registration", T-RO 2020) and its C++ library TEASER++ with the scale fixed to 1 (the real
TEASER++ is ``method=teaserpp``, :func:`catpose.methods.teaser.solve_teaserpp`). Given
correspondences ``b_i = R a_i + t + e_i`` with ``|e_i| <= noise_bound`` for inliers:

1. Translation- and rotation-invariant measurements (TIMs): pairwise lengths. A pair (i, j) is
   consistent when ``| ||b_i - b_j|| - ||a_i - a_j|| | <= 2 * noise_bound`` (scale 1).
2. Maximum clique of the consistency graph (:mod:`catpose.methods.max_clique`, exact within a
   node and a time budget; past either, ``SolverResult.clique_exact`` is False).
3. Rotation from the translation-invariant measurements (TIMs ``b_j - b_i`` vs ``a_j - a_i``) of
   a cyclic chain through the clique (TEASER++'s default) by graduated non-convexity with a
   truncated least-squares cost (GNC-TLS, Yang et al., RA-L 2020, :func:`gnc_tls_rotation`). The
   TIM noise bound is ``2 * noise_bound`` (sum of two point bounds) times ``sqrt(cbar2)``.
4. Translation by component-wise adaptive voting: per axis, the intervals
   ``t_i +- noise_bound`` of ``t_i = b_i - R a_i`` over the clique; the estimate is the mean of
   the largest consistent (maximum-consensus) set, ties broken by the smaller spread.
   (TEASER++'s ``ScalarTLSEstimator`` instead keeps the set of least TLS cost; both sweep the
   same interval end points.)

Lengths are in the caller's unit (object-normalised in catpose).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from catpose.errors import ConfigError, InvalidInputError
from catpose.geometry import apply_R, make_T
from catpose.kabsch import rotations_from_covariance

#: A max clique smaller than this gives no pose (both solvers), TEASER++'s own rule
#: (``RobustRegistrationSolver::solve``, teaser/src/registration.cc: "Clique size too small.
#: Abort." when ``max_clique_.size() <= 1``). Where a clique of 2 or 3 spans one direction the
#: rotation about it is the closed-form shortest arc (:func:`catpose.kabsch.rank_one_rotation`;
#: TEASER++ takes whatever its SVD returns) and ``SolverResult.rotation_degenerate`` says so.
MIN_CLIQUE_SIZE = 2


@dataclass(frozen=True)
class SolverResult:
    """Output of :func:`solve`.

    Attributes:
        R: (3, 3) rotation with ``b ~ R a + t``.
        t: (3,) translation.
        clique: indices of the max-clique correspondences (into the input rows).
        clique_exact: whether the clique search finished within its budgets.
        rotation_inliers: (k_pairs,) bool, TIMs kept by GNC-TLS (weight > 0.5).
        translation_inliers: indices (into the input rows) that voted for ``t`` on all axes.
        gnc_iterations: number of GNC iterations run.
        timings: seconds per stage.
        rotation_degenerate: the rotation inliers span one direction (or none), so the rotation
            about it is not fixed by the data (the closed-form shortest arc was taken).
    """

    R: np.ndarray
    t: np.ndarray
    clique: np.ndarray
    clique_exact: bool
    rotation_inliers: np.ndarray
    translation_inliers: np.ndarray
    gnc_iterations: int
    timings: dict = field(default_factory=dict)
    rotation_degenerate: bool = False

    @property
    def T(self) -> np.ndarray:
        """(4, 4) homogeneous transform mapping ``a`` (source) into ``b`` (target)."""
        return make_T(self.R, self.t)


def consistency_graph(src: np.ndarray, dst: np.ndarray, noise_bound: float) -> np.ndarray:
    """(N, N) bool adjacency of the row-matched ``src`` ``a_i`` and ``dst`` ``b_i`` (N, 3):
    ``| ||b_i - b_j|| - ||a_i - a_j|| | <= 2 noise_bound`` (scale 1), zero diagonal."""
    from scipy.spatial.distance import cdist

    adj = np.abs(cdist(dst, dst) - cdist(src, src)) <= 2.0 * noise_bound  # no (N, N, 3) temporaries
    np.fill_diagonal(adj, False)
    return adj


def weighted_kabsch(src: np.ndarray, dst: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, bool]:
    """Rotation (3, 3) minimising ``sum_k w_k ||dst_k - R src_k||^2`` over (K, 3) vectors, and
    whether the weighted measurements span one direction or none (then the rotation about it is
    :func:`catpose.kabsch.rank_one_rotation`'s)."""
    H = np.einsum("k,ki,kj->ij", w, src, dst)
    R, degenerate = rotations_from_covariance(H[None])
    return R[0], bool(degenerate[0])


def gnc_tls_rotation(
    src: np.ndarray,
    dst: np.ndarray,
    noise_bound: float,
    cbar2: float = 1.0,
    gnc_factor: float = 1.4,
    max_iterations: int = 100,
    cost_threshold: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray, int]:
    """GNC-TLS rotation: ``min_R sum_k min(||dst_k - R src_k||^2 / c^2, cbar2)``.

    Follows TEASER++'s ``GNCTLSRotationSolver``: each iteration solves a weighted Kabsch
    problem, then the TLS weights in closed form for the current ``mu``
    (``w = 1`` below ``th2 = mu/(mu+1) cbar2 c^2``, ``0`` above ``th1 = (mu+1)/mu cbar2 c^2``,
    ``sqrt(cbar2 c^2 mu (mu+1) / r^2) - mu`` between), ``mu *= gnc_factor``. It stops when the
    weights are binary and either unchanged or the cost (in units of ``cbar2 c^2``) changed by
    less than ``cost_threshold``. (TEASER++ stops on an absolute cost change alone, which can
    stop while ``mu`` is still tiny and every weight is near 0 when residuals are small in
    absolute terms, as they are in object-normalised units.)

    Args:
        src, dst: (K, 3) rotation-only measurements (TIMs).
        noise_bound: bound ``c`` on an inlier measurement's residual norm.

    Returns:
        (R (3, 3), weights (K,), iterations run, whether R is not determined by the final weighted
        measurements, as :func:`weighted_kabsch`).
    """
    K = len(src)
    w = np.ones(K)
    bound2 = max(cbar2 * noise_bound**2, 1e-16)
    mu = 1.0
    prev_cost = np.inf
    R = np.eye(3)
    it = 0
    for it in range(1, max_iterations + 1):
        R, _ = weighted_kabsch(src, dst, w)
        r2 = ((dst - apply_R(R, src)) ** 2).sum(axis=1)
        if it == 1:
            mu = 1.0 / (2.0 * r2.max() / bound2 - 1.0)
            if mu <= 0:  # every residual is already within the bound: least squares is TLS
                break
        th1 = (mu + 1.0) / mu * bound2
        th2 = mu / (mu + 1.0) * bound2
        cost = float((w * r2).sum()) / bound2  # dimensionless, so the threshold is unit-free
        with np.errstate(divide="ignore"):
            mid = np.sqrt(bound2 * mu * (mu + 1.0) / np.maximum(r2, 1e-300)) - mu
        w_prev = w
        w = np.where(r2 >= th1, 0.0, np.where(r2 <= th2, 1.0, np.clip(mid, 0.0, 1.0)))
        mu *= gnc_factor
        # converged once the weights are binary (TLS reached) and stable
        binary = bool(np.all((w == 0.0) | (w == 1.0)))
        if binary and (np.array_equal(w, w_prev) or abs(cost - prev_cost) < cost_threshold):
            break
        prev_cost = cost
    degenerate = True
    if w.sum() > 0:
        R, degenerate = weighted_kabsch(src, dst, w)
    return R, w, it, degenerate


def adaptive_voting(values: np.ndarray, bound: float) -> tuple[float, np.ndarray]:
    """Scalar maximum-consensus estimate of ``values`` (K,) by adaptive voting: each votes for
    ``[x_i - bound, x_i + bound]``; sweeping the sorted end points gives every maximal set of
    overlapping intervals. Returns the mean of the largest (ties: the least variance) and its
    bool (K,) mask."""
    x = np.asarray(values, dtype=np.float64)
    lo, hi = x - bound, x + bound
    # events: +1 at the interval start, -1 after its end; starts sort before ends at ties
    pos = np.concatenate([lo, hi])
    kind = np.concatenate([np.zeros(len(x), int), np.ones(len(x), int)])
    order = np.lexsort((kind, pos))
    is_start = kind[order] == 0
    count = np.cumsum(np.where(is_start, 1, -1))  # open intervals just after each event
    best_var, best_mask = np.inf, np.ones(len(x), dtype=bool)
    # the maximal sets are read at start events; keep the largest, then the first least spread
    for e in order[is_start & (count == count[is_start].max())]:
        mask = (lo <= pos[e]) & (hi >= pos[e])
        var = float(x[mask].var())
        if var < best_var:
            best_var, best_mask = var, mask
    return float(x[best_mask].mean()), best_mask


def checked_inputs(
    src: np.ndarray, dst: np.ndarray, noise_bound: float, solver: str = "TEASER"
) -> tuple[np.ndarray, np.ndarray]:
    """``src``, ``dst`` as float64 after the checks every TEASER solver makes (matched (N, 3)
    arrays, a positive noise bound), each failure in one line naming ``solver``."""
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3:
        raise InvalidInputError(f"{solver} needs two (N, 3) arrays of matched points; got {src.shape} and {dst.shape}")
    if not noise_bound > 0:
        raise ConfigError(f"noise_bound={noise_bound} must be > 0 (object-normalised units, e.g. 0.02)")
    return src, dst


def solve(
    src: np.ndarray,
    dst: np.ndarray,
    noise_bound: float,
    cbar2: float = 1.0,
    gnc_factor: float = 1.4,
    max_iterations: int = 100,
    cost_threshold: float = 1e-6,
    clique_node_budget: int = 200_000,
    clique_time_budget_s: float | None = None,
) -> SolverResult:
    """Robust registration ``dst ~ R src + t`` from putative correspondences (TEASER, scale 1).

    Args:
        src, dst: (N, 3) row-matched points ``a_i`` (e.g. camera frame), ``b_i`` (template frame).
        noise_bound: inlier bound ``beta`` on ``||b_i - (R a_i + t)||`` (same unit).
        cbar2: TLS truncation (squared, in units of the bound); 1 as in TEASER++.
        gnc_factor, max_iterations, cost_threshold: GNC-TLS schedule.
        clique_node_budget, clique_time_budget_s: the max-clique search's node cap and seconds
            (None: no limit); past either, the best clique so far is used.

    Raises:
        InvalidInputError: a max clique smaller than :data:`MIN_CLIQUE_SIZE`: no pose.
    """
    import time

    src, dst = checked_inputs(src, dst, noise_bound)
    timings: dict[str, float] = {}
    if len(src) < MIN_CLIQUE_SIZE:
        raise InvalidInputError(
            f"TEASER got {len(src)} correspondences; a max clique of {MIN_CLIQUE_SIZE} or more is needed "
            "(TEASER++ gives no pose under it)"
        )

    t0 = time.perf_counter()
    from catpose.methods.max_clique import max_clique  # numba loads here, so `bench --help` stays instant

    adj = consistency_graph(src, dst, noise_bound)
    clique, exact = max_clique(adj, clique_node_budget, clique_time_budget_s)
    timings["clique_s"] = time.perf_counter() - t0
    if len(clique) < MIN_CLIQUE_SIZE:
        raise InvalidInputError(
            f"TEASER max clique has {len(clique)} of {len(src)} correspondences: no pose under "
            f"{MIN_CLIQUE_SIZE}, as TEASER++ (registration.cc, RobustRegistrationSolver::solve)"
        )

    t0 = time.perf_counter()
    i = np.arange(len(clique))  # the cyclic chain k -> k + 1 (one pair for a clique of 2)
    j = np.roll(i, -1)
    if len(clique) == 2:
        i, j = i[:1], j[:1]
    a, b = src[clique], dst[clique]
    R, w, iters, degenerate = gnc_tls_rotation(
        a[j] - a[i], b[j] - b[i], 2.0 * noise_bound, cbar2, gnc_factor, max_iterations, cost_threshold
    )
    timings["rotation_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    t_meas = b - apply_R(R, a)
    t = np.zeros(3)
    voted = np.ones(len(clique), dtype=bool)
    for axis in range(3):
        t[axis], mask = adaptive_voting(t_meas[:, axis], noise_bound * np.sqrt(cbar2))
        voted &= mask
    timings["translation_s"] = time.perf_counter() - t0
    return SolverResult(R, t, clique, exact, w > 0.5, clique[voted], iters, timings, bool(degenerate))
