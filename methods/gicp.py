"""Generalized ICP (Segal, Haehnel, Thrun, RSS 2009) through Open3D, from ICP's starts.

Generalized ICP models each point as a Gaussian whose covariance is flat along its local surface
(plane-to-plane), which is the default of the small_gicp anchor; Open3D's
``registration_generalized_icp`` estimates the covariances from each cloud's 20 nearest
neighbours. Like :class:`~catpose.methods.icp.ICP` it converges to the nearest local minimum, so it
runs from the same starts (one rotation per cell of a partition of SO(3)) and the same
coarse-to-fine distances, and the start with the highest fitness, then the lowest RMSE, wins.
"""

from __future__ import annotations

from typing import Any

from catpose.methods import options
from catpose.methods.icp import ICP
from catpose.methods.registry import register_method


@register_method("gicp", "GICP")
class GICP(ICP):
    """Multi-start generalized ICP.

    Args:
        epsilon: the covariances' regulariser, the variance across a point's local plane relative
            to along it (Open3D's ``TransformationEstimationForGeneralizedICP`` default 1e-3).
        **icp: :class:`~catpose.methods.icp.ICP`'s arguments (starts, voxel, distances, iterations,
            threads).
    """

    def __init__(self, epsilon: float = 1e-3, **icp: Any) -> None:
        super().__init__(**icp)
        self.epsilon = options.positive("method.epsilon", epsilon)

    def _variant(self, reg: Any) -> tuple[Any, Any]:
        return reg.registration_generalized_icp, reg.TransformationEstimationForGeneralizedICP(self.epsilon)
