"""K-medoids of a dissimilarity matrix: PAM's BUILD, then FasterPAM's eager swaps, in NumPy.

Schubert and Rousseeuw, "Fast and eager k-medoids clustering: O(k) runtime improvement of the
PAM, CLARA, and CLARANS algorithms", Information Systems 101, 2021 (FasterPAM); Kaufman and
Rousseeuw, "Partitioning Around Medoids", 1990 (BUILD). The ``kmedoids`` package implements the
same algorithm in Rust under the GPL-3.0; this one (MIT, with the project) visits the points in
index order, as ``kmedoids.fasterpam(D, k, init="build", random_state=None)`` does, and
``tests/test_fasterpam.py`` compares the two where ``kmedoids`` is installed and both against an
exhaustive search on small problems.

With ``D`` (N, N) symmetric, zero diagonal, and medoids ``M`` (K,), the loss is
``sum_i min_m D[i, M[m]]``. BUILD adds, K times, the point that lowers the loss most. FasterPAM
then goes through the non-medoids ``j`` in order; for each, the change of the loss when ``j``
replaces medoid ``b`` is, for every ``b`` at once (the journal version's O(N) step):

    change(b) = removal(b) + sum_i [D_ij < dn_i] (D_ij - dn_i)
              + sum_{i: n_i = b} ([D_ij < dn_i] (dn_i - ds_i) + [dn_i <= D_ij < ds_i] (D_ij - ds_i))

with ``dn_i``, ``ds_i`` the distances to the nearest and second nearest medoid, ``n_i`` the
nearest's slot and ``removal(b) = sum_{i: n_i = b} (ds_i - dn_i)``. The best ``b`` is swapped
at once when its change is negative (by more than a relative 1e-12, so that rounding never
swaps between equal losses); the search stops when a whole pass since the last swap finds none.
"""

from __future__ import annotations

import numpy as np

#: a swap must lower the loss by more than this fraction of it (ties and rounding never swap)
RELATIVE_TOLERANCE = 1e-12


def _assignment(D: np.ndarray, medoids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nearest medoid slot (N,), its distance (N,) and the second nearest's distance (N,);
    a medoid is its own nearest, ties go to the lower slot."""
    k = len(medoids)
    Dm = D[:, medoids].copy()
    Dm[medoids, np.arange(k)] = -1.0  # a medoid's own slot first, even beside a duplicate point
    order = np.argsort(Dm, axis=1, kind="stable")
    rows = np.arange(len(D))
    near = order[:, 0]
    return near, D[rows, medoids[near]], D[rows, medoids[order[:, 1]]]


def build(D: np.ndarray, k: int) -> np.ndarray:
    """PAM's BUILD: K medoid indices (K,), each the point that lowers the loss most (ties: the
    lowest index); the first one minimises the sum of distances to all points."""
    medoids = [int(np.argmin(D.sum(axis=0)))]
    nearest = D[:, medoids[0]].copy()
    for _ in range(1, k):
        gain = np.minimum(D - nearest[:, None], 0.0).sum(axis=0)  # (N,) loss change per candidate
        gain[medoids] = np.inf
        best = int(np.argmin(gain))
        medoids.append(best)
        nearest = np.minimum(nearest, D[:, best])
    return np.array(medoids, dtype=int)


def fasterpam(D: np.ndarray, k: int, max_iter: int = 100) -> tuple[np.ndarray, float]:
    """K medoids (K,) of the dissimilarity matrix ``D`` (N, N) and their loss (the sum of each
    point's distance to its nearest medoid). BUILD, then FasterPAM's swaps in index order, at
    most ``max_iter`` passes. Deterministic: no random order, no random start."""
    D = np.asarray(D, dtype=float)
    n = len(D)
    if D.ndim != 2 or D.shape != (n, n):
        raise ValueError(f"D must be a square (N, N) matrix, got shape {D.shape}")
    if not 1 <= k <= n:
        raise ValueError(f"k={k} must be between 1 and N={n}")
    medoids = build(D, k)
    if k == 1 or k == n:
        return medoids, float(D[:, medoids].min(axis=1).sum())
    near, dn, ds = _assignment(D, medoids)
    loss = float(dn.sum())
    last_swap = n  # no swap yet: the first pass visits every point
    for _ in range(max_iter):
        swapped = False
        removal = np.bincount(near, weights=ds - dn, minlength=k)
        for j in range(n):
            if j == last_swap:
                break  # a whole pass since the last swap found nothing better
            if medoids[near[j]] == j:
                continue
            dj = D[j]
            closer = dj < dn
            acc = float(np.where(closer, dj - dn, 0.0).sum())
            own = np.where(closer, dn - ds, np.where(dj < ds, dj - ds, 0.0))
            change = removal + np.bincount(near, weights=own, minlength=k) + acc
            b = int(np.argmin(change))
            if change[b] >= -RELATIVE_TOLERANCE * max(loss, 1.0):
                continue
            candidate = medoids.copy()
            candidate[b] = j
            c_near, c_dn, c_ds = _assignment(D, candidate)
            if float(c_dn.sum()) >= loss:  # rounding: the predicted gain is not there
                continue
            medoids, near, dn, ds, loss = candidate, c_near, c_dn, c_ds, float(c_dn.sum())
            removal = np.bincount(near, weights=ds - dn, minlength=k)
            last_swap, swapped = j, True
        if not swapped:
            break
    return medoids, loss
