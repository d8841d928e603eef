"""The shared kernels (src/catpose: kabsch, hpr, point_to_plane, lru, content_hash) and the keypoint
samplers (methods/keypoints.py), each against an independent reference."""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from catpose.content_hash import content_hash, template_key
from catpose.geometry import make_T
from catpose.kabsch import kabsch
from catpose.lru import LRUCache
from catpose.methods.keypoints import farthest_point_indices, voxel_downsample
from catpose.types import Template

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _point_to_plane_reference import refine_point_to_plane  # noqa: E402


# ----------------------------------------------------------------------------- kabsch
@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("mirror", [False, True])
def test_kabsch_matches_scipy_align_vectors(weighted: bool, mirror: bool) -> None:
    """Rotation and translation agree with scipy's weighted Wahba solution on centred points,
    also when the target is mirrored (no rotation fits: both return the best proper rotation)."""
    rng = np.random.default_rng(1)
    P = rng.normal(size=(3, 40, 3))
    Q = P @ Rotation.random(random_state=rng).as_matrix().T + rng.normal(size=3) + 0.05 * rng.normal(size=P.shape)
    if mirror:
        Q = Q * np.array([1.0, 1.0, -1.0])
    w = rng.uniform(0.1, 2.0, size=(3, 40)) if weighted else np.ones((3, 40))
    T = kabsch(P, Q, w if weighted else None)
    for b in range(3):
        wn = w[b] / w[b].sum()
        mp, mq = wn @ P[b], wn @ Q[b]
        R_ref, _ = Rotation.align_vectors(Q[b] - mq, P[b] - mp, weights=w[b])
        np.testing.assert_allclose(T[b, :3, :3], R_ref.as_matrix(), atol=1e-9)
        np.testing.assert_allclose(T[b, :3, 3], mq - R_ref.as_matrix() @ mp, atol=1e-9)
        np.testing.assert_allclose(np.linalg.det(T[b, :3, :3]), 1.0)


def test_kabsch_unbatched_recovers_an_exact_transform() -> None:
    rng = np.random.default_rng(2)
    P = rng.normal(size=(10, 3))
    T_gt = make_T(Rotation.random(random_state=rng).as_matrix(), [0.3, -1.0, 2.0])
    T = kabsch(P, P @ T_gt[:3, :3].T + T_gt[:3, 3])
    assert T.shape == (4, 4)
    np.testing.assert_allclose(T, T_gt, atol=1e-10)


