"""Exact nearest-neighbour queries within a radius, on a uniform cell grid, compiled (numba).

Ours asks ~100,000 bounded nearest-neighbour questions per problem (ICP pairs, truncated Chamfer
scores); a ``cKDTree.query`` call costs tens of microseconds before any search. Here each cell
lists, once per template, every point within the radius of the cell's box, sorted by distance
from the cell's centre, so a query reads one list and stops at the first point the triangle
inequality puts beyond the best so far (with a margin far above rounding), and a whole loop is one
compiled call. The answer is exact: the distance and index of a KD-tree queried with
``distance_upper_bound`` (inclusive, ties towards the lowest index; ``tests/test_cell_grid.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

#: grids larger than this get coarser cells (memory stays bounded for any input extent)
MAX_CELLS = 1 << 21
#: cells per reach of a grid built once per template and queried by every registration (ours'
#: template grids): shorter lists per query for a one-off build and about 4x the memory
CACHED_CELLS_PER_REACH = 2


@dataclass(frozen=True, eq=False)
class CellGrid:
    """Per cell, every point within ``reach`` of the cell's box: a query for the nearest point
    within ``radius <= reach`` scans one list, with no search over cells. ICP pairing (0.05) and
    truncated Chamfer terms (0.1) ask exactly this, and on real scans about 40% of the queries
    (background and mask bleed) have no point in reach at all: an empty or short list.

    Attributes:
        points: (M, 3) float64, original order (indices refer to it).
        origin, cell, dims: the grid over the points' bounding box grown by ``reach`` (cell edge
            ``reach / cells_per_reach`` or coarser); a query outside it has no point within ``reach``.
        start: (prod(dims) + 1,) int64 offsets into ``cand``; cand: point indices, per cell by
            distance from the cell's centre (ties: ascending index); cand_r: those distances.
        reach: the largest radius the lists answer.
    """

    points: np.ndarray
    origin: np.ndarray
    cell: float
    dims: np.ndarray
    start: np.ndarray
    cand: np.ndarray
    cand_r: np.ndarray
    reach: float


def build(points: np.ndarray, reach: float, cells_per_reach: int = 1) -> CellGrid:
    """:class:`CellGrid` of ``points`` (M, 3) answering radii up to ``reach`` (cells of edge
    ``reach / cells_per_reach``, coarsened beyond :data:`MAX_CELLS`; with one cell per reach each
    point is listed in about 20 cells, with two in about 90, and a query's list is about half as
    long: a grid built once and queried often pays for the finer cells)."""
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise ValueError(f"cell_grid.build: points must be (M, 3) with M > 0, got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("cell_grid.build: points contain NaN or inf")
    reach = float(reach)
    if not reach > 0:
        raise ValueError(f"cell_grid.build: reach must be > 0, got {reach}")
    lo, hi = p.min(axis=0) - reach, p.max(axis=0) + reach
    if int(cells_per_reach) != cells_per_reach or cells_per_reach < 1:
        raise ValueError(f"cell_grid.build: cells_per_reach must be an integer >= 1, got {cells_per_reach}")
    cell = reach / int(cells_per_reach)
    while np.prod(np.floor((hi - lo) / cell) + 1.0) > MAX_CELLS:
        cell *= 2.0
    dims = np.floor((hi - lo) / cell).astype(np.int64) + 1
    counts = np.zeros(int(np.prod(dims)) + 1, dtype=np.int64)
    _reach_lists(p, lo, cell, dims, reach, counts, np.empty(0, dtype=np.int64), False)
    start = np.zeros_like(counts)
    np.cumsum(counts[:-1], out=start[1:])
    cand = np.empty(int(start[-1]), dtype=np.int64)
    _reach_lists(p, lo, cell, dims, reach, start.copy(), cand, True)
    cand_r = np.empty(len(cand))
    _sort_lists(p, lo, cell, dims, start, cand, cand_r)
    return CellGrid(p, lo, cell, dims, start, cand, cand_r, reach)


@numba.njit(cache=True, nogil=True)
def _centre(origin, cell, i, j, k):  # pragma: no cover - compiled
    """The centre of cell (i, j, k): the same expression wherever a list or a query needs it."""
    return origin[0] + (i + 0.5) * cell, origin[1] + (j + 0.5) * cell, origin[2] + (k + 0.5) * cell


@numba.njit(cache=True, nogil=True)
def _sort_lists(points, origin, cell, dims, start, cand, cand_r):  # pragma: no cover - compiled
    """Each cell's list (ascending indices) reordered by distance from the cell's centre, stably
    (equal distances keep ascending indices); ``cand_r`` gets the distances."""
    ny, nz = dims[1], dims[2]
    for c in range(start.shape[0] - 1):
        s0, s1 = start[c], start[c + 1]
        if s1 == s0:
            continue
        cx, cy, cz = _centre(origin, cell, c // (ny * nz), (c // nz) % ny, c % nz)
        r = np.empty(s1 - s0)
        for s in range(s0, s1):
            q = cand[s]
            dx, dy, dz = points[q, 0] - cx, points[q, 1] - cy, points[q, 2] - cz
            r[s - s0] = np.sqrt(dx * dx + dy * dy + dz * dz)
        order = np.argsort(r, kind="mergesort")
        listed = cand[s0:s1].copy()
        for t in range(s1 - s0):
            cand[s0 + t] = listed[order[t]]
            cand_r[s0 + t] = r[order[t]]


@numba.njit(cache=True, nogil=True)
def _reach_lists(points, origin, cell, dims, reach, slots, cand, fill):  # pragma: no cover - compiled
    """Count (``fill`` False: into ``slots[c]``) or write (``fill`` True: at ``slots[c]``, the
    running offsets) each point into every cell whose box is within ``reach`` of it, plus a slack
    of 1e-9 cells for rounding. Points are visited in index order, so each list is ascending."""
    lim = reach + 1e-9 * cell
    lim2 = lim * lim
    nx, ny, nz = dims[0], dims[1], dims[2]
    span = int(np.ceil(reach / cell)) + 1  # cells within reach, +1 against rounding in floor
    for p in range(points.shape[0]):
        x, y, z = points[p, 0], points[p, 1], points[p, 2]
        ci = int(np.floor((x - origin[0]) / cell))
        cj = int(np.floor((y - origin[1]) / cell))
        ck = int(np.floor((z - origin[2]) / cell))
        # +-span cells: the box test decides, the wider loop only guards against rounding in floor
        for i in range(max(ci - span, 0), min(ci + span, nx - 1) + 1):
            gx = max(origin[0] + i * cell - x, x - (origin[0] + (i + 1) * cell), 0.0)
            for j in range(max(cj - span, 0), min(cj + span, ny - 1) + 1):
                gy = max(origin[1] + j * cell - y, y - (origin[1] + (j + 1) * cell), 0.0)
                for k in range(max(ck - span, 0), min(ck + span, nz - 1) + 1):
                    gz = max(origin[2] + k * cell - z, z - (origin[2] + (k + 1) * cell), 0.0)
                    if gx * gx + gy * gy + gz * gz <= lim2:
                        c = (i * ny + j) * nz + k
                        if fill:
                            cand[slots[c]] = p
                        slots[c] += 1


def arrays(grid: CellGrid) -> tuple:
    """The grid's fields in the argument order of :func:`nearest_one` (for compiled callers)."""
    return grid.points, grid.origin, grid.cell, grid.dims, grid.start, grid.cand, grid.cand_r


