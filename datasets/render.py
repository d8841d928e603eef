"""Depth rendering and back-projection with a pinhole camera.

Rendering casts one ray per pixel with Open3D's ``RaycastingScene`` and recomputes each hit in
float64 from the hit triangle (:meth:`catpose.raycast.RayCaster.cast`), so depth images are the same bits on every
CPU whatever code path Embree takes. Depth is the z coordinate in the camera frame (OpenCV:
x right, y down, z forward), in the object-normalised unit, 0 where no surface was hit. The same camera model back-projects depth images from real
sensors (BOP, Redwood), so synthetic and real views go through one code path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose.errors import ConfigError, InvalidInputError
from catpose.geometry import transform_points
from catpose.raycast import RayCaster


def check_intrinsics(group: str, **values: float) -> None:
    """Raise a one-line :class:`ConfigError` unless every value (image size, focal length; pixels)
    is a positive finite number (an image size a positive integer): a zero or negative focal length would be scored as a mirrored or
    degenerate camera instead of failing (``fx=0`` even stalls the renderer)."""
    for key, value in values.items():
        try:
            ok = bool(
                np.isfinite(float(value)) and float(value) > 0 and (key not in ("width", "height") or int(value) >= 1)
            )
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ConfigError(
                f"{group}.{key}={value!r} must be a positive number of pixels; "
                f"set {group}.{key}=<pixels> (e.g. the PrimeSense fx=fy=525)"
            )


@dataclass(frozen=True)
class PinholeCamera:
    """Pinhole intrinsics in pixels; ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @classmethod
    def from_K(cls, K: np.ndarray, width: int, height: int) -> PinholeCamera:
        K = np.asarray(K, dtype=np.float64).reshape(3, 3)
        return cls(int(width), int(height), float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]))


def render_depth(
    vertices: np.ndarray, triangles: np.ndarray, T_camera_object: np.ndarray, camera: PinholeCamera
) -> np.ndarray:
    """Render the depth image of a triangle mesh, the same bits on every CPU.

    Pixel (row, col) is cast through image point (col, row), the OpenCV convention that
    :func:`depth_to_points` and real sensors' ``K`` use. The mesh is moved into the camera frame
    in closed form and each ray ``(0, (col - cx) / fx, (row - cy) / fy, 1)`` is cast by
    :meth:`~catpose.raycast.RayCaster.cast`, so the ray parameter is the depth itself.

    Args:
        vertices: (V, 3) mesh vertices in the object frame.
        triangles: (F, 3) vertex indices.
        T_camera_object: (4, 4) pose of the object in the camera frame.
        camera: intrinsics and image size.

    Returns:
        (H, W) float32 depth (camera-frame z), 0 where the ray hits nothing.
    """
    v_camera = transform_points(np.asarray(T_camera_object, dtype=np.float64), np.asarray(vertices, dtype=np.float64))
    rows, cols = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    dirs = np.stack([(cols - camera.cx) / camera.fx, (rows - camera.cy) / camera.fy, np.ones_like(cols)], axis=-1)
    z = RayCaster(v_camera, triangles).cast(np.zeros(3), dirs)
    return np.where(np.isfinite(z), z, 0.0).astype(np.float32)


def depth_to_points(
    depth: np.ndarray,
    camera: PinholeCamera,
    mask: np.ndarray | None = None,
    depth_range: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Back-project a depth image to camera-frame points.

    Args:
        depth: (H, W) depth (z) in scene units; 0 or non-finite means no measurement.
        camera: intrinsics; the image size must match ``depth``.
        mask: optional (H, W) bool mask of pixels to keep.
        depth_range: optional (near, far) to keep.

    Returns:
        (N, 3) points in the camera frame and (N, 2) int pixel coordinates (row, col).
    """
    depth = np.asarray(depth, dtype=np.float64)
    if depth.shape != (camera.height, camera.width):
        raise InvalidInputError(
            f"depth image is {depth.shape[1]}x{depth.shape[0]} but the camera is "
            f"{camera.width}x{camera.height}; fix the intrinsics or image size"
        )
    valid = np.isfinite(depth) & (depth > 0)
    if mask is not None:
        valid &= np.asarray(mask, dtype=bool)
    if depth_range is not None:
        valid &= (depth >= depth_range[0]) & (depth <= depth_range[1])
    rows, cols = np.nonzero(valid)
    z = depth[rows, cols]
    x = (cols - camera.cx) * z / camera.fx
    y = (rows - camera.cy) * z / camera.fy
    return np.stack([x, y, z], axis=1), np.stack([rows, cols], axis=1)


def estimate_normals(
    points: np.ndarray, radius: float, max_nn: int = 30, viewpoint: np.ndarray | None = None
) -> np.ndarray:
    """Unit normals by local plane fitting (Open3D hybrid KNN/radius search), flipped to face
    ``viewpoint`` (the camera origin by default)."""
    from catpose.o3d import o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64)))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=max_nn))
    normals = np.asarray(pcd.normals)
    vp = np.zeros(3) if viewpoint is None else np.asarray(viewpoint, dtype=np.float64)
    flip = np.einsum("ij,ij->i", normals, vp - points) < 0
    normals[flip] *= -1
    return normals
