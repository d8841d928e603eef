"""Point Feature Histograms (Rusu et al. 2008) and their EMD affinity (paper Section III-B).

A keypoint's descriptor is the 125-bin histogram (5 bins for each Darboux-frame angle theta,
alpha, phi; no distance feature) of the pair features of all unordered pairs of its neighbours
within ``radius``, as PCL's ``computePairFeatures`` (:func:`pair_features`): only dot and cross
products, so invariant to rigid motions.

The affinity (:class:`catpose.methods.descriptors.PFH`) is ``A_jk = 1 / (EMD(h_j, h_k) + eps)``
(paper Eq. 1) with the *marginal EMD*: the L1 distance of the :func:`marginal_cdfs`, bin units, a
lower bound of the exact L1-ground EMD (tests/test_pfh.py checks the bound and the rank agreement).
"""

from __future__ import annotations

import numpy as np

BINS = 5


def neighbourhoods(
    points: np.ndarray, centres: np.ndarray, radius: float, max_nn: int, tree=None
) -> tuple[np.ndarray, np.ndarray]:
    """The up to ``max_nn`` nearest points of ``points`` (N, 3) within ``radius`` of each centre.

    Returns (K, max_nn) int indices into ``points`` (padded with 0) and a (K, max_nn) bool mask.
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(points) if tree is None else tree
    k = min(int(max_nn), len(points))
    dist, idx = tree.query(centres, k=k, distance_upper_bound=radius)
    dist, idx = np.asarray(dist).reshape(len(centres), k), np.asarray(idx).reshape(len(centres), k)
    mask = np.isfinite(dist)
    idx = np.where(mask, idx, 0)
    return idx, mask


def pair_features(p1: np.ndarray, n1: np.ndarray, p2: np.ndarray, n2: np.ndarray) -> tuple[np.ndarray, ...]:
    """PCL pair features (theta, alpha, phi) of point pairs, shapes (..., 3) -> three (...) arrays,
    and a (...) bool mask of valid pairs (distinct points, normal not along the line)."""
    d = p2 - p1
    dist = np.linalg.norm(d, axis=-1)
    valid = dist > 1e-12
    d = d / np.where(valid, dist, 1.0)[..., None]
    a1 = np.einsum("...i,...i->...", n1, d)
    a2 = np.einsum("...i,...i->...", n2, d)
    swap = np.arccos(np.clip(np.abs(a1), 0, 1)) > np.arccos(np.clip(np.abs(a2), 0, 1))
    u = np.where(swap[..., None], n2, n1)
    nt = np.where(swap[..., None], n1, n2)
    d = np.where(swap[..., None], -d, d)
    phi = np.where(swap, -a2, a1)
    v = np.cross(d, u)
    vn = np.linalg.norm(v, axis=-1)
    valid &= vn > 1e-12
    v = v / np.where(vn > 1e-12, vn, 1.0)[..., None]
    w = np.cross(u, v)
    alpha = np.einsum("...i,...i->...", v, nt)
    theta = np.arctan2(np.einsum("...i,...i->...", w, nt), np.einsum("...i,...i->...", u, nt))
    return theta, alpha, phi, valid


def pfh_descriptors(
    points: np.ndarray, normals: np.ndarray, centres: np.ndarray, radius: float, max_nn: int = 32, tree=None
) -> np.ndarray:
    """PFH histograms (K, 125) of keypoints ``centres`` (K, 3) over the cloud ``points`` (N, 3)
    with unit ``normals`` (N, 3); each row sums to 1 (uniform when a keypoint has no valid pair).
    Bin index = 25 * bin(theta) + 5 * bin(alpha) + bin(phi)."""
    idx, mask = neighbourhoods(points, centres, radius, max_nn, tree)
    P, N = points[idx], normals[idx]  # (K, k, 3)
    k = idx.shape[1]
    iu, ju = np.triu_indices(k, 1)
    theta, alpha, phi, valid = pair_features(P[:, iu], N[:, iu], P[:, ju], N[:, ju])
    valid &= mask[:, iu] & mask[:, ju]
    bt = np.clip(((theta + np.pi) / (2 * np.pi) * BINS).astype(np.int64), 0, BINS - 1)
    ba = np.clip(((alpha + 1) / 2 * BINS).astype(np.int64), 0, BINS - 1)
    bp = np.clip(((phi + 1) / 2 * BINS).astype(np.int64), 0, BINS - 1)
    flat = bt * BINS * BINS + ba * BINS + bp + (np.arange(len(idx)) * BINS**3)[:, None]
    hist = np.bincount(flat[valid], minlength=len(idx) * BINS**3).reshape(len(idx), BINS**3)
    hist = hist.astype(np.float64)
    total = hist.sum(axis=1, keepdims=True)
    return np.where(total > 0, hist / np.maximum(total, 1), 1.0 / BINS**3)


def marginal_cdfs(hist: np.ndarray) -> np.ndarray:
    """(K, 125) histograms -> (K, 15) concatenated CDFs of the three 5-bin marginals."""
    h = hist.reshape(-1, BINS, BINS, BINS)
    margs = [h.sum(axis=(2, 3)), h.sum(axis=(1, 3)), h.sum(axis=(1, 2))]
    return np.concatenate([np.cumsum(m, axis=1) for m in margs], axis=1)
