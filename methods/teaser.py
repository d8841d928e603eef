"""TEASER on the shared matching pipeline: ``method=teaser`` solved by the re-implementation
(:mod:`catpose.methods.teaser_solver`), ``method=teaserpp`` by TEASER++ itself through its Python
bindings ``teaserpp_python`` (MIT-SPARK/TEASER-plusplus; catpose does not build or ship it).

Correspondences: mutual FPFH nearest neighbours (``features="fpfh"``, as in TEASER++'s examples)
or the top-1 LPS keypoint pairs (``features="lps"``). ``noise_bound`` is the inlier bound in
object-normalised units (on the order of the voxel size); both solvers use ``2 noise_bound
sqrt(cbar2)`` for pairwise consistency and ``2 noise_bound`` as the rotation (TIM) bound.

No pose is given only where TEASER++ gives none: a max clique of 0 or 1 correspondences
(:data:`catpose.methods.teaser_solver.MIN_CLIQUE_SIZE`). Cliques of 2 or 3 are solved as TEASER++
solves them, ``rotation_degenerate`` in the details saying when their rotation is not fixed by the
data. A target without a pose gives no candidate; a sample none of whose targets gives one is
recorded as failed, its error naming the clique.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from catpose.errors import ConfigError, InvalidInputError
from catpose.methods import options, teaser_solver
from catpose.methods.correspondence import PIPELINE_SPEC, CorrespondenceRegistration, MatchInput, suite
from catpose.methods.registry import register_method
from catpose.methods.teaser_solver import MIN_CLIQUE_SIZE, SolverResult, checked_inputs


@register_method("teaser", "TEASER (re-impl.)", suite=suite("teaser", 4), **PIPELINE_SPEC)
class TEASER(CorrespondenceRegistration):
    """TEASER-style robust registration (max clique + GNC-TLS rotation + adaptive voting).

    Args:
        noise_bound: inlier noise bound ``beta`` (object-normalised, > 0).
        cbar2: TLS truncation (1 as in TEASER++).
        gnc_factor: GNC ``mu`` growth per iteration (> 1).
        max_iterations: GNC iterations cap.
        cost_threshold: GNC stops when the cost changes by less than this.
        mutual_filter: keep only mutual FPFH nearest neighbours (fpfh only).
        max_correspondences: keep at most this many FPFH pairs (most similar first; 0 = all).
        clique_node_budget: branch-and-bound node cap of the max-clique search.
        clique_time_budget_s: seconds the max-clique search may take (0 = no limit); past either
            budget the best clique so far is used (``clique_exact`` False in the details).
        **pipeline: :class:`CorrespondenceRegistration` arguments (matching, features, ...).
    """

    def __init__(
        self,
        noise_bound: float = 0.05,
        cbar2: float = 1.0,
        gnc_factor: float = 1.4,
        max_iterations: int = 100,
        cost_threshold: float = 1e-6,
        mutual_filter: bool = True,
        max_correspondences: int = 1000,
        clique_node_budget: int = 200_000,
        clique_time_budget_s: float = 10.0,
        **pipeline: Any,
    ) -> None:
        super().__init__(**pipeline)
        self.noise_bound = options.positive("method.noise_bound", noise_bound)
        self.cbar2 = options.positive("method.cbar2", cbar2)
        self.gnc_factor = options.within("method.gnc_factor", gnc_factor, 1)
        self.max_iterations = options.positive("method.max_iterations", max_iterations, integer=True)
        self.cost_threshold = options.non_negative("method.cost_threshold", cost_threshold)
        self.mutual_filter = options.flag("method.mutual_filter", mutual_filter)
        self.max_correspondences = options.non_negative("method.max_correspondences", max_correspondences, integer=True)
        self.clique_node_budget = options.positive("method.clique_node_budget", clique_node_budget, integer=True)
        self.clique_time_budget_s = options.non_negative("method.clique_time_budget_s", clique_time_budget_s)

    #: the solver's name in the details' timings (``teaser_<stage>``)
    solver_name = "teaser"

    def _solve(self, src: np.ndarray, dst: np.ndarray) -> SolverResult:
        """``dst ~ R src + t`` by the re-implementation (:func:`catpose.methods.teaser_solver.solve`)."""
        settings = (self.noise_bound, self.cbar2, self.gnc_factor, self.max_iterations, self.cost_threshold)
        return teaser_solver.solve(src, dst, *settings, self.clique_node_budget, self.clique_time_budget_s or None)

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        corr = match.fpfh_correspondences(self.mutual_filter, self.max_correspondences)
        try:
            if len(corr) < MIN_CLIQUE_SIZE:  # TEASER++ is not called: its solution would be invalid
                raise InvalidInputError(
                    f"TEASER got {len(corr)} correspondences: no pose under a max clique of {MIN_CLIQUE_SIZE}, "
                    "as TEASER++ (registration.cc, RobustRegistrationSolver::solve)"
                )
            r = self._solve(match.source.points[corr[:, 0]], match.target.points[corr[:, 1]])
        except InvalidInputError as e:  # a degenerate clique: this target gives no pose (others may)
            return None, {"num_correspondences": int(len(corr)), "clique_size": 0, "no_pose_reason": str(e)}
        info = {
            "num_correspondences": int(len(corr)),
            "clique_size": int(len(np.unique(r.clique))),  # PMC's exact solver (TEASER++) may list a vertex twice
            "clique_exact": r.clique_exact,
            "translation_inliers": int(len(r.translation_inliers)),
            "gnc_iterations": r.gnc_iterations,
            "rotation_degenerate": r.rotation_degenerate,
            **{f"{self.solver_name}_{k}": v for k, v in r.timings.items()},
        }
        return r.T, info


_MISSING = (
    "method=teaserpp needs the teaserpp_python module (TEASER++'s Python bindings), which is not "
    "importable: build and install it into this environment as TEASER++'s own README says "
    "(github.com/MIT-SPARK/TEASER-plusplus, 'Minimal Python 3 example'; it builds on Python 3.11 too), "
    "or use method=teaser"
)


def _import_teaserpp():
    try:
        import teaserpp_python
    except ImportError:
        raise ConfigError(_MISSING) from None
    return teaserpp_python


@contextlib.contextmanager
def _stdout_silenced() -> Iterator[None]:
    """File descriptor 1 to /dev/null: TEASER++ built with TEASER_DIAG_PRINT writes its progress
    to the C++ stdout, which would interleave with the runner's output."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def solve_teaserpp(
    src: np.ndarray,
    dst: np.ndarray,
    noise_bound: float,
    cbar2: float = 1.0,
    gnc_factor: float = 1.4,
    max_iterations: int = 100,
    cost_threshold: float = 1e-6,
    min_clique_size: int = MIN_CLIQUE_SIZE,
) -> SolverResult:
    """``dst ~ R src + t`` by TEASER++ (scale fixed, exact max clique ``PMC_EXACT``, GNC-TLS rotation
    on the chain TIM graph), with the arguments of :func:`catpose.methods.teaser_solver.solve`.

    ``cost_threshold`` is unit-free there (a change of the GNC cost in units of ``cbar2 (2
    noise_bound)^2``); TEASER++ compares the absolute change, so it gets ``cost_threshold * cbar2 *
    (2 noise_bound)^2`` (unconverted, 1e-6 lets TEASER++ stop while the GNC weights are still
    fractional on object-normalised points).

    Args:
        src, dst: (N, 3) row-matched points (object-normalised).
        noise_bound: inlier bound ``beta`` (same unit).
        min_clique_size: a max clique smaller than this raises :class:`InvalidInputError`, as a
            clique of 0 or 1 leaves TEASER++'s solution invalid (0: TEASER++'s raw output).

    Returns:
        :class:`~catpose.methods.teaser_solver.SolverResult`; ``gnc_iterations`` is -1 (TEASER++
        does not report it), ``timings["solve_s"]`` the wall time of TEASER++'s ``solve``.
    """
    tpp = _import_teaserpp()
    src, dst = checked_inputs(src, dst, noise_bound, "TEASER++")
    Solver = tpp.RobustRegistrationSolver
    params = Solver.Params()
    params.noise_bound = float(noise_bound)
    params.cbar2 = float(cbar2)
    params.estimate_scaling = False
    params.rotation_estimation_algorithm = Solver.ROTATION_ESTIMATION_ALGORITHM.GNC_TLS
    params.rotation_gnc_factor = float(gnc_factor)
    params.rotation_max_iterations = int(max_iterations)
    params.rotation_cost_threshold = float(cost_threshold) * float(cbar2) * (2.0 * float(noise_bound)) ** 2
    params.rotation_tim_graph = Solver.INLIER_GRAPH_FORMULATION.CHAIN
    params.inlier_selection_mode = Solver.INLIER_SELECTION_MODE.PMC_EXACT
    solver = Solver(params)
    with _stdout_silenced():
        t0 = time.perf_counter()
        solver.solve(np.ascontiguousarray(src.T), np.ascontiguousarray(dst.T))
        solve_s = time.perf_counter() - t0
    clique = np.sort(np.asarray(solver.getInlierMaxClique(), dtype=np.int64))  # as returned (may repeat)
    sol = solver.getSolution()
    if len(np.unique(clique)) < min_clique_size or (min_clique_size and not sol.valid):
        raise InvalidInputError(
            f"TEASER++ max clique has {len(np.unique(clique))} of {len(src)} correspondences: degenerate, "
            f"no valid solution under {min_clique_size} (registration.cc, RobustRegistrationSolver::solve)"
        )
    translation_inliers = np.asarray(solver.getTranslationInliers(), dtype=np.int64)
    return SolverResult(
        R=np.asarray(sol.rotation, dtype=np.float64).reshape(3, 3),
        t=np.asarray(sol.translation, dtype=np.float64).reshape(3),
        clique=clique,
        clique_exact=True,
        rotation_inliers=np.asarray(solver.getRotationInliersMask(), dtype=bool).reshape(-1),
        translation_inliers=clique[translation_inliers[translation_inliers < len(clique)]],
        gnc_iterations=-1,
        timings={"solve_s": solve_s},
    )


# not in bench suite: TEASER++ is built by hand (method=teaser is its re-implementation there)
@register_method("teaserpp", "Teaser++", suite=(), requires="teaserpp_python", **PIPELINE_SPEC)
class TEASERPlusPlus(TEASER):
    """:class:`TEASER`'s pipeline and arguments, solved by TEASER++ (:func:`solve_teaserpp`; its
    exact max clique search draws no random numbers)."""

    solver_name = "teaserpp"

    def __init__(self, **kwargs: Any) -> None:
        _import_teaserpp()  # how to build TEASER++ when it is absent, before any sample runs
        super().__init__(**kwargs)

    def _solve(self, src: np.ndarray, dst: np.ndarray) -> SolverResult:
        return solve_teaserpp(
            src, dst, self.noise_bound, self.cbar2, self.gnc_factor, self.max_iterations, self.cost_threshold
        )
