"""TEASER++ itself (MIT-SPARK/TEASER-plusplus) through ``teaserpp_python``, when installed.

No wheel of ``teaserpp_python`` exists for Python 3.11; constructing this method without it
raises :class:`~catpose.errors.ConfigError` saying how to get it. ``method=teaser`` is the
NumPy re-implementation (:mod:`catpose.methods.teaser_solver`) on the same pipeline.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from catpose.errors import ConfigError
from catpose.methods.correspondence import MatchInput
from catpose.methods.teaser import TEASER


class TEASERPlusPlus(TEASER):
    """The same pipeline and arguments as :class:`~catpose.methods.teaser.TEASER`, solved by
    ``teaserpp_python.RobustRegistrationSolver`` (scale fixed, exact max clique, GNC-TLS)."""

    def __init__(self, **kwargs: Any) -> None:
        try:
            import teaserpp_python  # noqa: F401
        except ImportError:
            raise ConfigError("method=teaserpp needs teaserpp_python: build TEASER++ with its Python bindings "
                              "from source (github.com/MIT-SPARK/TEASER-plusplus, Python <= 3.10) "
                              "or use method=teaser") from None
        super().__init__(**kwargs)

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        import teaserpp_python

        corr = match.fpfh_correspondences(self.mutual_filter, self.max_correspondences)
        if len(corr) < 3:
            return None, {"num_correspondences": int(len(corr))}
        params = teaserpp_python.RobustRegistrationSolver.Params()
        params.cbar2 = self.cbar2
        params.noise_bound = self.noise_bound
        params.estimate_scaling = False
        params.rotation_estimation_algorithm = (
            teaserpp_python.RobustRegistrationSolver.ROTATION_ESTIMATION_ALGORITHM.GNC_TLS)
        params.rotation_gnc_factor = self.gnc_factor
        params.rotation_max_iterations = self.max_iterations
        params.rotation_cost_threshold = self.cost_threshold
        graphs = teaserpp_python.RobustRegistrationSolver.INLIER_GRAPH_FORMULATION
        params.rotation_tim_graph = graphs.CHAIN if self.rotation_tim_graph == "chain" else graphs.COMPLETE
        params.inlier_selection_mode = teaserpp_python.RobustRegistrationSolver.INLIER_SELECTION_MODE.PMC_EXACT
        solver = teaserpp_python.RobustRegistrationSolver(params)
        solver.solve(np.ascontiguousarray(match.source.points[corr[:, 0]].T),
                     np.ascontiguousarray(match.target.points[corr[:, 1]].T))
        sol = solver.getSolution()
        T = np.eye(4)
        T[:3, :3] = np.asarray(sol.rotation)
        T[:3, 3] = np.asarray(sol.translation).reshape(3)
        return T, {"num_correspondences": int(len(corr)),
                   "clique_size": int(len(solver.getInlierMaxClique()))}
