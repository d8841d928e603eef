"""Local Patch Similarity (LPS), the paper's descriptor (Section III-B).

Local frame at a keypoint ``p`` with unit normal ``n_p`` and ground normal ``g`` (the up
direction, same frame): ``x = n_p``, ``y = g x x / |g x x|``, ``z = x x y``; when ``n_p`` is
within ``parallel_deg`` of +-g, PCA of the neighbourhood instead (:func:`local_frames`). The patch
is every point within ``radius`` of ``p`` (at most ``max_points`` nearest) in local coordinates
``R^T (q - p)``, ``R = [x y z]``: invariant to rigid motions that move the ground normal along.

Similarity of two patches = F-score at threshold ``tau`` (Tatarchenko et al. 2019).
:func:`fscore_voxel` computes it on grids (its exact all-pairs reference: tests/test_lps.py): each
patch becomes point counts on cells of ``tau / subdiv`` over [-radius, radius]^3 and a dilated
occupancy grid, and precision and recall of all pairs are two products ``counts_a @ dilated_b^T``
(effective threshold tau +- one cell diagonal). Rows of the affinity are normalised by the caller.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from catpose.methods.pfh import neighbourhoods


@dataclass(frozen=True, eq=False)
class Patches:
    """Local patches of K keypoints.

    Attributes:
        points: (K, k, 3) neighbour coordinates in each keypoint's local frame (0 where padded).
        mask: (K, k) bool, True for real points.
        frames: (K, 3, 3) local frames ``R`` (columns x, y, z) in the cloud's frame.
    """

    points: np.ndarray
    mask: np.ndarray
    frames: np.ndarray


def local_frames(
    points: np.ndarray,
    normals: np.ndarray,
    centres_idx: np.ndarray,
    ground_normal: np.ndarray,
    nb_idx: np.ndarray,
    nb_mask: np.ndarray,
    parallel_deg: float = 10.0,
) -> np.ndarray:
    """Local frames (K, 3, 3), columns (x, y, z), for keypoints ``points[centres_idx]``.

    Args:
        points: (N, 3) cloud; normals: (N, 3) unit normals; ground_normal: (3,) unit up, same frame.
        nb_idx, nb_mask: (K, k) neighbour indices and mask (from :func:`neighbourhoods`), used by the
            PCA fallback.
        parallel_deg: below this angle between ``n_p`` and +-g the PCA fallback is used.
    """
    g = np.asarray(ground_normal, dtype=np.float64)
    g = g / np.linalg.norm(g)
    x = normals[centres_idx].copy()
    y = np.cross(g, x)
    yn = np.linalg.norm(y, axis=1)
    fallback = yn < np.sin(np.deg2rad(parallel_deg))
    y = y / np.where(fallback, 1.0, yn)[:, None]
    for i in np.nonzero(fallback)[0]:
        q = points[nb_idx[i][nb_mask[i]]] - points[centres_idx[i]]
        if len(q) < 3:
            a = np.array([1.0, 0.0, 0.0]) if abs(x[i, 0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            yi = np.cross(x[i], a)
            y[i] = yi / np.linalg.norm(yi)
            continue
        _, vecs = np.linalg.eigh(q.T @ q)
        xi = vecs[:, 0] * (1.0 if vecs[:, 0] @ x[i] >= 0 else -1.0)
        yi = vecs[:, 2] - (vecs[:, 2] @ xi) * xi
        yi /= np.linalg.norm(yi)
        if np.sum((q @ yi) ** 3) < 0:
            yi = -yi
        x[i], y[i] = xi, yi
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=2)


def lps_patches(
    points: np.ndarray,
    normals: np.ndarray,
    centres_idx: np.ndarray,
    ground_normal: np.ndarray,
    radius: float,
    max_points: int = 128,
    parallel_deg: float = 10.0,
    tree=None,
) -> Patches:
    """Crop and express the patches of keypoints ``points[centres_idx]`` in their local frames."""
    nb_idx, nb_mask = neighbourhoods(points, points[centres_idx], radius, max_points, tree)
    frames = local_frames(points, normals, centres_idx, ground_normal, nb_idx, nb_mask, parallel_deg)
    rel = points[nb_idx] - points[centres_idx][:, None]
    local = np.einsum("kpi,kij->kpj", rel, frames)
    local[~nb_mask] = 0.0
    return Patches(points=local, mask=nb_mask, frames=frames)


@dataclass(frozen=True, eq=False)
class VoxelPatches:
    """Grid form of patches for :func:`fscore_voxel`: (K, G^3) float32 point counts, (K, G^3)
    float32 dilated occupancy, (K,) point counts."""

    counts: np.ndarray
    dilated: np.ndarray
    n: np.ndarray


def voxelize(p: Patches, radius: float, tau: float, subdiv: int = 1) -> VoxelPatches:
    """Grid the patches on [-radius, radius]^3 with cell ``tau / subdiv`` (see module docstring)."""
    from scipy.ndimage import binary_dilation

    cell = tau / subdiv
    G = int(np.ceil(2 * radius / cell))
    ijk = np.clip(np.floor((p.points + radius) / cell).astype(np.int64), 0, G - 1)
    flat = (ijk[..., 0] * G + ijk[..., 1]) * G + ijk[..., 2] + (np.arange(len(p.points)) * G**3)[:, None]
    counts = np.bincount(flat[p.mask], minlength=len(p.points) * G**3).reshape(len(p.points), G, G, G)
    r = np.arange(-subdiv, subdiv + 1)
    ball = (r[:, None, None] ** 2 + r[None, :, None] ** 2 + r[None, None, :] ** 2) <= subdiv**2 + 1e-9
    dil = binary_dilation(counts > 0, structure=ball[None])
    K = len(p.points)
    return VoxelPatches(
        counts=counts.reshape(K, -1).astype(np.float32),
        dilated=dil.reshape(K, -1).astype(np.float32),
        n=p.mask.sum(1).astype(np.float32),
    )


def fscore_voxel(a: VoxelPatches, b: VoxelPatches, dtype: type = np.float64) -> np.ndarray:
    """Approximate F-score (Ka, Kb) from grids: two sparse x dense products (``a``'s grids, the
    input's, are sparse), computed in float32 (the matched-point counts are small integers, so
    exact) and returned as ``dtype``. ``b`` may stack the keypoints of many partial templates."""
    from scipy import sparse

    prec = np.asarray(sparse.csr_matrix(a.counts) @ b.dilated.T) / np.maximum(a.n[:, None], 1)
    rec = np.asarray(sparse.csr_matrix(a.dilated) @ b.counts.T) / np.maximum(b.n[None], 1)
    s = prec + rec
    return np.where(s > 0, 2 * prec * rec / np.maximum(s, 1e-12), 0.0).astype(dtype)
