"""Stable resting poses of a rigid object on a table: which of its directions can point up.

An object dropped on a plane rests on a face of its convex hull; trimesh's
``compute_stable_poses`` lists those faces with their probabilities. :func:`resting_ups` turns
each into ``up``, the object-frame unit vector pointing away from the table, merged within
``merge_deg``; :func:`up_classes` merges ups of an object with a continuous symmetry axis that make
the same angle with it (a can: upright, upside down, on its side). Ups are rounded to 1e-6 and
probabilities to 1e-9 so that BLAS-dependent last bits cannot change them between CPUs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose import libm
from catpose.geometry import dot3, norm3, unit3

__all__ = ["RestingUp", "rest_classes", "resting_ups", "resting_ups_cached", "up_classes"]


@dataclass(frozen=True)
class RestingUp:
    """One resting direction of an object.

    Attributes:
        up: (3,) unit vector in the object frame that points away from the table.
        probability: probability of coming to rest this way (summed over merged faces).
    """

    up: tuple[float, float, float]
    probability: float

    @property
    def vector(self) -> np.ndarray:
        return np.array(self.up, dtype=np.float64)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(libm.arccos(float(np.clip(dot3(a, b), -1.0, 1.0)))))


def solid_hull(points: np.ndarray):
    """The convex hull (``trimesh.Trimesh``) of ``points`` (N, 3), or None when they are not finite
    or flat (a hull of no volume, on which trimesh's stable-pose search never ends)."""
    import trimesh

    p = np.asarray(points, dtype=np.float64)
    if len(p) < 4 or not np.isfinite(p).all():
        return None
    try:
        hull = trimesh.convex.convex_hull(p)
    except Exception:  # noqa: BLE001 - qhull refuses some flat inputs itself
        return None
    with np.errstate(invalid="ignore", divide="ignore"):  # a flat hull's centre of mass is 0 / 0
        return hull if hull.volume > 1e-12 * float(np.max(hull.extents)) ** 3 else None


def resting_ups(points: np.ndarray, merge_deg: float = 10.0) -> list[RestingUp]:
    """Resting directions of the solid convex hull of ``points`` (N, 3), most probable first.

    Args:
        points: (N, 3) vertices or surface samples of the object (any unit, object frame).
        merge_deg: faces whose ups differ by less than this merge into one (probabilities add,
            the most probable face's up is kept).

    Returns:
        every distinct resting up with its probability (the probabilities sum to 1).

    Raises:
        InvalidInputError: the points are flat (their hull has no volume: trimesh's search would
            never end) or not finite.
    """
    import trimesh

    from catpose.errors import InvalidInputError

    hull = solid_hull(points)
    if hull is None:
        raise InvalidInputError(
            f"the model is flat or degenerate ({len(points)} points, a hull of no volume): it has no resting pose "
            "on a table; give a solid model (a mesh that encloses a volume)"
        )
    transforms, probs = trimesh.poses.compute_stable_poses(hull, n_samples=1, sigma=0.0)
    raw = []
    for T, p in zip(transforms, probs):
        up = np.round(np.asarray(T, dtype=np.float64)[2, :3], 6)  # R^T e_z: the table normal in the object frame
        if norm3(up) > 0.5 and p > 0:
            raw.append((round(float(p), 9), unit3(up)))
    raw.sort(key=lambda r: (-r[0], tuple(r[1])))
    merged: list[list] = []
    for p, up in raw:
        for m in merged:
            if _angle_deg(m[1], up) < merge_deg:
                m[0] += p
                break
        else:
            merged.append([p, up])
    total = sum(m[0] for m in merged) or 1.0
    out = [RestingUp(tuple(float(x) for x in np.round(up, 6)), round(p / total, 9)) for p, up in merged]
    return sorted(out, key=lambda r: (-r.probability, r.up))


def resting_ups_cached(points: np.ndarray, merge_deg: float = 10.0) -> list[RestingUp]:
    """:func:`resting_ups` through the disk cache (:mod:`catpose.disk_cache`, kind ``resting``,
    keyed by the points' content, ``merge_deg`` and this module's code): trimesh's stable poses
    take about a second for a YCB-Video model; the values come back with the same bits."""
    from catpose import disk_cache
    from catpose.content_hash import content_hash

    p = np.asarray(points, dtype=np.float64)
    key = f"{content_hash(p)}|{float(merge_deg)!r}|{disk_cache.fingerprint('catpose.resting')}"
    return disk_cache.cached(
        "resting",
        key,
        lambda: resting_ups(p, merge_deg),
        lambda ups: {
            "up": np.array([r.up for r in ups], float).reshape(-1, 3),
            "p": np.array([r.probability for r in ups]),
        },
        lambda z: [RestingUp(tuple(float(x) for x in u), float(q)) for u, q in zip(z["up"], z["p"], strict=True)],
    )


def rest_classes(
    ups: list[RestingUp], symmetry_axis: np.ndarray | None, merge_deg: float = 10.0
) -> list[tuple[RestingUp, list[RestingUp]]]:
    """``ups`` grouped into classes equivalent under a continuous symmetry about
    ``symmetry_axis`` (3,): two ups are equivalent when they make the same angle with the axis
    (within ``merge_deg``; a can on any of its side lines is one class). Each class is
    ``(representative, members)``: the representative has the most probable member's up and the
    class's summed probability. Without an axis every up is its own class. Most probable first."""
    if symmetry_axis is None:
        return [(r, [r]) for r in ups]
    axis = unit3(np.asarray(symmetry_axis, dtype=np.float64))
    merged: list[list] = []
    for r in sorted(ups, key=lambda r: (-r.probability, r.up)):
        angle = _angle_deg(r.vector, axis)
        for m in merged:
            if abs(m[2] - angle) < merge_deg:
                m[0] += r.probability
                m[3].append(r)
                break
        else:
            merged.append([r.probability, r.up, angle, [r]])
    out = [(RestingUp(up, round(p, 9)), members) for p, up, _, members in merged]
    return sorted(out, key=lambda c: (-c[0].probability, c[0].up))


def up_classes(ups: list[RestingUp], symmetry_axis: np.ndarray | None, merge_deg: float = 10.0) -> list[RestingUp]:
    """``ups`` with those equivalent under a continuous symmetry about ``symmetry_axis`` (3,)
    merged (the representatives of :func:`rest_classes`). Without an axis, ``ups`` unchanged.
    Most probable first."""
    if symmetry_axis is None:
        return list(ups)
    return [r for r, _ in rest_classes(ups, symmetry_axis, merge_deg)]
