"""Exact nearest-neighbour queries on a uniform cell grid, compiled (numba).

Ours asks hundreds of small nearest-neighbour questions per problem: 30 point-to-plane ICP
iterations on each of 12 hypotheses, and visibility-aware Chamfer scores of 30 poses. A
``cKDTree.query`` call costs tens of microseconds of Python and dispatch before any search, which
at ~256 queries a call is most of the time; here the whole refinement or scoring loop is one
compiled call that searches a grid directly.

The grid buckets the points by cells of edge ``cell`` (points sorted by cell, ``start[c]`` the
first of cell ``c``). A query scans the cells in rings of growing Chebyshev radius ``k`` around its
own cell; every point not yet scanned is at least ``k * cell`` away, so the search stops after
ring ``k`` once the best distance is at most that, or once ``k * cell`` exceeds the radius. The
answer is exact: the same distance as a KD-tree (``tests/test_cell_grid.py`` compares with
``scipy.spatial.cKDTree``), ties broken towards the lowest point index.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

#: grids larger than this get coarser cells (memory stays bounded for any input extent)
MAX_CELLS = 1 << 21


@dataclass(frozen=True, eq=False)
class CellGrid:
    """Points bucketed by cell.

    Attributes:
        points: (M, 3) float64, the points in their original order (indices refer to it).
        origin: (3,) lower corner of cell (0, 0, 0); ``cell``: cell edge (the points' unit).
        dims: (3,) int64 cells per axis; ``start``: (prod(dims) + 1,) int64 offsets into ``order``;
        order: (M,) int64 point indices sorted by cell (stable: by index within a cell).
    """

    points: np.ndarray
    origin: np.ndarray
    cell: float
    dims: np.ndarray
    start: np.ndarray
    order: np.ndarray


def build(points: np.ndarray, cell: float) -> CellGrid:
    """Grid of ``points`` (M, 3) with cells of edge ``cell`` (coarsened if the bounding box would
    need more than :data:`MAX_CELLS` cells)."""
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise ValueError(f"cell_grid.build: points must be (M, 3) with M > 0, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("cell_grid.build: points contain NaN or inf")
    lo, hi = p.min(axis=0), p.max(axis=0)
    cell = float(cell)
    if not cell > 0:
        raise ValueError(f"cell_grid.build: cell must be > 0, got {cell}")
    while np.prod(np.floor((hi - lo) / cell) + 1.0) > MAX_CELLS:  # in floats: no overflow
        cell *= 2.0
    dims = np.floor((hi - lo) / cell).astype(np.int64) + 1
    ijk = np.minimum(np.floor((p - lo) / cell).astype(np.int64), dims - 1)
    flat = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    order = np.argsort(flat, kind="stable").astype(np.int64)
    counts = np.bincount(flat, minlength=int(np.prod(dims)))
    start = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts, out=start[1:])
    return CellGrid(p, lo.astype(np.float64), cell, dims, start, order)


def nearest(grid: CellGrid, queries: np.ndarray, radius: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """Nearest grid point of each query within ``radius`` (inclusive).

    Args:
        grid: :func:`build` result.
        queries: (K, 3) points, the grid points' frame and unit.
        radius: search radius (``inf``: unbounded).

    Returns:
        distances (K,) float64 (``inf`` where none is within ``radius``) and indices (K,) int64
        into ``grid.points`` (``-1`` where none).
    """
    q = np.ascontiguousarray(queries, dtype=np.float64)
    d = np.empty(len(q))
    j = np.empty(len(q), dtype=np.int64)
    nearest_into(grid.points, grid.origin, grid.cell, grid.dims, grid.start, grid.order, q, float(radius), d, j)
    return d, j


def arrays(grid: CellGrid) -> tuple:
    """The grid's fields in the argument order of the compiled kernels."""
    return grid.points, grid.origin, grid.cell, grid.dims, grid.start, grid.order


@numba.njit(cache=True, nogil=True)
def _gap(f, c):  # pragma: no cover - compiled
    """Distance along one axis from a query at ``f`` to cell ``c``, both in cell units, less a
    slack of 1e-9 cells so that rounding in the bucketing can never prune the true neighbour."""
    g = c - f if c > f else f - (c + 1)
    return g - 1e-9 if g > 1e-9 else 0.0


@numba.njit(cache=True, nogil=True)
def _scan(points, start, order, c, x, y, z, best2, best_j, lim2):  # pragma: no cover - compiled
    """The points of cell ``c`` against the best so far: (best2, best_j, lim2)."""
    for s in range(start[c], start[c + 1]):
        p = order[s]
        dx = points[p, 0] - x
        dy = points[p, 1] - y
        dz = points[p, 2] - z
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best2 or (d2 == best2 and p < best_j):
            best2 = d2
            best_j = p
            if d2 < lim2:
                lim2 = d2
    return best2, best_j, lim2


@numba.njit(cache=True, nogil=True)
def _near_faces(f, c, n, cell, lim2):  # pragma: no cover - compiled
    """Range of cells next to cell ``c`` (of ``n``) along one axis whose gap to ``f`` is within
    ``sqrt(lim2)``: (lo, hi) within [c - 1, c + 1] and the grid."""
    lo, hi = c, c
    g = _gap(f, c - 1) * cell
    if c > 0 and g * g <= lim2:
        lo = c - 1
    g = _gap(f, c + 1) * cell
    if c + 1 < n and g * g <= lim2:
        hi = c + 1
    return lo, hi


@numba.njit(cache=True, nogil=True)
def nearest_one(points, origin, cell, dims, start, order, x, y, z, radius, hint=-1):  # pragma: no cover
    """(distance, index) of the nearest point to (x, y, z) within ``radius``; (inf, -1) if none
    (also for a non-finite query). ``hint``: index of a point likely to be near (e.g. this query's
    neighbour in the previous ICP iteration) or -1; its distance bounds the search from the start,
    so that only cells closer than it are scanned. The answer does not depend on it."""
    if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(z)):
        return np.inf, -1
    far = 1e12  # cell coordinates are clipped so that far-away queries cannot overflow
    fx = min(max((x - origin[0]) / cell, -far), far)
    fy = min(max((y - origin[1]) / cell, -far), far)
    fz = min(max((z - origin[2]) / cell, -far), far)
    ci, cj, ck = int(np.floor(fx)), int(np.floor(fy)), int(np.floor(fz))
    nx, ny, nz = dims[0], dims[1], dims[2]
    best2 = np.inf
    best_j = -1
    lim2 = radius * radius  # squared distance a cell must be within to be scanned
    if hint >= 0:
        dx = points[hint, 0] - x
        dy = points[hint, 1] - y
        dz = points[hint, 2] - z
        d2 = dx * dx + dy * dy + dz * dz
        if d2 <= lim2:
            best2, best_j, lim2 = d2, hint, d2
    # the first ring that can hold a cell of the grid
    k0 = 0
    if ci < 0:
        k0 = -ci
    elif ci >= nx:
        k0 = ci - nx + 1
    if cj < 0:
        k0 = max(k0, -cj)
    elif cj >= ny:
        k0 = max(k0, cj - ny + 1)
    if ck < 0:
        k0 = max(k0, -ck)
    elif ck >= nz:
        k0 = max(k0, ck - nz + 1)
    # every point of ring k (Chebyshev cell distance k >= 1) is at least (k - 1 + m) cells away,
    # m the query's distance to the nearest face of its own cell
    m = min(min(fx - ci, ci + 1 - fx), min(min(fy - cj, cj + 1 - fy), min(fz - ck, ck + 1 - fz)))
    m = m - 1e-9 if m > 1e-9 else 0.0
    if k0 == 0:
        best2, best_j, lim2 = _scan(points, start, order, (ci * ny + cj) * nz + ck, x, y, z, best2, best_j, lim2)
        k0 = 1
        # ring 1 (the common last ring near a surface): only the neighbours across the faces the
        # query is closer to than the best so far
        if (m * cell) * (m * cell) <= lim2:
            i_lo, i_hi = _near_faces(fx, ci, nx, cell, lim2)
            j_lo, j_hi = _near_faces(fy, cj, ny, cell, lim2)
            k_lo, k_hi = _near_faces(fz, ck, nz, cell, lim2)
            for i in range(i_lo, i_hi + 1):
                gx = _gap(fx, i) * cell
                for jj in range(j_lo, j_hi + 1):
                    gy = _gap(fy, jj) * cell
                    gxy2 = gx * gx + gy * gy
                    base = (i * ny + jj) * nz
                    for kk in range(k_lo, k_hi + 1):
                        if i == ci and jj == cj and kk == ck:
                            continue
                        gz = _gap(fz, kk) * cell
                        if gxy2 + gz * gz <= lim2:
                            best2, best_j, lim2 = _scan(points, start, order, base + kk, x, y, z, best2, best_j,
                                                        lim2)
            k0 = 2
    kmax = max(max(nx, ny), nz) + k0
    for k in range(k0, kmax + 1):
        lower = (k - 1 + m) * cell
        if lower * lower > lim2:
            break
        for i in range(max(ci - k, 0), min(ci + k, nx - 1) + 1):
            gx = _gap(fx, i) * cell
            gx2 = gx * gx
            if gx2 > lim2:
                continue
            edge_i = i == ci - k or i == ci + k
            for jj in range(max(cj - k, 0), min(cj + k, ny - 1) + 1):
                gy = _gap(fy, jj) * cell
                gxy2 = gx2 + gy * gy
                if gxy2 > lim2:
                    continue
                base = (i * ny + jj) * nz
                if edge_i or jj == cj - k or jj == cj + k:
                    for kk in range(max(ck - k, 0), min(ck + k, nz - 1) + 1):
                        gz = _gap(fz, kk) * cell
                        if gxy2 + gz * gz <= lim2:
                            best2, best_j, lim2 = _scan(points, start, order, base + kk, x, y, z, best2, best_j,
                                                        lim2)
                else:  # inside the shell only the two z faces belong to ring k
                    for kk in (ck - k, ck + k):
                        if 0 <= kk < nz:
                            gz = _gap(fz, kk) * cell
                            if gxy2 + gz * gz <= lim2:
                                best2, best_j, lim2 = _scan(points, start, order, base + kk, x, y, z, best2,
                                                            best_j, lim2)
    if best_j < 0 or best2 > radius * radius:
        return np.inf, -1
    return np.sqrt(best2), best_j


@numba.njit(cache=True, nogil=True)
def nearest_into(points, origin, cell, dims, start, order, queries, radius, out_d, out_j):  # pragma: no cover
    """:func:`nearest_one` for every row of ``queries`` (K, 3), into ``out_d`` (K,), ``out_j`` (K,)."""
    for q in range(queries.shape[0]):
        d, j = nearest_one(points, origin, cell, dims, start, order, queries[q, 0], queries[q, 1],
                           queries[q, 2], radius)
        out_d[q] = d
        out_j[q] = j
