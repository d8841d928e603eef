"""Small rigid-geometry helpers shared by datasets, methods and metrics (NumPy, float64).

Dot products, lengths and products of 3x3 matrices and (N, 3) points are written out in closed
form (element-wise multiplies and adds in a fixed order) rather than through ``@`` or a 1-D
``np.linalg.norm``: NumPy hands those to OpenBLAS, whose kernel is chosen per CPU at run time
(SkylakeX, Haswell, Sandybridge, ...) and rounds differently (FMA or not, other summation
orders). Closed form gives the same bits on every machine, so a dataset's points and
ground-truth poses do not depend on the CPU. ``tests/test_portable_bits.py`` checks that no
BLAS product or CPU-dispatched transcendental remains under ``datasets/`` and ``src/catpose/``.
"""

from __future__ import annotations

import numpy as np


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product of 3-vectors along the last axis, ``a[..., 0] * b[..., 0] + ...``, in a fixed
    order: (3,) inputs give a float, (N, 3) inputs an (N,) array. ``a @ b`` on 1-D arrays is a
    BLAS ``ddot`` whose rounding depends on the CPU's kernel (SkylakeX fuses multiply-adds)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    out = a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]
    return float(out) if out.ndim == 0 else out


def norm3(v: np.ndarray) -> np.ndarray:
    """Euclidean length of 3-vectors along the last axis, in closed form (bit-identical on every
    CPU; ``np.linalg.norm`` of a 1-D vector calls BLAS ``ddot``). (3,) gives a float."""
    out = np.sqrt(dot3(v, v))
    return float(out) if np.ndim(out) == 0 else out


def unit3(v: np.ndarray) -> np.ndarray:
    """``v / |v|`` for (3,) or (N, 3) vectors, in closed form. Zero vectors give NaN (callers that
    can meet one check the length first)."""
    v = np.asarray(v, dtype=np.float64)
    return v / np.asarray(norm3(v))[..., None]


