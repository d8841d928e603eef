"""Fast Global Registration (Zhou, Park, Koltun, ECCV 2016) through Open3D.

``features="fpfh"`` calls ``registration_fgr_based_on_feature_matching`` on the FPFH features
of the voxel-downsampled clouds; ``features="lps"`` calls
``registration_fgr_based_on_correspondence`` on the top-1 LPS keypoint pairs. The matching
pipeline (direct / dictionary, ICP refinement, selection) is
:class:`catpose.methods.correspondence.CorrespondenceRegistration`.

Open3D's Python ``FastGlobalRegistrationOption()`` defaults ``decrease_mu=False`` while its C++
default (and the paper's algorithm, graduated non-convexity) is ``True``, so every option is
passed explicitly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from catpose.methods import options
from catpose.methods.correspondence import PIPELINE_SPEC, CorrespondenceRegistration, MatchInput, suite
from catpose.methods.registry import register_method


@register_method("fgr", "FGR", suite=suite("fgr", 3), **PIPELINE_SPEC)
class FGR(CorrespondenceRegistration):
    """FGR baseline.

    Args:
        division_factor: GNC step (mu is divided by it every 4 iterations when ``decrease_mu``).
        decrease_mu: graduated non-convexity on (Open3D C++ default True).
        maximum_correspondence_distance: final Geman-McClure scale ``mu`` (object-normalised).
        iteration_number: number of FGR iterations.
        tuple_scale: tuple test similarity threshold in (0, 1).
        maximum_tuple_count: cap on tuples kept by the tuple test.
        tuple_test: enable the tuple (edge-length) test.
        **pipeline: :class:`CorrespondenceRegistration` arguments (matching, features, ...).
    """

    def __init__(
        self,
        division_factor: float = 1.4,
        decrease_mu: bool = True,
        maximum_correspondence_distance: float = 0.025,
        iteration_number: int = 64,
        tuple_scale: float = 0.95,
        maximum_tuple_count: int = 1000,
        tuple_test: bool = True,
        **pipeline: Any,
    ) -> None:
        super().__init__(**pipeline)
        self.option_kwargs = dict(
            division_factor=options.within("method.division_factor", division_factor, 1),
            use_absolute_scale=False,
            decrease_mu=options.flag("method.decrease_mu", decrease_mu),
            maximum_correspondence_distance=options.positive(
                "method.maximum_correspondence_distance", maximum_correspondence_distance
            ),
            iteration_number=options.positive("method.iteration_number", iteration_number, integer=True),
            tuple_scale=options.within("method.tuple_scale", tuple_scale, 0, 1),
            maximum_tuple_count=options.positive("method.maximum_tuple_count", maximum_tuple_count, integer=True),
            tuple_test=options.flag("method.tuple_test", tuple_test),
        )

    def _estimate(self, match: MatchInput) -> tuple[np.ndarray, dict[str, Any]]:
        from catpose.o3d import o3d

        reg = o3d.pipelines.registration
        option = reg.FastGlobalRegistrationOption(**self.option_kwargs)
        clouds = (match.source.pcd, match.target.pcd)
        if match.correspondences is None:
            features = (match.source.feature, match.target.feature)
            result = reg.registration_fgr_based_on_feature_matching(*clouds, *features, option)
            n = len(match.source.points)
        else:
            pairs = o3d.utility.Vector2iVector(match.correspondences)
            result = reg.registration_fgr_based_on_correspondence(*clouds, pairs, option)
            n = len(match.correspondences)
        return np.asarray(result.transformation).copy(), {"num_correspondences": int(n)}
