"""TEASER baseline on the shared matching pipeline, solved by :mod:`catpose.methods.teaser_solver`.

Correspondences: mutual FPFH nearest neighbours (``features="fpfh"``, as in TEASER++'s examples)
or the top-1 LPS keypoint pairs (``features="lps"``). ``noise_bound`` is the inlier bound in
object-normalised units (on the order of the voxel size).

No pose is given only where TEASER++ gives none: a max clique of 0 or 1 correspondences
(``teaser::RobustRegistrationSolver::solve``, teaser/src/registration.cc: "Clique size too small.
Abort." when ``max_clique_.size() <= 1``; :data:`catpose.methods.teaser_solver.MIN_CLIQUE_SIZE`).
Cliques of 2 or 3 are solved as TEASER++ solves them, ``rotation_degenerate`` in the details
saying when their rotation is not fixed by the data. A target without a pose gives no candidate;
a sample none of whose targets gives one is recorded as failed, its error naming the clique.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from catpose.errors import InvalidInputError
from catpose.methods import options, teaser_solver
from catpose.methods.correspondence import PIPELINE_SPEC, CorrespondenceRegistration, MatchInput, suite
from catpose.methods.registry import register_method
from catpose.methods.teaser_solver import MIN_CLIQUE_SIZE


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
        rotation_tim_graph: ``"chain"`` (TEASER++'s default) or ``"complete"`` TIMs for GNC-TLS.
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
        rotation_tim_graph: str = "chain",
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
        self.rotation_tim_graph = options.one_of("method.rotation_tim_graph", rotation_tim_graph, ("chain", "complete"))
        self.clique_time_budget_s = options.non_negative("method.clique_time_budget_s", clique_time_budget_s)

    #: the solver's name in the details' timings (``teaser_<stage>``)
    solver_name = "teaser"

    def _solve(self, src: np.ndarray, dst: np.ndarray, seed: int) -> teaser_solver.SolverResult:
        """``dst ~ R src + t`` by the re-implementation (:func:`catpose.methods.teaser_solver.solve`)."""
        return teaser_solver.solve(
            src,
            dst,
            self.noise_bound,
            self.cbar2,
            self.gnc_factor,
            self.max_iterations,
            self.cost_threshold,
            self.clique_node_budget,
            self.rotation_tim_graph,
            seed=seed,
            clique_time_budget_s=self.clique_time_budget_s or None,
        )

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        corr = match.fpfh_correspondences(self.mutual_filter, self.max_correspondences)
        if len(corr) < MIN_CLIQUE_SIZE:
            return None, {"num_correspondences": int(len(corr)), "clique_size": 0, "no_pose_reason": no_pose(len(corr))}
        try:
            r = self._solve(match.source.points[corr[:, 0]], match.target.points[corr[:, 1]], match.seed)
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


def no_pose(num_correspondences: int) -> str:
    """Why a target with ``num_correspondences`` (fewer than :data:`MIN_CLIQUE_SIZE`) gives no pose."""
    return (
        f"TEASER got {num_correspondences} correspondences: no pose under a max clique of {MIN_CLIQUE_SIZE}, "
        "as TEASER++ (registration.cc, RobustRegistrationSolver::solve)"
    )
