"""Keypoints and descriptors of a template's partial templates, computed once per process and
shared by every method that matches against the same dictionary with the same descriptor: ours
and the correspondence baselines with ``matching=dictionary features=lps|pfh`` (FGR, RANSAC,
TEASER). With LPS these are ~25 MB and ~0.4 s a template; before, each method built its own.

The cache is a bounded LRU of :data:`CACHE_SIZE` templates keyed by the dictionary's content key,
the template's up axis, the descriptor's parameters and the keypoint count, so two methods share
an entry exactly when they would compute the same thing. Below it, the disk cache
(:mod:`catpose.disk_cache`, kind ``dictionary_features``: the same key and the descriptor code's
fingerprint) keeps them between processes: a template described once is loaded (about 1.5 MB for
LPS, its voxel grids stored sparse) by the next run or process, with the same bits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from catpose.lru import LRUCache
from catpose.methods.descriptors import Descriptor
from catpose.methods.dictionary import DictionaryLayout
from catpose.types import Template

#: templates whose dictionary features stay in memory (LPS: ~25 MB each)
CACHE_SIZE = 32

_CACHE: LRUCache[tuple, DictionaryFeatures] = LRUCache(CACHE_SIZE)


@dataclass(frozen=True, eq=False)
class DictionaryFeatures:
    """Keypoints and descriptors of ``m`` clouds (the partial templates), ``k`` keypoints each.

    Attributes:
        keypoints: (m, k, 3) keypoint positions, template frame (FPS order; a partial with fewer
            than ``k`` points after downsampling repeats its keypoints: only the first
            ``counts[i]`` are distinct).
        normals: (m, k, 3) unit normals at the keypoints.
        counts: (m,) distinct keypoints per partial.
        stacked: the descriptors, stacked for ``descriptor.batched_affinity`` (affinities of
            ``n`` input keypoints to all of them at once: (m, n, k)).
    """

    keypoints: np.ndarray
    normals: np.ndarray
    counts: np.ndarray
    stacked: Any


def describe_clouds(
    descriptor: Descriptor, clouds: Sequence[tuple[np.ndarray, np.ndarray]], up: np.ndarray, num_keypoints: int
) -> DictionaryFeatures:
    """:class:`DictionaryFeatures` of ``clouds`` ((points (N, 3), normals (N, 3)) pairs, one frame with
    up direction ``up``), ``num_keypoints`` keypoints each; not cached."""
    parts = [descriptor.keypoint_features(p, n, num_keypoints, up, pad=True) for p, n in clouds]
    counts = np.array([len(np.unique(f.indices)) for f in parts], dtype=np.int64)
    return DictionaryFeatures(
        np.stack([f.keypoints for f in parts]),
        np.stack([f.normals[f.indices] for f in parts]),
        counts,
        descriptor.stack([f.features for f in parts]),
    )


#: the modules whose code computes an entry (their source is part of the disk key)
_CODE = (
    "catpose.methods.dictionary_features",
    "catpose.methods.descriptors",
    "catpose.methods.keypoints",
    "catpose.methods.lps",
    "catpose.methods.pfh",
)


def dictionary_features(
    descriptor: Descriptor,
    layout: DictionaryLayout,
    template: Template,
    num_keypoints: int,
) -> DictionaryFeatures:
    """The partial templates of ``template`` under ``layout`` described by ``descriptor`` with
    ``num_keypoints`` keypoints each (template frame, ``template.up`` as up), from the shared
    cache, the disk cache, or computed and cached in both."""
    dictionary = layout.dictionary(template)
    up = np.asarray(template.up, dtype=np.float64)
    key = (dictionary.key, tuple(np.round(up, 12)), descriptor.cache_key(), int(num_keypoints))

    def build() -> DictionaryFeatures:
        return describe_clouds(descriptor, list(zip(dictionary.points, dictionary.normals)), up, num_keypoints)

    from catpose import disk_cache

    disk_key = f"{key!r}|{disk_cache.fingerprint(*_CODE)}"
    return _CACHE.get_or_build(
        key,
        lambda: disk_cache.cached(
            "dictionary_features", disk_key, build, disk_cache.pack, _from_arrays, label=dictionary.key
        ),
    )


def _from_arrays(arrays) -> DictionaryFeatures:
    """A :class:`DictionaryFeatures` from its disk-cache entry (the dataclasses it may hold: itself
    and LPS's stacked grids)."""
    from catpose import disk_cache
    from catpose.methods.lps import VoxelPatches

    types = {f"{c.__module__}:{c.__qualname__}": c for c in (DictionaryFeatures, VoxelPatches)}
    out = disk_cache.unpack(arrays, types)
    if not isinstance(out, DictionaryFeatures):
        raise ValueError("not a DictionaryFeatures entry")
    return out


def clear() -> None:
    """Empty the shared cache (tests, memory measurements)."""
    _CACHE.clear()