def nearest(grid: CellGrid, queries: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Nearest grid point of each query (K, 3) within ``radius <= grid.reach`` (inclusive):
    distances (K,) (``inf`` where none) and indices (K,) (``-1`` where none)."""
    if not radius <= grid.reach:
        raise ValueError(f"cell_grid.nearest: radius {radius} exceeds the grid's reach {grid.reach}")
    q = np.ascontiguousarray(queries, dtype=np.float64)
    d = np.empty(len(q))
    j = np.empty(len(q), dtype=np.int64)
    _nearest_into(*arrays(grid), q, float(radius), d, j)
    return d, j


@numba.njit(cache=True, nogil=True)
def nearest_one(points, origin, cell, dims, start, cand, cand_r, x, y, z, radius):  # pragma: no cover - compiled
    """(distance, index) of the nearest point to (x, y, z) within ``radius`` (at most the grid's
    reach, inclusive; ties to the lowest index); (inf, -1) if none or the query is not finite.
    The cell's list is read in order of distance from the cell's centre ``c`` until a point's
    ``|p - c| - |q - c|`` (a lower bound of ``|q - p|``) exceeds the best distance so far, with a
    margin (1e-12 relative, 1e-12 cells) far above the rounding of these distances."""
    fx = (x - origin[0]) / cell
    fy = (y - origin[1]) / cell
    fz = (z - origin[2]) / cell
    # also false for NaN: outside the grid (or not finite) no point is within reach
    if not (0.0 <= fx < dims[0] and 0.0 <= fy < dims[1] and 0.0 <= fz < dims[2]):
        return np.inf, -1
    i, j, k = int(fx), int(fy), int(fz)
    c = (i * dims[1] + j) * dims[2] + k
    cx, cy, cz = _centre(origin, cell, i, j, k)
    qc = np.sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz))
    slack = 1e-12 * cell
    best2 = radius * radius
    bound = radius * (1.0 + 1e-12) + slack  # no listed point further from c than this + qc can win
    best_j = -1
    for s in range(start[c], start[c + 1]):
        if cand_r[s] - qc > bound:
            break
        p = cand[s]
        dx = points[p, 0] - x
        dy = points[p, 1] - y
        dz = points[p, 2] - z
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best2 or (d2 == best2 and (best_j < 0 or p < best_j)):
            best2 = d2
            best_j = p
            bound = np.sqrt(d2) * (1.0 + 1e-12) + slack
    if best_j < 0:
        return np.inf, -1
    return np.sqrt(best2), best_j


@numba.njit(cache=True, nogil=True)
def _nearest_into(points, origin, cell, dims, start, cand, cand_r, queries, radius, out_d, out_j):  # pragma: no cover
    for q in range(queries.shape[0]):
        d, j = nearest_one(
            points, origin, cell, dims, start, cand, cand_r, queries[q, 0], queries[q, 1], queries[q, 2], radius
        )
        out_d[q] = d
        out_j[q] = j
