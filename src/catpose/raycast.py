"""Ray casting against a triangle mesh, the same bits on every CPU.

Open3D's ``RaycastingScene`` (Embree, float32) finds which triangle each ray hits; the hit
distance is then recomputed in float64 from that triangle's plane (:meth:`RayCaster.cast`).
Embree ships code paths for several instruction sets (SSE, AVX2, AVX-512) whose float32 hit
distances differ in the last bits, so its own ``t_hit`` changes with the CPU; the plane of a
given triangle does not (closed form, no BLAS).

Both the datasets (depth rendering, :mod:`catpose.datasets.render`) and the methods (ours'
depth-image verification, :mod:`catpose.methods.ours.check`) cast rays, so the helper lives here,
where both may import it. :class:`RayCaster` keeps one scene per mesh for repeated casts (a
method scoring many poses of one template).
"""

from __future__ import annotations

import numba
import numpy as np

from catpose.geometry import norm3

__all__ = ["RayCaster"]


class RayCaster:
    """One triangle mesh in an Open3D ``RaycastingScene``, for many casts.

    Args:
        vertices: (V, 3) mesh vertices (any frame, any unit); triangles: (F, 3) vertex indices.
    """

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray) -> None:
        from catpose.o3d import o3d

        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.triangles = np.ascontiguousarray(triangles, dtype=np.int64)
        self._scene = o3d.t.geometry.RaycastingScene()
        mesh = o3d.t.geometry.TriangleMesh()
        mesh.vertex.positions = o3d.core.Tensor(self.vertices.astype(np.float32))
        mesh.triangle.indices = o3d.core.Tensor(self.triangles.astype(np.int32))
        self._scene.add_triangles(mesh)
        self._invalid = int(o3d.t.geometry.RaycastingScene.INVALID_ID)
        self.bounds = (self.vertices.min(axis=0), self.vertices.max(axis=0))  # the box every hit lies in
        # per triangle, once: its first vertex, its plane's normal (unnormalised) and that normal's length
        tri = self.vertices[self.triangles]  # (F, 3, 3)
        self._v0 = np.ascontiguousarray(tri[:, 0])
        self._normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        self._normal_lengths = norm3(self._normals)

    def cast(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Ray parameter ``s`` of the first hit along ``origins + s * directions``, in float64.

        ``s`` is recomputed from the hit triangle's plane, ``s = n . (v0 - o) / n . d``. Rays that
        graze their triangle (``|n . d| < 1e-9 |n| |d|``) keep Embree's value.

        Args:
            origins, directions: (..., 3) rays in the vertices' frame (directions need not be
                unit; broadcast against each other).

        Returns:
            (...) float64 ray parameters, ``inf`` where the ray hits nothing.
        """
        from catpose.o3d import o3d

        o = np.asarray(origins, dtype=np.float64)
        d = np.asarray(directions, dtype=np.float64)
        shape = np.broadcast_shapes(o.shape, d.shape)[:-1]
        o, d = np.broadcast_to(o, shape + (3,)).reshape(-1, 3), np.broadcast_to(d, shape + (3,)).reshape(-1, 3)
        rays = np.empty((len(o), 6), dtype=np.float32)
        rays[:, :3], rays[:, 3:] = o, d
        ans = self._scene.cast_rays(o3d.core.Tensor(rays))
        s = np.empty(len(o))
        _plane_hits(
            o, d, ans["primitive_ids"].numpy(), ans["t_hit"].numpy(), self._invalid,
            self._v0, self._normals, self._normal_lengths, s,
        )  # fmt: skip
        return s.reshape(shape)


@numba.njit(cache=True, nogil=True)
def _plane_hits(o, d, prim, t_embree, invalid, v0, normals, normal_lengths, out):  # pragma: no cover - compiled
    """Per ray ``i`` (``o``, ``d`` (N, 3) float64; Embree's ``prim`` (N,) uint32 and ``t_embree``
    (N,) float32): ``out[i]`` = ``n . (v0 - o) / n . d`` of the hit triangle's plane, Embree's
    value where the ray grazes it (``|n . d| < 1e-9 |n| |d|``), ``inf`` where it hits nothing.
    Each product and sum in the order of :func:`catpose.geometry.dot3` (the NumPy form's bits)."""
    for i in range(o.shape[0]):
        k = np.int64(prim[i])
        t = np.float64(t_embree[i])
        if k == invalid or not np.isfinite(t):
            out[i] = np.inf
            continue
        nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        nd = nx * dx + ny * dy + nz * dz
        num = nx * (v0[k, 0] - o[i, 0]) + ny * (v0[k, 1] - o[i, 1]) + nz * (v0[k, 2] - o[i, 2])
        s_hit = num / (1.0 if nd == 0.0 else nd)
        grazing = np.abs(nd) < 1e-9 * normal_lengths[k] * np.sqrt(dx * dx + dy * dy + dz * dz)
        out[i] = t if grazing else s_hit
