"""Hypotheses from the dictionary, ours' first stage (paper Section III-A to C): one candidate pose
per partial template.

1. Dictionary: ``m`` partial templates of the template laid out by a
   :class:`~catpose.methods.dictionary.DictionaryLayout` (default 18 views, 3 elevation rings
   0/30/60 deg x 6 azimuths, hidden point removal), cached.
2. Both the input and every partial template are voxel-downsampled with the descriptor's
   ``voxel_size`` so that their local point densities (which descriptors see) match.
3. Keypoints by farthest point sampling (start index 0): ``n`` on the input, ``2n`` on each
   partial (:mod:`catpose.methods.keypoints`).
4. Descriptors and affinity ``A`` (m, n, 2n) from the injected
   :class:`~catpose.methods.descriptors.Descriptor` (LPS, the default, or PFH); rows normalised
   to sum to 1. Template-side keypoints and descriptors are computed once per template and cached.
5. Initial pose per partial: soft targets ``A P_t`` and Kabsch/SVD with the reflection fix; the
   solver (:mod:`catpose.methods.ours.solver`) takes it from there.
"""

from __future__ import annotations

import time

import numpy as np

from catpose import cell_grid
from catpose.errors import InvalidInputError
from catpose.kabsch import kabsch
from catpose.methods.descriptors import Descriptor
from catpose.methods.dictionary import DictionaryLayout
from catpose.methods.dictionary_features import dictionary_features
from catpose.methods.keypoints import farthest_point_indices, too_few_points
from catpose.methods.ours.candidates import Prepared, TemplateFeatures
from catpose.methods.ours.point_choice import VISIBILITY_TRUNC
from catpose.methods.ours.refine import REFINE_MAX_DISTANCE
from catpose.types import RegistrationProblem, Template

__all__ = ["CHAMFER_POINTS", "input_features", "prepare", "template_features"]

#: input / template points (farthest-point subsets) of the Chamfer distances: the selection's and
#: the search's scores and the refinement of many poses (docs/choosing-defaults.md: the embedded set)
CHAMFER_POINTS = 256
#: the Chamfer distances' grid answers nearer points (object-normalised unit), the KD-tree the rest
CHAMFER_REACH = 0.3


def template_features(descriptor: Descriptor, layout: DictionaryLayout, template: Template) -> TemplateFeatures:
    """Keypoints and descriptors of every partial template of ``template`` (the dictionary's cache,
    shared with the correspondence baselines) and the searches over its complete points."""
    from scipy.spatial import cKDTree

    # a tiny partial repeats keypoints (padded) so all candidates batch together
    shared = dictionary_features(descriptor, layout, template, 2 * layout.num_keypoints)
    complete = template.points[farthest_point_indices(template.points, CHAMFER_POINTS)]
    return TemplateFeatures(
        shared.keypoints,
        shared.stacked,
        complete,
        cell_grid.build(template.points, REFINE_MAX_DISTANCE, cell_grid.CACHED_CELLS_PER_REACH),
        cell_grid.build(template.points, max(VISIBILITY_TRUNC, CHAMFER_REACH), cell_grid.CACHED_CELLS_PER_REACH),
        cKDTree(template.points),
    )


def input_features(descriptor: Descriptor, num_keypoints: int, problem: RegistrationProblem):
    """The input's ``num_keypoints`` keypoints and their descriptors (independent of the template);
    an :class:`~catpose.errors.InvalidInputError` when fewer than 3 points survive downsampling."""
    inp = descriptor.keypoint_features(
        problem.points_camera, problem.normals_camera, num_keypoints, problem.ground_normal_camera
    )
    if len(inp.indices) < 3:
        n, voxel = len(inp.indices), descriptor.voxel_size
        raise InvalidInputError(too_few_points(problem.sample_id, n, problem.points_camera, voxel))
    return inp


def prepare(descriptor: Descriptor, feats: TemplateFeatures, inp, timings: dict[str, float]) -> Prepared:
    """Steps 4-5 of the module docstring: affinities of the input's features ``inp`` against every
    partial of ``feats`` and the SVD pose of each."""
    t0 = time.perf_counter()
    A = descriptor.batched_affinity(inp.features, feats.stacked)  # (m, n, 2n)
    A = np.maximum(A, 0.0) + 1e-12
    A /= A.sum(axis=2, keepdims=True)
    timings["affinity"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    P_c, P_t = inp.keypoints, feats.keypoints  # (n, 3), (m, 2n, 3)
    T0 = kabsch(np.broadcast_to(P_c, (len(P_t),) + P_c.shape), A @ P_t)
    chamfer_src = inp.points[farthest_point_indices(inp.points, CHAMFER_POINTS)]
    timings["initial_pose"] = time.perf_counter() - t0
    return Prepared(feats, inp.points, P_c, P_t, A, T0, chamfer_src)
