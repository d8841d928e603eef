"""What ``ours`` (:class:`~catpose.methods.ours.Ours`) computes on the way to its answer: the
per-template features it caches, one problem's prepared inputs, and every candidate pose of one
problem (the result of :meth:`~catpose.methods.ours.Ours.candidates`).

Shapes: ``m`` partial templates (candidates), ``n`` input keypoints, ``2n`` keypoints per partial;
lengths in the object-normalised unit, poses ``T_template_camera`` (4, 4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose.cell_grid import CellGrid

__all__ = ["Candidates", "Prepared", "TemplateFeatures"]


@dataclass(frozen=True, eq=False)
class TemplateFeatures:
    """Constant per (template, parameters): keypoints (m, 2n, 3) and per-partial descriptors (the
    cache shared with the correspondence baselines, :mod:`catpose.methods.dictionary_features`),
    and what the selection searches."""

    keypoints: np.ndarray
    stacked: object  # the partials' descriptors, stacked for one batched affinity
    complete_points: np.ndarray  # (M', 3) FPS subset of the complete template for Chamfer terms
    pairing: CellGrid  # the full template points, searched within the refinement's pairing distance
    truncated: CellGrid  # the same: the visibility score's truncation, the Chamfer distances' nearer points
    tree: object  # cKDTree of the same points (unbounded queries)


@dataclass(frozen=True, eq=False)
class Prepared:
    """One problem up to the optimiser: features, downsampled input (N', 3), keypoints (n, 3),
    partial-template keypoints (m, 2n, 3), affinities (m, n, 2n), SVD poses (m, 4, 4), Chamfer
    source points."""

    feats: TemplateFeatures
    points: np.ndarray
    keypoints: np.ndarray
    P_t: np.ndarray
    A: np.ndarray
    T_svd: np.ndarray
    chamfer_src: np.ndarray


@dataclass(frozen=True, eq=False)
class Candidates:
    """Every candidate of one problem, one per partial template (``m`` of them).

    Attributes:
        points: (N', 3) downsampled input, camera frame; ``keypoints`` (n, 3) its FPS keypoints;
            ``chamfer_src`` (CHAMFER_POINTS, 3) its FPS subset for the Chamfer distances.
        A: (m, n, 2n) row-normalised affinities (input keypoint -> partial-template keypoint).
        T_svd: (m, 4, 4) initial poses ``T_template_camera`` (weighted Kabsch on ``A P_t``).
        T: (m, 4, 4) poses after the optimiser (``mode=none``: ``T_svd`` rounded through the
            optimiser's float32 6D parameters and re-orthonormalised).
        losses: (m,) final mean correspondence-weighted keypoint distances.
        C: (m, n, 2n) final soft correspondences (``A`` without stage 2).
    """

    points: np.ndarray
    keypoints: np.ndarray
    chamfer_src: np.ndarray
    A: np.ndarray
    T_svd: np.ndarray
    T: np.ndarray
    losses: np.ndarray
    C: np.ndarray
