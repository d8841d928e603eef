"""Small rigid-geometry helpers shared by datasets, methods and metrics (NumPy, float64).

Products of 3x3 matrices and (N, 3) points are written out in closed form (element-wise
multiplies and adds in a fixed order) rather than through ``@``: NumPy hands ``@`` to OpenBLAS,
whose kernel is chosen per CPU at run time (SkylakeX, Haswell, Sandybridge, ...) and rounds
differently (FMA or not, other summation orders). Closed form gives the same bits on every
machine, so a dataset's points and ground-truth poses do not depend on the CPU.
"""

from __future__ import annotations

import numpy as np


def matmul3(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A @ B`` for (3, 3) matrices, in closed form (bit-identical on every CPU)."""
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    return A[:, 0:1] * B[0] + A[:, 1:2] * B[1] + A[:, 2:3] * B[2]


def apply_R(R: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``vectors @ R.T`` for (3, 3) ``R`` and (N, 3) or (3,) vectors, in closed form."""
    R = np.asarray(R, dtype=np.float64)
    v = np.asarray(vectors, dtype=np.float64)
    return v[..., 0:1] * R[:, 0] + v[..., 1:2] * R[:, 1] + v[..., 2:3] * R[:, 2]


def compose_T(T_a_b: np.ndarray, T_b_c: np.ndarray) -> np.ndarray:
    """``T_a_c = T_a_b @ T_b_c`` for (4, 4) rigid transforms, in closed form."""
    return make_T(matmul3(T_a_b[:3, :3], T_b_c[:3, :3]), apply_R(T_a_b[:3, :3], T_b_c[:3, 3]) + T_a_b[:3, 3])


def make_T(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return the (4, 4) rigid transform with rotation ``R`` (3, 3) and translation ``t`` (3,)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(t).reshape(3)
    return T


def invert_T(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform: ``T_b_a`` from ``T_a_b``."""
    R, t = np.asarray(T, dtype=np.float64)[:3, :3], np.asarray(T, dtype=np.float64)[:3, 3]
    return make_T(R.T, -apply_R(R.T, t))


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply (4, 4) ``T`` to (N, 3) points."""
    return apply_R(T[:3, :3], points) + T[:3, 3]


def rotate_vectors(T_or_R: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate (N, 3) or (3,) direction vectors by the rotation part of a (4, 4) or (3, 3) matrix."""
    return apply_R(T_or_R[:3, :3], vectors)


def axis_angle_to_R(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rodrigues' formula: rotation by ``angle_rad`` about unit ``axis`` (3,)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle_rad) * K + (1 - np.cos(angle_rad)) * matmul3(K, K)


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation drawn uniformly from SO(3) (Shoemake's unit-quaternion method)."""
    u1, u2, u3 = rng.random(3)
    q = np.array([np.sqrt(1 - u1) * np.sin(2 * np.pi * u2), np.sqrt(1 - u1) * np.cos(2 * np.pi * u2),
                  np.sqrt(u1) * np.sin(2 * np.pi * u3), np.sqrt(u1) * np.cos(2 * np.pi * u3)])
    return quat_to_R(q)


def quat_to_R(q: np.ndarray) -> np.ndarray:
    """(x, y, z, w) unit quaternion(s) (..., 4) to rotation matrices (..., 3, 3)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ], axis=-1)
    return R.reshape(q.shape[:-1] + (3, 3))


def look_at_T_camera_world(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Camera extrinsics ``T_camera_world`` for an OpenCV camera (x right, y down, z forward)
    at ``eye`` looking at ``target`` with image-up roughly along world ``up``."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-8:  # looking straight along up: any perpendicular works
        x = np.cross(z, np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R_world_camera = np.stack([x, y, z], axis=1)
    return invert_T(make_T(R_world_camera, eye))


def normalize_to_unit_sphere(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre ``vertices`` (N, 3) at their bounding-box centre and scale the farthest to 1.

    Returns (normalised vertices, centre, scale) with ``v_norm = (v - centre) / scale``.
    """
    v = np.asarray(vertices, dtype=np.float64)
    centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
    scale = float(np.linalg.norm(v - centre, axis=1).max())
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError("cannot normalise a shape with zero extent")
    return (v - centre) / scale, centre, scale


def stable_seed(*parts: object) -> int:
    """A 63-bit seed derived deterministically from ``parts`` (independent of PYTHONHASHSEED)."""
    import hashlib

    h = hashlib.blake2b("\x1f".join(map(str, parts)).encode(), digest_size=8).digest()
    return int.from_bytes(h, "little") & ((1 << 63) - 1)