def matmul3(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A @ B`` for (..., 3, 3) matrices, in closed form (bit-identical on every CPU)."""
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    return A[..., 0:1] * B[..., 0:1, :] + A[..., 1:2] * B[..., 1:2, :] + A[..., 2:3] * B[..., 2:3, :]


def small_matmul(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A @ B`` for small (..., n, k) and (..., k, m) matrices without BLAS: ``np.einsum``'s own
    loops (no BLAS call, and not dispatched per CPU) give the same bits on every machine."""
    return np.einsum("...ij,...jk->...ik", np.asarray(A, dtype=np.float64), np.asarray(B, dtype=np.float64))


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


def axis_angle_to_R(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rodrigues' formula: rotation by ``angle_rad`` about unit ``axis`` (3,)."""
    a = unit3(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle_rad) * K + (1 - np.cos(angle_rad)) * matmul3(K, K)


def R_onto_z(up: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) that turns unit ``up`` onto +z by the shortest arc (about ``up x z``);
    the identity for ``up = z`` and a half turn about x for ``up = -z``."""
    up = unit3(np.asarray(up, dtype=np.float64))
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(up, z)
    s, c = norm3(axis), float(np.clip(up[2], -1.0, 1.0))
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    a = axis / s
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * matmul3(K, K)


def quat_to_R(q: np.ndarray) -> np.ndarray:
    """(x, y, z, w) unit quaternion(s) (..., 4) to rotation matrices (..., 3, 3)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.stack(
        [
            1 - 2 * (y * y + z * z),
            2 * (x * y - z * w),
            2 * (x * z + y * w),
            2 * (x * y + z * w),
            1 - 2 * (x * x + z * z),
            2 * (y * z - x * w),
            2 * (x * z - y * w),
            2 * (y * z + x * w),
            1 - 2 * (x * x + y * y),
        ],
        axis=-1,
    )
    return R.reshape(q.shape[:-1] + (3, 3))


def look_at_T_camera_world(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Camera extrinsics ``T_camera_world`` for an OpenCV camera (x right, y down, z forward)
    at ``eye`` looking at ``target`` with image-up roughly along world ``up``."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z = unit3(z)
    x = np.cross(z, up)
    if norm3(x) < 1e-8:  # looking straight along up: any perpendicular works
        x = np.cross(z, np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    x = unit3(x)
    y = np.cross(z, x)
    R_world_camera = np.stack([x, y, z], axis=1)
    return invert_T(make_T(R_world_camera, eye))


def smallest_eigenvector_sym3(C: np.ndarray) -> np.ndarray:
    """Unit eigenvector (3,) of the smallest eigenvalue of a symmetric (3, 3) ``C``, in closed
    form: the eigenvalues by the trigonometric formula (Smith 1961, the C library's ``acos`` and
    ``cos``), the vector as the longest cross product of two rows of ``C - lambda I``. Unlike
    LAPACK, whose kernel is chosen per CPU, it gives the same bits on every machine. The sign is
    arbitrary (callers orient it); a repeated smallest eigenvalue gives one vector of its plane.
    """
    import math

    C = np.asarray(C, dtype=np.float64)
    q = (C[0, 0] + C[1, 1] + C[2, 2]) / 3.0
    p1 = C[0, 1] * C[0, 1] + C[0, 2] * C[0, 2] + C[1, 2] * C[1, 2]
    p2 = (C[0, 0] - q) * (C[0, 0] - q) + (C[1, 1] - q) * (C[1, 1] - q) + (C[2, 2] - q) * (C[2, 2] - q) + 2.0 * p1
    if p2 <= 0.0:  # a multiple of the identity: every direction is an eigenvector
        return np.array([0.0, 0.0, 1.0])
    p = math.sqrt(p2 / 6.0)
    B = (C - q * np.eye(3)) / p
    det_B = (
        B[0, 0] * (B[1, 1] * B[2, 2] - B[1, 2] * B[2, 1])
        - B[0, 1] * (B[1, 0] * B[2, 2] - B[1, 2] * B[2, 0])
        + B[0, 2] * (B[1, 0] * B[2, 1] - B[1, 1] * B[2, 0])
    )
    phi = math.acos(min(max(det_B / 2.0, -1.0), 1.0)) / 3.0
    lam_min = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    M = C - lam_min * np.eye(3)
    crosses = np.stack([np.cross(M[0], M[1]), np.cross(M[0], M[2]), np.cross(M[1], M[2])])
    lengths = norm3(crosses)
    k = int(np.argmax(lengths))
    if lengths[k] <= 0.0:  # rank <= 1: any vector orthogonal to the non-zero row
        row = M[int(np.argmax(norm3(M)))]
        helper = np.array([1.0, 0.0, 0.0]) if abs(row[0]) < 0.9 * norm3(row) else np.array([0.0, 1.0, 0.0])
        return unit3(np.cross(row, helper))
    return crosses[k] / lengths[k]


def normalize_to_unit_sphere(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre ``vertices`` (N, 3) at their bounding-box centre and scale the farthest to 1.

    Returns (normalised vertices, centre, scale) with ``v_norm = (v - centre) / scale``.
    """
    v = np.asarray(vertices, dtype=np.float64)
    centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
    scale = float(norm3(v - centre).max())
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError("cannot normalise a shape with zero extent")
    return (v - centre) / scale, centre, scale


def stable_seed(*parts: object) -> int:
    """A 63-bit seed derived deterministically from ``parts`` (independent of PYTHONHASHSEED)."""
    import hashlib

    h = hashlib.blake2b("\x1f".join(map(str, parts)).encode(), digest_size=8).digest()
    return int.from_bytes(h, "little") & ((1 << 63) - 1)


def seed_everything(seed: int) -> None:
    """Seed Python, NumPy, and (when loaded) torch and Open3D, for one sample."""
    import random
    import sys

    seed32 = seed % (1 << 32)
    random.seed(seed32)
    np.random.seed(seed32)
    if "torch" in sys.modules:
        sys.modules["torch"].manual_seed(seed32)
    if "open3d" in sys.modules:
        from catpose.o3d import o3d

        o3d.utility.random.seed(seed32 % (1 << 31))
