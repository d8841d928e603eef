"""The resting directions of a template: where ours looks for objects that do not stand on the
template's up axis.

Ours' gravity filter keeps candidates whose rotation maps the measured ground normal near the
template's up axis. An object lying on its side breaks that (the potted meat can of the shared
YCB-V frames). Each stable resting direction ``u`` of the template (the table normal seen from the
object: :func:`catpose.resting.resting_ups`, merged under the template's continuous symmetry by
:func:`catpose.resting.up_classes`) is a direction the coarse search
(:mod:`catpose.methods.ours.rest_search`) rests the template on and the depth check's gravity
filter accepts. The first direction is always the template's own up.
"""

from __future__ import annotations

import numpy as np

from catpose.content_hash import template_hash
from catpose.lru import LRUCache
from catpose.methods.ours.settings import RestingSettings
from catpose.resting import resting_ups_cached, up_classes
from catpose.types import Template

__all__ = ["rotation_between", "ups"]

_CACHE: LRUCache[tuple, np.ndarray] = LRUCache(32)


#: resting directions closer than this are one (degrees): the drop test's classes of a cylinder's
#: side differ by less than a degree, a box's faces by 90 (docs/choosing-defaults.md)
MERGE_DEG = 10.0


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) the shortest rotation taking unit ``a`` onto unit ``b`` (a half turn about an axis
    perpendicular to ``a`` when they are opposite)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    v, c = np.cross(a, b), float(np.clip(a @ b, -1.0, 1.0))
    if np.linalg.norm(v) < 1e-12:
        if c > 0:
            return np.eye(3)
        p = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        p /= np.linalg.norm(p)
        return 2.0 * np.outer(p, p) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def ups(template: Template, settings: RestingSettings) -> np.ndarray:
    """(H, 3) unit resting directions, template frame: the template's own up, then up to
    ``settings.max_poses`` other resting directions with probability at least
    ``settings.min_probability``, most probable first; cached per template."""
    up0 = np.asarray(template.up, dtype=np.float64) / np.linalg.norm(template.up)
    if settings.max_poses == 0:
        return up0[None]
    geometry = template.vertices if template.has_mesh else template.points
    key = (
        template.template_id,
        template_hash(template, "vertices" if template.has_mesh else "points"),  # the up classes depend on it
        tuple(np.round(up0, 9)),
        None if template.symmetry_axis is None else tuple(np.round(template.symmetry_axis, 9)),
        settings.max_poses,
        settings.min_probability,
        MERGE_DEG,
    )
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    classes = up_classes(resting_ups_cached(geometry, MERGE_DEG), template.symmetry_axis, MERGE_DEG)
    out = [up0]
    for r in classes:
        if len(out) > settings.max_poses or r.probability < settings.min_probability:
            break
        if not _same_class(r.vector, up0, template.symmetry_axis, MERGE_DEG):
            out.append(np.asarray(r.vector, dtype=np.float64))
    result = np.stack(out)
    _CACHE.put(key, result)
    return result


def _same_class(a: np.ndarray, b: np.ndarray, axis: np.ndarray | None, merge_deg: float) -> bool:
    """Whether resting directions ``a`` and ``b`` are one (within ``merge_deg``; under a continuous
    symmetry about ``axis``: the same angle to it)."""

    def angle(u, v):
        return float(np.degrees(np.arccos(np.clip(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)), -1.0, 1.0))))

    if axis is None:
        return angle(a, b) < merge_deg
    axis = np.asarray(axis, float)
    return abs(angle(a, axis) - angle(b, axis)) < merge_deg
