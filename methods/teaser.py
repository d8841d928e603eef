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

from catpose.errors import ConfigError, InvalidInputError
from catpose.methods import teaser_solver
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
        if not noise_bound > 0:
            raise ConfigError(f"teaser noise_bound={noise_bound} must be > 0 (object-normalised units, e.g. 0.05)")
        if not cbar2 > 0 or not gnc_factor > 1 or max_iterations < 1:
            raise ConfigError(
                f"teaser cbar2={cbar2} (> 0), gnc_factor={gnc_factor} (> 1), "
                f"max_iterations={max_iterations} (>= 1) out of range"
            )
        if not clique_time_budget_s >= 0:
            raise ConfigError(
                f"teaser clique_time_budget_s={clique_time_budget_s} must be >= 0 (seconds; 0 = no limit)"
            )
        if max_correspondences < 0 or clique_node_budget < 1:
            raise ConfigError(
                f"teaser max_correspondences={max_correspondences} (>= 0) or "
                f"clique_node_budget={clique_node_budget} (>= 1) out of range"
            )
        if rotation_tim_graph not in ("chain", "complete"):
            raise ConfigError(f"teaser rotation_tim_graph={rotation_tim_graph!r} is unknown; use 'chain' or 'complete'")
        self.rotation_tim_graph = str(rotation_tim_graph)
        self.noise_bound = float(noise_bound)
        self.cbar2 = float(cbar2)
        self.gnc_factor = float(gnc_factor)
        self.max_iterations = int(max_iterations)
        self.cost_threshold = float(cost_threshold)
        self.mutual_filter = bool(mutual_filter)
        self.max_correspondences = int(max_correspondences)
        self.clique_node_budget = int(clique_node_budget)
        self.clique_time_budget_s = float(clique_time_budget_s)

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        corr = match.fpfh_correspondences(self.mutual_filter, self.max_correspondences)
        if len(corr) < MIN_CLIQUE_SIZE:
            return None, {"num_correspondences": int(len(corr)), "clique_size": 0, "no_pose_reason": no_pose(len(corr))}
        try:
            r = teaser_solver.solve(
                match.source.points[corr[:, 0]],
                match.target.points[corr[:, 1]],
                self.noise_bound,
                self.cbar2,
                self.gnc_factor,
                self.max_iterations,
                self.cost_threshold,
                self.clique_node_budget,
                self.rotation_tim_graph,
                seed=match.seed,
                clique_time_budget_s=self.clique_time_budget_s or None,
            )
        except InvalidInputError as e:  # a degenerate clique: this target gives no pose (others may)
            return None, {"num_correspondences": int(len(corr)), "clique_size": 0, "no_pose_reason": str(e)}
        info = {
            "num_correspondences": int(len(corr)),
            "clique_size": int(len(r.clique)),
            "clique_exact": r.clique_exact,
            "translation_inliers": int(len(r.translation_inliers)),
            "gnc_iterations": r.gnc_iterations,
            "rotation_degenerate": r.rotation_degenerate,
            **{f"teaser_{k}": v for k, v in r.timings.items()},
        }
        return r.T, info


def no_pose(num_correspondences: int) -> str:
    """Why a target with ``num_correspondences`` (fewer than :data:`MIN_CLIQUE_SIZE`) gives no pose."""
    return (
        f"TEASER got {num_correspondences} correspondences: no pose under a max clique of {MIN_CLIQUE_SIZE}, "
        "as TEASER++ (registration.cc, RobustRegistrationSolver::solve)"
    )