# ----------------------------------------------------------------------------- hidden point removal
def test_hpr_equals_open3d_and_keeps_the_facing_side() -> None:
    from catpose.hpr import visible_indices
    from catpose.o3d import o3d

    rng = np.random.default_rng(0)
    p = rng.normal(size=(2000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    viewpoint = np.array([0.0, 0.0, 3.0])
    idx = visible_indices(p, viewpoint, 100.0)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    radius = 100.0 * np.linalg.norm(p - viewpoint, axis=1).max()
    _, ref = pcd.hidden_point_removal(viewpoint, radius)
    np.testing.assert_array_equal(idx, np.sort(np.asarray(ref)))
    assert idx.dtype == np.int64 and np.all(np.diff(idx) > 0)
    # on a unit sphere seen from distance 3 the visible cap is z > 1/3; HPR is approximate near it
    assert np.all(p[idx, 2] > 0.1)
    assert np.mean(p[idx, 2] > 1 / 3) > 0.9 and len(idx) > 0.8 * np.sum(p[:, 2] > 1 / 3)


# ----------------------------------------------------------------------------- point-to-plane
def _box_cloud(rng: np.random.Generator, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Points and outward normals on the faces of a 1 x 0.6 x 0.4 box (three plane directions)."""
    half = np.array([0.5, 0.3, 0.2])
    axis = rng.integers(0, 3, n)
    sign = rng.choice([-1.0, 1.0], n)
    p = rng.uniform(-1, 1, size=(n, 3)) * half
    p[np.arange(n), axis] = sign * half[axis]
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), axis] = sign
    return p, nrm


def _refine_reference(src, tgt, tgt_n, T, max_distance, iterations):
    """Brute-force point-to-plane ICP: all-pairs nearest neighbours, lstsq, scipy rotations."""
    T = T.copy()
    for _ in range(iterations):
        s = src @ T[:3, :3].T + T[:3, 3]
        d = np.linalg.norm(s[:, None] - tgt[None], axis=2)
        j = d.argmin(1)
        ok = d[np.arange(len(s)), j] <= max_distance
        if ok.sum() < 6:
            break
        s, q, n = s[ok], tgt[j[ok]], tgt_n[j[ok]]
        J = np.concatenate([np.cross(s, n), n], axis=1)
        x = np.linalg.lstsq(J, np.einsum("ij,ij->i", q - s, n), rcond=None)[0]
        T = make_T(Rotation.from_rotvec(x[:3]).as_matrix(), x[3:]) @ T
        if np.linalg.norm(x) < 1e-7:
            break
    return T


def test_point_to_plane_matches_a_brute_force_reference_and_recovers_the_pose() -> None:
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(3)
    tgt, tgt_n = _box_cloud(rng)
    T_gt = make_T(Rotation.from_rotvec([0.05, -0.03, 0.04]).as_matrix(), [0.02, -0.03, 0.01])
    src = (tgt[::3] - T_gt[:3, 3]) @ T_gt[:3, :3]  # T_gt maps src onto the target
    for iterations in (1, 3, 30):
        T = refine_point_to_plane(src, tgt, tgt_n, cKDTree(tgt), np.eye(4), 0.2, iterations)
        T_ref = _refine_reference(src, tgt, tgt_n, np.eye(4), 0.2, iterations)
        np.testing.assert_allclose(T, T_ref, atol=1e-8)
    np.testing.assert_allclose(T, T_gt, atol=1e-6)
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)


# ----------------------------------------------------------------------------- keypoint sampling
def test_farthest_point_sampling_matches_brute_force() -> None:
    rng = np.random.default_rng(4)
    p = rng.normal(size=(300, 3))
    D = np.linalg.norm(p[:, None] - p[None], axis=2)
    for start in (0, 17):
        ref = [start]
        for _ in range(39):
            ref.append(int(np.argmax(D[:, ref].min(axis=1))))
        np.testing.assert_array_equal(farthest_point_indices(p, 40, start), ref)
    np.testing.assert_array_equal(np.sort(farthest_point_indices(p[:5], 9)), np.arange(5))


def test_voxel_downsample_keeps_the_first_point_per_voxel() -> None:
    rng = np.random.default_rng(5)
    p = rng.uniform(0, 1, size=(500, 3))
    n = rng.normal(size=(500, 3))
    q, m = voxel_downsample(p, n, 0.25)
    first = {}
    for i, key in enumerate(map(tuple, np.floor(p / 0.25).astype(int))):
        first.setdefault(key, i)
    keep = sorted(first.values())
    np.testing.assert_array_equal(q, p[keep])
    np.testing.assert_array_equal(m, n[keep])
    assert voxel_downsample(p, n, 0.0)[0] is p


# ----------------------------------------------------------------------------- LRU cache
def test_lru_cache_evicts_the_least_recently_used() -> None:
    c: LRUCache[str, int] = LRUCache(2)
    c.put("a", 1)
    c.put("b", 2)
    assert c.get("a") == 1  # a is now the most recent
    c.put("c", 3)  # evicts b, not a
    assert c.get("b") is None and list(c._data) == ["a", "c"]
    built = []
    assert c.get_or_build("a", lambda: built.append(1) or 9) == 1 and not built
    assert c.get_or_build("d", lambda: built.append(1) or 4) == 4 and built == [1]
    assert list(c._data) == ["a", "d"]
    c.clear()
    assert c.get("a") is None and c.get("d") is None
    with pytest.raises(ValueError, match="maxsize"):
        LRUCache(0)


# ----------------------------------------------------------------------------- content hash
def test_content_hash_is_blake2b_of_the_float64_bytes() -> None:
    rng = np.random.default_rng(6)
    a, b = rng.normal(size=(10, 3)), rng.normal(size=(10, 3))
    ref = hashlib.blake2b(a.tobytes() + b.tobytes() + b"x", digest_size=10).hexdigest()
    assert content_hash(a, b, extra="x", digest_size=10) == ref
    assert content_hash(a.astype(np.float32).astype(np.float64)) != content_hash(a)
    nrm = a / np.linalg.norm(a, axis=1, keepdims=True)
    t1 = Template("set/chair 1", "chair", a, nrm)
    t2 = Template("set/chair 1", "chair", a + 1e-9, nrm)
    assert template_key(t1).startswith("set_chair_1-") and template_key(t1) != template_key(t2)
