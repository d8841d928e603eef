"""RANSAC registration through Open3D (feature matching or given correspondences).

``features="fpfh"``: ``registration_ransac_based_on_feature_matching`` on FPFH features;
``features="lps"``: ``registration_ransac_based_on_correspondence`` on the top-1 LPS pairs.
Hypotheses are pruned by the edge-length and distance checkers (and optionally the normal
checker) before the full inlier count. Open3D's RANSAC draws from its global generator, which
the pipeline seeds per (sample, candidate) with ``o3d.utility.random.seed`` before every call.
Its TBB worker threads share that generator and an early-termination counter, so the result
depends on thread timing unless Open3D runs on one thread: ``num_threads=1`` (the default,
:func:`catpose.o3d.max_threads` for the call) makes runs reproducible.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from catpose.methods import options
from catpose.methods.correspondence import PIPELINE_SPEC, CorrespondenceRegistration, MatchInput, suite
from catpose.methods.registry import register_method


@register_method(
    "ransac",
    "RANSAC",
    suite=suite("ransac", 5),
    **{**PIPELINE_SPEC, "smoke_options": {**PIPELINE_SPEC["smoke_options"], "max_iteration": 20000}},
)
class RANSAC(CorrespondenceRegistration):
    """RANSAC baseline.

    Args:
        max_correspondence_distance: inlier distance (object-normalised; e.g. 1.5 x voxel_size).
        mutual_filter: keep only mutual FPFH nearest neighbours (fpfh only).
        ransac_n: points per hypothesis (>= 3).
        edge_length_similarity: ``CorrespondenceCheckerBasedOnEdgeLength`` threshold in (0, 1).
        normal_angle_deg: ``CorrespondenceCheckerBasedOnNormal`` angle; 0 disables it.
        max_iteration: ``RANSACConvergenceCriteria.max_iteration``.
        confidence: ``RANSACConvergenceCriteria.confidence`` in (0, 1].
        num_threads: Open3D threads during the call; 1 is deterministic, 0 keeps Open3D's
            default (faster, not reproducible).
        **pipeline: :class:`CorrespondenceRegistration` arguments (matching, features, ...).
    """

    def __init__(
        self,
        max_correspondence_distance: float = 0.075,
        mutual_filter: bool = True,
        ransac_n: int = 3,
        edge_length_similarity: float = 0.9,
        normal_angle_deg: float = 0.0,
        max_iteration: int = 100000,
        confidence: float = 0.999,
        num_threads: int = 1,
        **pipeline: Any,
    ) -> None:
        super().__init__(**pipeline)
        self.max_correspondence_distance = options.positive(
            "method.max_correspondence_distance", max_correspondence_distance
        )
        self.mutual_filter = options.flag("method.mutual_filter", mutual_filter)
        self.ransac_n = options.at_least("method.ransac_n", ransac_n, 3)
        self.edge_length_similarity = options.within("method.edge_length_similarity", edge_length_similarity, 0, 1)
        self.normal_angle_deg = options.within("method.normal_angle_deg", normal_angle_deg, 0, 180, closed="low")
        self.max_iteration = options.positive("method.max_iteration", max_iteration, integer=True)
        self.confidence = options.within("method.confidence", confidence, 0, 1, closed="high")
        self.num_threads = options.non_negative("method.num_threads", num_threads, integer=True)

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        from catpose.o3d import max_threads, o3d

        reg = o3d.pipelines.registration
        checkers = [
            reg.CorrespondenceCheckerBasedOnEdgeLength(self.edge_length_similarity),
            reg.CorrespondenceCheckerBasedOnDistance(self.max_correspondence_distance),
        ]
        if self.normal_angle_deg > 0:
            checkers.append(reg.CorrespondenceCheckerBasedOnNormal(np.deg2rad(self.normal_angle_deg)))
        criteria = reg.RANSACConvergenceCriteria(self.max_iteration, self.confidence)
        estimation = reg.TransformationEstimationPointToPoint(False)
        clouds = (match.source.pcd, match.target.pcd)
        solver = (self.max_correspondence_distance, estimation, self.ransac_n, checkers, criteria)
        with max_threads(self.num_threads or None):
            if match.correspondences is None:
                features = (match.source.feature, match.target.feature, self.mutual_filter)
                result = reg.registration_ransac_based_on_feature_matching(*clouds, *features, *solver)
            else:
                pairs = o3d.utility.Vector2iVector(match.correspondences)
                result = reg.registration_ransac_based_on_correspondence(*clouds, pairs, *solver)
        info = {
            "num_inliers": int(len(result.correspondence_set)),
            "fitness": float(result.fitness),
            "inlier_rmse": float(result.inlier_rmse),
        }
        return np.asarray(result.transformation).copy(), info
