"""Mesh primitives of the procedural category shapes (:mod:`catpose.datasets.shapes`).

Boxes, cylinders, convex hulls, surfaces of revolution and swept tubes, each placed by a rigid
transform in closed form (:func:`catpose.geometry.transform_points`), so the shapes are the same
bits on every CPU; :func:`finish` concatenates the parts and normalises the result to the unit
bounding sphere.
"""

from __future__ import annotations

import numpy as np
import trimesh

from catpose import libm
from catpose.geometry import axis_angle_to_R, make_T, norm3, normalize_to_unit_sphere, transform_points, unit3

__all__ = ["align_z", "box", "cylinder", "finish", "hull", "posed", "revolve_z", "tube"]


def posed(mesh: trimesh.Trimesh, T: np.ndarray) -> trimesh.Trimesh:
    """``mesh`` moved by the (4, 4) rigid ``T``. The vertices are transformed in closed form
    (:func:`catpose.geometry.transform_points`), not by trimesh's BLAS product, so the shapes
    are the same bits on every CPU."""
    return trimesh.Trimesh(
        transform_points(T, np.asarray(mesh.vertices, dtype=np.float64)), np.asarray(mesh.faces), process=False
    )


def align_z(direction: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) taking +z onto the unit ``direction`` (the shortest arc)."""
    z = np.array([0.0, 0.0, 1.0])
    d = unit3(direction)
    axis = np.cross(z, d)
    s, c = norm3(axis), float(d[2])
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return axis_angle_to_R(axis, libm.arctan2(s, c))


def box(
    extents: tuple[float, float, float], center: tuple[float, float, float], R: np.ndarray | None = None
) -> trimesh.Trimesh:
    """Axis-aligned box (optionally rotated by ``R`` about its centre)."""
    T = make_T(np.eye(3) if R is None else R, np.asarray(center, dtype=np.float64))
    return posed(trimesh.creation.box(extents=extents), T)


def cylinder(p0: np.ndarray, p1: np.ndarray, radius: float, sections: int = 20) -> trimesh.Trimesh:
    """Solid cylinder from point ``p0`` to ``p1``."""
    p0, p1 = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
    height = norm3(p1 - p0)
    T = make_T(align_z(p1 - p0), (p0 + p1) / 2)
    return posed(trimesh.creation.cylinder(radius=radius, height=height, sections=sections), T)


def hull(points: np.ndarray) -> trimesh.Trimesh:
    """Convex hull of (K, 3) points (wings, fins, car bodies)."""
    return trimesh.convex.convex_hull(np.asarray(points, dtype=np.float64))


def revolve_z(profile_rz: list[tuple[float, float]] | np.ndarray, sections: int = 48) -> trimesh.Trimesh:
    """Surface of revolution about +z of a (K, 2) (radius, height) profile that starts and ends
    on the axis (radius 0), running outward along the bottom and back inward along the top."""
    return trimesh.creation.revolve(np.asarray(profile_rz, dtype=np.float64), sections=sections)


def tube(path: np.ndarray, radius: float, sections: int = 12) -> trimesh.Trimesh:
    """Closed tube of circular cross-section swept along a (K, 3) polyline (mug handles)."""
    path = np.asarray(path, dtype=np.float64)
    tangents = np.gradient(path, axis=0)
    tangents = unit3(tangents)
    ref = np.array([0.0, 1.0, 0.0]) if abs(tangents[0, 1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    angles = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    rings = []
    for t in tangents:
        u = unit3(np.cross(t, ref))
        v = np.cross(t, u)
        rings.append(np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v)
    K = len(path)
    verts = (path[:, None, :] + radius * np.asarray(rings)).reshape(-1, 3)
    verts = np.vstack([verts, path[0], path[-1]])
    faces = []
    for k in range(K - 1):
        for j in range(sections):
            a, b = k * sections + j, k * sections + (j + 1) % sections
            c, d = a + sections, b + sections
            faces += [[a, b, d], [a, d, c]]
    start, end = K * sections, K * sections + 1
    for j in range(sections):
        faces.append([start, (j + 1) % sections, j])
        faces.append([end, (K - 1) * sections + j, (K - 1) * sections + (j + 1) % sections])
    mesh = trimesh.Trimesh(verts, np.asarray(faces), process=False)
    mesh.fix_normals()
    return mesh


def finish(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate parts and normalise to the unit bounding sphere."""
    mesh = trimesh.util.concatenate(parts)
    v, _, _ = normalize_to_unit_sphere(mesh.vertices)
    return trimesh.Trimesh(v, np.asarray(mesh.faces), process=False)
