"""The partial-template dictionary (paper Section III-B, "Overview").

A complete template cloud (template frame) is seen from ``m`` viewpoints; hidden point removal
(Katz et al. 2007, Open3D) keeps the points visible from each. The partial templates stay in the
template frame, so a pose estimated against any of them is a pose against the template.

Viewpoints (:func:`viewpoint_layout`, ``num_views=18``): elevation rings at ``elevations_deg = (0,
30, 60)`` degrees above the template's ground plane (xy, z up), azimuths evenly spaced from +x (odd
rings offset by half a step), at ``distance`` (object-normalised) from the origin: where a depth
camera looks at an upright object from.

Built once per template content and parameters, cached in memory and on disk
(:mod:`catpose.disk_cache`, indices only; points and normals come from the template).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from catpose.content_hash import template_hash
from catpose.errors import ConfigError
from catpose.hpr import visible_indices
from catpose.lru import LRUCache
from catpose.methods import options
from catpose.types import Template

_VERSION = "1"
# process-wide, so ``ours`` and the dictionary baselines share it; an own-model run sees a new
# template per instance
_MEMORY: LRUCache[str, PartialDictionary] = LRUCache(32)

__all__ = [
    "DictionaryLayout",
    "PartialDictionary",
    "clear_memory_cache",
    "get_dictionary",
    "viewpoint_layout",
    "visible_indices",
]


@dataclass(frozen=True, eq=False)
class PartialDictionary:
    """``m`` partial templates of one template, all in the template frame.

    Attributes:
        template_id: id of the template they were cut from.
        key: cache key (template id, points hash, parameters).
        viewpoints: (m, 3) camera positions in the template frame, object-normalised unit.
        indices: m int64 arrays; ``indices[i]`` (K_i,) indexes ``template.points`` visible from
            viewpoint ``i``.
        points: m arrays (K_i, 3), template frame: ``template.points[indices[i]]``.
        normals: m arrays (K_i, 3), unit outward normals of ``points[i]``.
    """

    template_id: str
    key: str
    viewpoints: np.ndarray
    indices: list[np.ndarray]
    points: list[np.ndarray]
    normals: list[np.ndarray]

    def __len__(self) -> int:
        return len(self.indices)


def viewpoint_layout(
    num_views: int = 18, elevations_deg: tuple[float, ...] = (0.0, 30.0, 60.0), distance: float = 3.0
) -> np.ndarray:
    """Camera positions (num_views, 3) around the template origin, template frame (z up):
    ``len(elevations_deg)`` rings (degrees above the xy plane) of ``num_views / len(elevations_deg)``
    azimuths evenly spaced from +x, odd rings turned by half a step so that rings interleave."""
    rings = len(elevations_deg)
    if num_views < 1 or rings == 0 or num_views % rings:
        raise ConfigError(
            f"method.dictionary.num_views={num_views} is not a multiple of the "
            f"{rings} elevation rings {list(elevations_deg)}; change one of them"
        )
    per = num_views // rings
    out = []
    for j, el in enumerate(elevations_deg):
        el_r = np.deg2rad(el)
        offset = 0.5 * (j % 2) * 2 * np.pi / per
        for a in range(per):
            az = offset + 2 * np.pi * a / per
            out.append([np.cos(el_r) * np.cos(az), np.cos(el_r) * np.sin(az), np.sin(el_r)])
    return distance * np.array(out)


def dictionary_key(
    template: Template,
    num_views: int,
    elevations_deg: tuple[float, ...],
    distance: float,
    hpr_radius_factor: float,
) -> str:
    """Cache key: safe template id + blake2b of the template points and every parameter."""
    params = repr(
        (
            _VERSION,
            num_views,
            tuple(float(e) for e in elevations_deg),
            float(distance),
            float(hpr_radius_factor),
        )
    )
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", template.template_id)[-80:]
    return f"{safe}-{template_hash(template, 'points', 'normals', extra=params, digest_size=10)}"


def get_dictionary(
    template: Template,
    num_views: int = 18,
    elevations_deg: tuple[float, ...] = (0.0, 30.0, 60.0),
    distance: float = 3.0,
    hpr_radius_factor: float = 100.0,
) -> PartialDictionary:
    """The :class:`PartialDictionary` of ``template`` (the same object for equal inputs), its
    viewpoints by :func:`viewpoint_layout`; ``hpr_radius_factor``: the hidden point removal radius
    over the cloud's extent from the viewpoint (Open3D's usual 100); cached on disk too (kind
    ``dictionary``)."""
    elevations_deg = tuple(float(e) for e in elevations_deg)
    key = dictionary_key(template, num_views, elevations_deg, distance, hpr_radius_factor)
    hit = _MEMORY.get(key)
    if hit is not None:
        return hit
    viewpoints = viewpoint_layout(num_views, elevations_deg, distance)

    def build() -> list[np.ndarray]:
        return [visible_indices(template.points, v, hpr_radius_factor) for v in viewpoints]

    def from_arrays(z) -> list[np.ndarray]:
        flat, offsets = z["indices"], z["offsets"]
        out = [flat[offsets[i] : offsets[i + 1]].astype(np.int64) for i in range(num_views)]
        if len(offsets) != num_views + 1 or any(len(i) and i.max() >= len(template.points) for i in out):
            raise ValueError("indices do not fit the template")
        return out

    def to_arrays(indices: list[np.ndarray]) -> dict[str, np.ndarray]:
        return {"indices": np.concatenate(indices), "offsets": np.cumsum([0] + [len(i) for i in indices])}

    from catpose import disk_cache

    disk_key = f"{key}|{disk_cache.fingerprint('catpose.methods.dictionary', 'catpose.hpr')}"
    indices = disk_cache.cached("dictionary", disk_key, build, to_arrays, from_arrays, label=key)
    d = PartialDictionary(
        template_id=template.template_id,
        key=key,
        viewpoints=viewpoints,
        indices=indices,
        points=[template.points[i] for i in indices],
        normals=[template.normals[i] for i in indices],
    )
    _MEMORY.put(key, d)
    return d


def clear_memory_cache() -> None:
    """Forget every in-memory dictionary (the disk cache stays)."""
    _MEMORY.clear()


@dataclass(frozen=True)
class DictionaryLayout:
    """How a template becomes a dictionary of partial templates, and how many keypoints each has.

    Attributes:
        num_views: ``m`` viewpoints (partial templates), a multiple of the rings.
        elevations_deg: ring elevations, degrees above the template's ground plane.
        view_distance: camera distance from the template origin, object-normalised units.
        hpr_radius_factor: hidden point removal radius / the cloud's extent from the viewpoint.
        num_keypoints: ``n`` keypoints on the input, ``2n`` on each partial template.
    Invalid values raise a one-line ConfigError naming ``method.dictionary.<key>``.
    """

    num_views: int = 18
    elevations_deg: tuple[float, ...] = (0.0, 30.0, 60.0)
    view_distance: float = 3.0
    hpr_radius_factor: float = 100.0
    num_keypoints: int = 32

    def __post_init__(self) -> None:
        k = "method.dictionary."
        set_ = object.__setattr__
        set_(self, "num_views", options.positive(k + "num_views", self.num_views, integer=True))
        try:
            elevations = tuple(float(e) for e in self.elevations_deg)
        except (TypeError, ValueError):
            raise ConfigError(f"{k}elevations_deg={self.elevations_deg!r} must be a list of degrees") from None
        set_(self, "elevations_deg", elevations)
        set_(self, "view_distance", options.positive(k + "view_distance", self.view_distance))
        set_(self, "hpr_radius_factor", options.positive(k + "hpr_radius_factor", self.hpr_radius_factor))
        set_(self, "num_keypoints", options.at_least(k + "num_keypoints", self.num_keypoints, 3))
        # rings that do not divide num_views fail here, not per sample
        viewpoint_layout(self.num_views, self.elevations_deg, self.view_distance)

    def dictionary(self, template: Template) -> PartialDictionary:
        """The partial-template dictionary of ``template`` (cached in memory and on disk)."""
        return get_dictionary(template, self.num_views, self.elevations_deg, self.view_distance, self.hpr_radius_factor)
