"""Depth rendering, back-projection, normals and view sampling (catpose.datasets.render)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from catpose.datasets.render import PinholeCamera, depth_to_points, estimate_normals, render_depth
from catpose.errors import InvalidInputError
from catpose.geometry import axis_angle_to_R, invert_T, make_T, transform_points

# odd image size: the principal point falls on a pixel centre
CAMERA = PinholeCamera(width=161, height=121, fx=150.0, fy=140.0, cx=80.0, cy=60.0)
HALF = np.array([0.5, 0.3, 0.2])  # box half extents, object frame


def box_sdf(points_box: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Exact signed distance of (N, 3) points (box frame) to an axis-aligned box at the origin."""
    q = np.abs(points_box) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return outside + inside


def box_mesh() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=2 * HALF)


def test_box_sdf_reference() -> None:
    p = np.array([[0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.5, 1.3, 0.0]])
    np.testing.assert_allclose(box_sdf(p, HALF), [0.0, 0.5, -0.2, np.hypot(1.0, 1.0)])


def test_rendered_box_backprojects_onto_its_surface() -> None:
    mesh = box_mesh()
    R = axis_angle_to_R(np.array([0.3, 1.0, 0.2]), np.deg2rad(35.0))
    T_camera_object = make_T(R, np.array([0.1, -0.05, 3.0]))
    depth = render_depth(mesh.vertices, mesh.faces, T_camera_object, CAMERA)
    assert depth.shape == (CAMERA.height, CAMERA.width) and depth.dtype == np.float32
    points_camera, pixels = depth_to_points(depth, CAMERA)
    assert len(points_camera) > 500
    assert (depth[pixels[:, 0], pixels[:, 1]] > 0).all()
    points_object = transform_points(invert_T(T_camera_object), points_camera)
    # every back-projected pixel lies on the box surface (float32 rays: ~1e-6)
    assert np.abs(box_sdf(points_object, HALF)).max() < 1e-4
    # and the silhouette is the box's: pixels outside its projection are empty
    corners = transform_points(T_camera_object, np.array(trimesh.creation.box(extents=2 * HALF).vertices))
    u = CAMERA.fx * corners[:, 0] / corners[:, 2] + CAMERA.cx
    assert (pixels[:, 1] >= np.floor(u.min())).all() and (pixels[:, 1] <= np.ceil(u.max())).all()


def test_known_pixel_depth_is_analytic() -> None:
    mesh = box_mesh()
    # axis-aligned box 3 units in front of the camera: the centre pixel sees the front face
    T_camera_object = make_T(np.eye(3), np.array([0.0, 0.0, 3.0]))
    depth = render_depth(mesh.vertices, mesh.faces, T_camera_object, CAMERA)
    assert depth[60, 80] == pytest.approx(3.0 - HALF[2], abs=1e-5)
    assert depth[0, 0] == 0.0  # background

    # tilted box: an off-centre pixel's depth is the ray/plane intersection with the front face
    R = axis_angle_to_R(np.array([0.0, 1.0, 0.0]), np.deg2rad(30.0))
    T_camera_object = make_T(R, np.array([0.0, 0.0, 3.0]))
    depth = render_depth(mesh.vertices, mesh.faces, T_camera_object, CAMERA)
    n_camera = R @ np.array([0.0, 0.0, -1.0])  # front face (z = -0.2) normal, camera frame
    p_camera = transform_points(T_camera_object, np.array([[0.0, 0.0, -HALF[2]]]))[0]
    for row, col in [(60, 80), (70, 95), (52, 66)]:
        ray = np.array([(col - CAMERA.cx) / CAMERA.fx, (row - CAMERA.cy) / CAMERA.fy, 1.0])
        z = n_camera @ p_camera / (n_camera @ ray)  # ray point s * ray has z = s
        assert depth[row, col] == pytest.approx(z, abs=1e-5), (row, col)


def test_depth_to_points_hand_computed() -> None:
    camera = PinholeCamera(width=4, height=3, fx=2.0, fy=4.0, cx=1.0, cy=1.0)
    depth = np.zeros((3, 4))
    depth[0, 0] = 2.0
    depth[1, 1] = 1.0
    depth[2, 3] = 4.0
    depth[2, 0] = np.nan  # no measurement
    points, pixels = depth_to_points(depth, camera)
    np.testing.assert_array_equal(pixels, [[0, 0], [1, 1], [2, 3]])
    # x = (col - cx) z / fx, y = (row - cy) z / fy
    np.testing.assert_allclose(points, [[-1.0, -0.5, 2.0], [0.0, 0.0, 1.0], [4.0, 1.0, 4.0]])

    points, _ = depth_to_points(depth, camera, depth_range=(1.5, 3.0))
    np.testing.assert_allclose(points, [[-1.0, -0.5, 2.0]])
    mask = np.zeros((3, 4), dtype=bool)
    mask[2, 3] = True
    points, _ = depth_to_points(depth, camera, mask=mask)
    np.testing.assert_allclose(points, [[4.0, 1.0, 4.0]])


def test_depth_to_points_rejects_wrong_size() -> None:
    with pytest.raises(InvalidInputError, match="161x121"):
        depth_to_points(np.ones((10, 10)), CAMERA)


def test_estimate_normals_face_the_camera() -> None:
    rng = np.random.default_rng(0)
    # plane z = 2 + 0.5 x, seen from the origin
    xy = rng.uniform(-0.5, 0.5, size=(800, 2))
    points = np.column_stack([xy, 2.0 + 0.5 * xy[:, 0]])
    normals = estimate_normals(points, radius=0.15)
    expected = np.array([0.5, 0.0, -1.0]) / np.linalg.norm([0.5, 0.0, -1.0])
    np.testing.assert_allclose(normals, np.broadcast_to(expected, normals.shape), atol=1e-6)
