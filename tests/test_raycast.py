"""catpose.raycast: the compiled float64 hit recomputation against its NumPy form, bit for bit."""

from __future__ import annotations

import numpy as np
import trimesh

from catpose.raycast import RayCaster


def numpy_cast(caster: RayCaster, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """The hit parameters in NumPy (the form the compiled loop replaced): Embree's triangle, then
    ``n . (v0 - o) / n . d`` from its plane, Embree's value where the ray grazes it."""
    from catpose.o3d import o3d

    o, d = np.asarray(origins, np.float64), np.asarray(directions, np.float64)
    rays = np.concatenate([o, d], axis=1).astype(np.float32)
    ans = caster._scene.cast_rays(o3d.core.Tensor(rays))
    prim = ans["primitive_ids"].numpy().astype(np.int64)
    t = ans["t_hit"].numpy().astype(np.float64)
    tri = caster.vertices[caster.triangles]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    s = np.full(len(o), np.inf)
    hit = (prim != caster._invalid) & np.isfinite(t)
    n, k = normals[prim[hit]], prim[hit]
    nd = n[:, 0] * d[hit, 0] + n[:, 1] * d[hit, 1] + n[:, 2] * d[hit, 2]
    w = tri[k, 0] - o[hit]
    s_hit = (n[:, 0] * w[:, 0] + n[:, 1] * w[:, 1] + n[:, 2] * w[:, 2]) / np.where(nd == 0.0, 1.0, nd)
    length = np.sqrt(n[:, 0] ** 2 + n[:, 1] ** 2 + n[:, 2] ** 2)
    dl = np.sqrt(d[hit, 0] * d[hit, 0] + d[hit, 1] * d[hit, 1] + d[hit, 2] * d[hit, 2])
    s[hit] = np.where(np.abs(nd) < 1e-9 * length * dl, t[hit], s_hit)
    return s


def test_compiled_hits_match_numpy_bit_for_bit() -> None:
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.4)
    caster = RayCaster(mesh.vertices, mesh.faces)
    rng = np.random.default_rng(0)
    origins = rng.normal(size=(20000, 3))
    origins *= 2.0 / np.linalg.norm(origins, axis=1, keepdims=True)
    directions = -origins + rng.normal(size=(20000, 3)) * 0.25  # some miss the sphere
    s = caster.cast(origins, directions)
    ref = numpy_cast(caster, origins, directions)
    assert np.isinf(s).sum() > 1000 and np.isfinite(s).sum() > 10000
    assert np.array_equal(s, ref)
    # a hit lies on the sphere's surface (float64 from the triangle's plane: the mesh, not float32)
    p = origins + s[:, None] * directions
    hit = np.isfinite(s)
    assert np.abs(np.linalg.norm(p[hit], axis=1) - 0.4).max() < 0.01


def test_broadcast_origin_and_grid_shape() -> None:
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    caster = RayCaster(mesh.vertices, mesh.faces)
    u, v = np.meshgrid(np.linspace(-0.3, 0.3, 7), np.linspace(-0.3, 0.3, 9), indexing="ij")
    directions = np.stack([u, v, np.ones_like(u)], axis=-1)  # (7, 9, 3) from one camera centre
    s = caster.cast(np.array([0.0, 0.0, -3.0]), directions)
    assert s.shape == (7, 9)
    # the face z = -0.5 is 2.5 ahead along z: s = 2.5 where the ray meets it inside the box; a ray
    # already outside the box's x or y range there only leaves it further (s * |u| grows)
    front = (np.abs(2.5 * u) < 0.5) & (np.abs(2.5 * v) < 0.5)
    miss = (np.abs(2.5 * u) > 0.5) | (np.abs(2.5 * v) > 0.5)
    assert front.sum() > 5 and miss.sum() > 5
    np.testing.assert_allclose(s[front], 2.5, rtol=0, atol=1e-12)
    assert np.isinf(s[miss]).all()
