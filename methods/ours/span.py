"""The object's depth span: which of the observation's pixels and points can be the object's.

A segmenter's mask bleeds onto whatever lies beside the object in the image. Where that is a
background metres behind (issue 58's real YCB-Video masks: over 5 % of a tuna can's pixels 1.2 m
behind it), those pixels move every mean of the observation (the coarse search's translation start
is the points' centroid: 5 % of the points 40 object units behind move it two radii) and count as
unexplained in the depth check's poor-fit test, which then hands the choice to the Chamfer rule.
No point of the object lies further from another than the template's diameter, 2 in the
object-normalised unit, so none further in depth than that from the mask's median depth. Ours
reads its points within that span (:func:`observed_points`) and so does the poor-fit test
(:meth:`~catpose.methods.ours.check.DepthVerifier.fit`); the depth check's costs need no cut, since
a pixel that far costs every pose the same. Nothing is tuned: ``experiments/far_bleed``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from catpose.types import DepthImage, RegistrationProblem

__all__ = ["REACH", "in_span", "median_depth", "observed_points"]

#: the template's diameter (object-normalised unit): the farthest an object's point lies in depth
#: from the mask's median depth
REACH = 2.0


def median_depth(image: DepthImage) -> float:
    """The median depth of the mask's measured pixels."""
    return float(np.median(image.depth[image.mask & (image.depth > 0)]))


def in_span(depth: np.ndarray, z: float) -> np.ndarray:
    """Bool of the shape of ``depth``: within :data:`REACH` of the median depth ``z``."""
    return np.abs(np.asarray(depth) - z) <= REACH


def observed_points(problem: RegistrationProblem) -> tuple[RegistrationProblem, int]:
    """``problem`` (with a depth image) without its points beyond the object's depth span, and how
    many went; ``problem`` itself when none did."""
    keep = in_span(problem.points_camera[:, 2], median_depth(problem.depth_image))
    n_far = int(len(keep) - keep.sum())
    if n_far == 0:
        return problem, 0
    return replace(
        problem, points_camera=problem.points_camera[keep], normals_camera=problem.normals_camera[keep]
    ), n_far
