"""Ours' last comparisons refine on points no seed draws (methods/ours/refine.py: mesh_sample,
final_inputs): the depth image's mask pixels on the check's lattice against a fixed mesh sample."""

from __future__ import annotations

import numpy as np
import trimesh

from catpose.geometry import compose_T, make_T, transform_points
from catpose.methods.ours.check import DepthVerifier
from catpose.methods.ours.refine import MESH_SAMPLES, final_inputs, mesh_sample, refine_poses
from tests.test_depth_check import _template, _view


def _distance(tpl, points: np.ndarray) -> np.ndarray:
    """Each point's distance from the template's mesh (Open3D)."""
    from catpose.o3d import o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(tpl.vertices.astype(np.float32)), o3d.core.Tensor(tpl.triangles.astype(np.uint32))
    )
    return scene.compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy()


def test_mesh_sample_is_fixed_and_on_the_mesh():
    tpl = _template()
    np.random.seed(1)
    grid, normals = mesh_sample(tpl)
    points = np.asarray(grid.points)
    assert points.shape == (MESH_SAMPLES, 3) and normals.shape == (MESH_SAMPLES, 3)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert _distance(tpl, points).max() < 1e-5
    # another template object with the same mesh (other sampled points): the same sample
    np.random.seed(2)
    other = type(tpl)(
        "test/other", "box", tpl.points[::2], tpl.normals[::2], vertices=tpl.vertices, triangles=tpl.triangles
    )
    np.testing.assert_array_equal(np.asarray(mesh_sample(other)[0].points), points)


def test_final_inputs_are_the_lattice_mask_pixels():
    tpl = _template()
    image, T_true = _view(tpl)
    v = DepthVerifier(tpl, image, tau=0.05, target_pixels=400)
    points, _, _ = final_inputs(v, tpl)
    L = v.lattice
    keep = L.mask & (L.depth > 0)
    assert len(points) == int(keep.sum()) > 100
    np.testing.assert_allclose(points[:, 2], L.depth[keep])
    # they lie on the template at the true pose
    in_template = transform_points(T_true, points)
    assert _distance(tpl, in_template).max() < 1e-4


def test_refining_on_them_recovers_a_nudged_pose():
    tpl = _template()
    image, T_true = _view(tpl)
    v = DepthVerifier(tpl, image, tau=0.05, target_pixels=800)
    nudge = make_T(trimesh.transformations.rotation_matrix(np.radians(3.0), [0, 0, 1])[:3, :3], [0.02, -0.01, 0.0])
    T = refine_poses(*final_inputs(v, tpl), compose_T(nudge, T_true)[None])[0]
    assert v.scores(T[None])[0] < v.scores(compose_T(nudge, T_true)[None])[0]
    assert np.abs(T[:3, 3] - T_true[:3, 3]).max() < 0.01
