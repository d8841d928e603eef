"""Refinement, ours' last stage: point-to-plane ICP of the input against the complete template
from each chosen pose, all poses at once (:func:`catpose.point_to_plane_kernel.refine_many`,
compiled, on a :class:`~catpose.cell_grid.CellGrid` of the template's points).

The depth check's last comparisons refine on what no seed changes (:func:`final_inputs`): the
depth image's mask pixels on the check's lattice against a fixed sample of the template's mesh,
so that the answer between near-equal poses (a can and its half turn) does not hinge on which
points the seed drew (docs/choosing-defaults.md)."""

from __future__ import annotations

import numpy as np

from catpose import cell_grid
from catpose.content_hash import template_hash
from catpose.lru import LRUCache
from catpose.point_to_plane_kernel import refine_many
from catpose.types import Template

__all__ = ["MESH_SAMPLES", "REFINE_ITERATIONS", "REFINE_MAX_DISTANCE", "final_inputs", "mesh_sample", "refine_poses"]

#: ICP pairing distance, object-normalised unit: a few times the keypoint spacing, well inside
#: the basin a right candidate starts in (the paper's pipeline plus refinement; docs/choosing-defaults.md)
REFINE_MAX_DISTANCE = 0.05
#: ICP steps at most (converged long before on the embedded set; docs/choosing-defaults.md)
REFINE_ITERATIONS = 30
#: points of the fixed mesh sample the last comparisons refine against
MESH_SAMPLES = 2048

_MESH_SAMPLES: LRUCache[str, tuple] = LRUCache(16)


def refine_poses(points: np.ndarray, grid, normals: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Poses ``T`` (B, 4, 4) ``T_template_camera`` refined by point-to-plane ICP of ``points``
    (N, 3, camera frame) against the template (``grid``: a :class:`~catpose.cell_grid.CellGrid`
    of its points with reach at least :data:`REFINE_MAX_DISTANCE`; ``normals`` (M, 3)), pairing
    within :data:`REFINE_MAX_DISTANCE`; a copy of ``T`` when it holds no pose."""
    if len(T) == 0:
        return np.array(T, copy=True)
    return refine_many(points, grid, normals, T, REFINE_MAX_DISTANCE, REFINE_ITERATIONS)


def mesh_sample(template: Template) -> tuple:
    """(grid, normals): a fixed area-weighted sample of :data:`MESH_SAMPLES` points of the
    template's mesh (the same points under every seed; its triangles' unit normals) as a
    :class:`~catpose.cell_grid.CellGrid` of reach :data:`REFINE_MAX_DISTANCE`, cached per mesh."""
    key = template_hash(template, "vertices", "triangles")
    hit = _MESH_SAMPLES.get(key)
    if hit is None:
        v = np.asarray(template.vertices, dtype=np.float64)
        tri = v[np.asarray(template.triangles, dtype=np.int64)]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.sqrt((n * n).sum(axis=1))
        keep = area > 0
        tri, n, area = tri[keep], n[keep] / area[keep, None], area[keep]
        rng = np.random.default_rng(0)
        f = rng.choice(len(tri), MESH_SAMPLES, p=area / area.sum())
        a, b = rng.random(MESH_SAMPLES), rng.random(MESH_SAMPLES)
        flip = a + b > 1
        a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
        t = tri[f]
        points = t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0])
        hit = (cell_grid.build(points, REFINE_MAX_DISTANCE), np.ascontiguousarray(n[f]))
        _MESH_SAMPLES.put(key, hit)
    return hit


def final_inputs(verifier, template: Template) -> tuple:
    """(points, grid, normals) of :func:`refine_poses` for the last comparisons: the mask's
    pixels with depth on ``verifier``'s lattice back-projected (camera frame, the depth unit)
    against :func:`mesh_sample` of ``template``."""
    L = verifier.lattice
    keep = L.mask & (L.depth > 0)
    points = np.ascontiguousarray(L.depth[keep][:, None] * L.dirs[keep])
    return (points, *mesh_sample(template))
