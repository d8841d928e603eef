"""Gravity hypotheses for objects that do not stand on the template's up axis.

Ours assumes that the object stands upright: its gravity filter keeps candidates whose rotation maps
the measured ground normal near the template's up axis, its LPS frames are built around that axis,
and its dictionary looks at the template from elevation rings above the plane normal to it. An
object lying on its side breaks all three at once (the potted meat can of the shared YCB-V frames).

Here each stable resting direction ``u`` of the template (the table normal seen from the object:
:func:`catpose.resting.resting_ups`, merged under the template's continuous symmetry by
:func:`catpose.resting.up_classes`) gives a hypothesis: the template turned by ``R_turned_template``
(the shortest rotation taking ``u`` onto the template's up axis), so that the unchanged pipeline
sees an upright object. A candidate ``T_turned_camera`` of that pipeline is the pose
``T_template_camera = R_turned_template^-1 T_turned_camera`` of the original template
(:meth:`Hypothesis.to_template`). The first hypothesis is always the template itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose.content_hash import content_hash
from catpose.lru import LRUCache
from catpose.methods.ours.settings import RestingSettings
from catpose.resting import resting_ups_cached, up_classes
from catpose.types import Template

__all__ = ["Hypothesis", "hypotheses", "rotation_between"]

_CACHE: LRUCache[tuple, tuple[Hypothesis, ...]] = LRUCache(32)


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


@dataclass(frozen=True, eq=False)
class Hypothesis:
    """One gravity hypothesis: the template turned so that resting direction ``up`` (template
    frame) is the template's up axis.

    Attributes:
        template: the turned template (points, normals and mesh rotated; same up attribute).
        R_turned_template: (3, 3) ``p_turned = R p_template``.
        up: (3,) the resting direction in the original template frame.
        probability: its drop-test probability (1 for the template's own up).
    """

    template: Template
    R_turned_template: np.ndarray
    up: np.ndarray
    probability: float

    def to_template(self, T_turned_camera: np.ndarray) -> np.ndarray:
        """Poses (..., 4, 4) of the turned template -> poses of the original template."""
        T = np.array(T_turned_camera, dtype=np.float64, copy=True)
        R_inv = self.R_turned_template.T
        T[..., :3, :3] = np.einsum("ij,...jk->...ik", R_inv, T[..., :3, :3])
        T[..., :3, 3] = np.einsum("ij,...j->...i", R_inv, T[..., :3, 3])
        return T


def _turned(template: Template, R: np.ndarray, up: np.ndarray) -> Template:
    tag = ",".join(f"{x:.3f}" for x in up)
    return Template(
        template_id=f"{template.template_id}@up({tag})",
        category=template.category,
        points=template.points @ R.T,
        normals=template.normals @ R.T,
        vertices=None if template.vertices is None else np.asarray(template.vertices, float) @ R.T,
        triangles=template.triangles,
        up=template.up,
        symmetry_axis=None if template.symmetry_axis is None else R @ np.asarray(template.symmetry_axis, float),
    )


def hypotheses(template: Template, settings: RestingSettings) -> tuple[Hypothesis, ...]:
    """The template's own up, then up to ``settings.max_poses`` other resting directions with
    probability at least ``settings.min_probability``, most probable first; cached per template."""
    up0 = np.asarray(template.up, dtype=np.float64) / np.linalg.norm(template.up)
    own = Hypothesis(template, np.eye(3), up0, 1.0)
    if settings.max_poses == 0:
        return (own,)
    geometry = template.vertices if template.has_mesh else template.points
    key = (
        template.template_id,
        content_hash(np.asarray(geometry, float)),  # the up classes depend on the geometry, ...
        content_hash(template.points, template.normals),  # ... the turned template holds the points
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
    out = [own]
    for r in classes:
        if len(out) > settings.max_poses or r.probability < settings.min_probability:
            break
        if _same_class(r.vector, up0, template.symmetry_axis, MERGE_DEG):
            continue
        R = rotation_between(r.vector, up0)
        out.append(Hypothesis(_turned(template, R, r.vector), R, r.vector, float(r.probability)))
    result = tuple(out)
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
