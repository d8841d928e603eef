"""Keypoint descriptors as interchangeable strategies: :class:`LPS` (the paper's) and :class:`PFH`,
used by ``ours`` and the correspondence baselines. :meth:`Descriptor.keypoint_features`
voxel-downsamples a cloud, picks keypoints by farthest point sampling from index 0 and describes
them; :meth:`Descriptor.affinity` gives unnormalised affinities (Ka, Kb), and
:meth:`Descriptor.batched_affinity` those of one set to ``m`` stacked sets (m, Ka, k) in one
product. Lengths are object-normalised; a bad option raises a one-line ConfigError naming
``method.descriptor.<key>``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from catpose.methods import options
from catpose.methods.keypoints import farthest_point_indices, voxel_downsample

_KEY = "method.descriptor."


@dataclass(frozen=True, eq=False)
class KeypointFeatures:
    """A downsampled cloud, its keypoints and their descriptors.

    Attributes:
        points, normals: (N', 3) voxel-downsampled cloud and unit normals (the input's frame).
        indices: (k,) keypoint indices into ``points`` (FPS order; repeated when padded).
        features: the descriptor's per-keypoint features (compare with ``affinity``).
    """

    points: np.ndarray
    normals: np.ndarray
    indices: np.ndarray
    features: Any

    @property
    def keypoints(self) -> np.ndarray:
        """(k, 3) keypoint positions."""
        return self.points[self.indices]


class Descriptor(ABC):
    """The interface of a keypoint descriptor (see the module docstring)."""

    name: str = ""
    voxel_size: float = 0.0

    def keypoint_features(
        self, points: np.ndarray, normals: np.ndarray, num_keypoints: int, up: np.ndarray, pad: bool = False
    ) -> KeypointFeatures:
        """Downsample, pick ``num_keypoints`` keypoints (FPS from index 0) and describe them.

        Args:
            points, normals: (N, 3) cloud and unit normals, any one frame.
            num_keypoints: keypoints to pick.
            up: (3,) up direction in that frame (ground normal for the camera frame,
                ``template.up`` for the template frame).
            pad: repeat keypoints up to ``num_keypoints`` when the downsampled cloud has fewer
                points (so partial templates batch together).
        """
        from scipy.spatial import cKDTree

        p, n = voxel_downsample(points, normals, self.voxel_size)
        idx = farthest_point_indices(p, num_keypoints)
        if pad and len(idx) < num_keypoints:
            idx = np.resize(idx, num_keypoints)
        return KeypointFeatures(p, n, idx, self.describe(p, n, idx, up, cKDTree(p)))

    @abstractmethod
    def describe(self, points: np.ndarray, normals: np.ndarray, kp_idx: np.ndarray, up: np.ndarray, tree) -> Any:
        """Features of the keypoints ``points[kp_idx]`` (``tree``: cKDTree of ``points``)."""

    @abstractmethod
    def stack(self, sets: list[Any]) -> Any:
        """``m`` feature sets of ``k`` keypoints each, prepared for :meth:`batched_affinity`."""

    @abstractmethod
    def batched_affinity(self, a: Any, stacked: Any) -> np.ndarray:
        """Unnormalised affinities (m, Ka, k) of ``a`` (:meth:`describe`'s) to each of the stacked sets."""

    def affinity(self, a: Any, b: Any) -> np.ndarray:
        """Unnormalised affinities (Ka, Kb) between two feature sets from :meth:`describe`."""
        return self.batched_affinity(a, self.stack([b]))[0]

    def cache_key(self) -> tuple:
        """The descriptor's name and every parameter."""
        return (self.name,) + tuple((f.name, getattr(self, f.name)) for f in fields(self))


@dataclass(frozen=True, eq=False)
class LPS(Descriptor):
    """Local Patch Similarity (the paper's descriptor, :mod:`catpose.methods.lps`).

    Args:
        radius: patch crop radius r (object-normalised).
        tau: F-score threshold (object-normalised).
        max_points: patch size cap (nearest points kept).
        parallel_deg: PCA frame when the normal is this close to the ground normal (degrees).
        voxel_size: downsampling voxel before keypoints and patches (0: none).
    """

    radius: float = 0.2
    tau: float = 0.03
    max_points: int = 96
    parallel_deg: float = 10.0
    voxel_size: float = 0.025
    name = "lps"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for key in ("radius", "tau"):
            set_(self, key, options.positive(_KEY + key, getattr(self, key)))
        set_(self, "max_points", options.positive(_KEY + "max_points", self.max_points, integer=True))
        set_(self, "parallel_deg", options.non_negative(_KEY + "parallel_deg", self.parallel_deg))
        set_(self, "voxel_size", options.non_negative(_KEY + "voxel_size", self.voxel_size))

    def describe(self, points, normals, kp_idx, up, tree):
        """``VoxelPatches`` of the keypoints."""
        from catpose.methods.lps import lps_patches, voxelize

        patches = lps_patches(points, normals, kp_idx, up, self.radius, self.max_points, self.parallel_deg, tree)
        return voxelize(patches, self.radius, self.tau)

    def stack(self, sets):
        from catpose.methods.lps import VoxelPatches

        # Fortran order: fscore_voxel multiplies by the transposes, which are then C-contiguous
        return (
            len(sets),
            VoxelPatches(
                np.asfortranarray(np.concatenate([s.counts for s in sets])),
                np.asfortranarray(np.concatenate([s.dilated for s in sets])),
                np.concatenate([s.n for s in sets]),
            ),
        )

    def batched_affinity(self, a, stacked) -> np.ndarray:
        from catpose.methods.lps import fscore_voxel

        m, b = stacked
        f = fscore_voxel(a, b, np.float32)  # (Ka, m k), the grids' precision
        return f.reshape(len(f), m, -1).transpose(1, 0, 2)


@dataclass(frozen=True, eq=False)
class PFH(Descriptor):
    """Point Feature Histograms with affinity 1 / (EMD + eps) (:mod:`catpose.methods.pfh`).

    Args:
        radius: neighbourhood radius (object-normalised).
        max_nn: neighbour cap.
        eps: affinity epsilon (the EMD: the sum of the 1D EMDs of the 3 marginals).
        voxel_size: downsampling voxel before keypoints and histograms (0: none).
    """

    radius: float = 0.2
    max_nn: int = 32
    eps: float = 0.01
    voxel_size: float = 0.025
    name = "pfh"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "radius", options.positive(_KEY + "radius", self.radius))
        set_(self, "max_nn", options.positive(_KEY + "max_nn", self.max_nn, integer=True))
        set_(self, "eps", options.positive(_KEY + "eps", self.eps))
        set_(self, "voxel_size", options.non_negative(_KEY + "voxel_size", self.voxel_size))

    def describe(self, points, normals, kp_idx, up, tree):
        """(k, 125) histograms, each summing to 1 (``up`` is not used: PFH is rotation-invariant)."""
        from catpose.methods.pfh import pfh_descriptors

        return pfh_descriptors(points, normals, points[kp_idx], self.radius, self.max_nn, tree)

    def stack(self, sets):
        from catpose.methods.pfh import marginal_cdfs

        return len(sets), marginal_cdfs(np.concatenate(sets))  # (m k, 15)

    def batched_affinity(self, a, stacked) -> np.ndarray:
        from scipy.spatial.distance import cdist

        from catpose.methods.pfh import marginal_cdfs

        m, cdfs = stacked
        emd = cdist(marginal_cdfs(a), cdfs, metric="cityblock")
        return (1.0 / (emd + self.eps)).reshape(len(a), m, -1).transpose(1, 0, 2)
