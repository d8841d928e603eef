"""Exact maximum clique of an undirected graph, compiled with numba (the TEASER solver's step 2).

Tomita and Seki's MCQ branch and bound (greedy sequential colouring as the bound; DMTCS 2003) on
uint64 bitsets as San Segundo's BBMC, with an explicit stack so that the search can pause and
resume; first, as TEASER++'s PMC, the graph is pruned to the ``(s - 1)``-core that a greedy clique
of size ``s`` implies. Past ``node_budget`` search-tree nodes or ``time_budget_s`` seconds it
returns the best clique so far (at least the greedy one: from each of the 16 highest-degree
vertices, add the candidate with the most candidate neighbours) and says it is not exact. It
returns the same clique, ties included, as the pure-Python MCQ it replaced (networkx's
``max_weight_clique`` picks other ties, which would move TEASER's answers).
"""

from __future__ import annotations

import time

import numba
import numpy as np

_CHUNK_NODES = 4096  # search-tree nodes between two checks of the time budget
GREEDY_STARTS = 16
_ONE = np.uint64(1)


@numba.njit(cache=True, nogil=True)
def _popcount(x):
    """Set bits of a uint64 (SWAR)."""
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@numba.njit(cache=True, nogil=True)
def _greedy_clique(adj, nbr, starts):
    n = adj.shape[0]
    A = adj.view(np.uint8)
    deg = np.zeros(n, dtype=np.int64)
    for u in range(n):
        for w in range(nbr.shape[1]):
            deg[u] += _popcount(nbr[u, w])
    best = np.empty(0, dtype=np.int64)
    cl = np.empty(n, dtype=np.int64)  # candidates (common neighbours), ascending
    cdeg = np.empty(n, dtype=np.int64)  # candidate neighbours of each candidate
    gone = np.empty(n, dtype=np.int64)
    for s in starts:
        if deg[s] + 1 <= len(best):  # cannot beat the best so far (nor can any later start)
            break
        k = 0
        for u in range(n):
            if adj[s, u]:
                cl[k] = u
                k += 1
        for a in range(k):
            c = 0
            for w in range(nbr.shape[1]):
                c += _popcount(nbr[cl[a], w] & nbr[s, w])
            cdeg[a] = c
        clique = [s]
        while k > 0:
            ia = 0
            for a in range(1, k):  # most candidate neighbours, lowest vertex on ties
                if cdeg[a] > cdeg[ia]:
                    ia = a
            v = cl[ia]
            clique.append(v)
            kept, ngone = 0, 0
            for a in range(k):  # keep v's neighbours, in order
                u = cl[a]
                if a != ia and adj[v, u]:
                    cl[kept] = u
                    cdeg[kept] = cdeg[a]
                    kept += 1
                else:
                    gone[ngone] = u
                    ngone += 1
            k = kept
            for g in range(ngone):  # the leavers no longer count as candidate neighbours
                r = gone[g]
                for a in range(k):
                    cdeg[a] -= A[r, cl[a]]
        if len(clique) > len(best):
            best = np.array(clique, dtype=np.int64)
    return best


def greedy_clique(adj: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Multi-start greedy clique (the lower bound and the budget fallback).

    From each start vertex, repeatedly add the candidate (common neighbour of the clique) with
    the most candidate neighbours, lowest index on ties. Returns the largest clique (the first
    start's on ties) as (s,) int64 vertex indices in the order added.

    Args:
        adj: (N, N) symmetric bool adjacency, false diagonal.
        starts: (S,) start vertices in non-increasing degree (a start whose degree cannot beat
            the best clique so far ends the loop).
    """
    adj = np.ascontiguousarray(adj, dtype=bool)
    return _greedy_clique(adj, _bitsets(adj), np.asarray(starts, dtype=np.int64))


@numba.njit(cache=True, nogil=True)
def _colour_sort(nbr, P, kmin, ordr, colr, U, Q):
    """Greedy sequential colouring of the vertex bitset ``P`` in index order (MCQ's bound).

    Writes the vertices of colour ``>= kmin`` and their colours (non-decreasing) to ``ordr`` and
    ``colr`` and returns how many; a vertex of smaller colour can never lead past the incumbent.
    ``U``, ``Q``: (W,) uint64 scratch.
    """
    W = P.shape[0]
    for w in range(W):
        U[w] = P[w]
    cnt, k, wlo = 0, 0, 0
    while True:
        while wlo < W and U[wlo] == 0:
            wlo += 1
        if wlo == W:
            return cnt
        k += 1
        for w in range(wlo, W):
            Q[w] = U[w]
        wq = wlo
        while True:
            while wq < W and Q[wq] == 0:
                wq += 1
            if wq == W:
                break
            x = Q[wq]
            lsb = x & (~x + _ONE)
            v = wq * 64 + np.int64(_popcount(lsb - _ONE))  # the lowest set bit's index
            U[wq] &= ~lsb
            Q[wq] &= ~lsb
            for w in range(wq, W):
                Q[w] &= ~nbr[v, w]
            if k >= kmin:
                ordr[cnt] = v
                colr[cnt] = k
                cnt += 1


@numba.njit(cache=True, nogil=True)
def _branch_and_bound(nbr, P, ordr, colr, pos, cur, best, meta, U, Q, node_stop):
    """MCQ with an explicit stack; runs until the search is over (returns 0) or the count of
    expanded nodes ``meta[2]`` reaches ``node_stop`` (returns 1; call again to resume).

    Level ``d`` (clique ``cur[:d]``) holds the candidate bitset ``P[d]``, its coloured branching
    list ``ordr[d], colr[d]`` and the position ``pos[d]`` of the next branch, taken from the end
    (highest colour first). ``meta`` = [depth, size of ``best``, nodes expanded].
    """
    W = P.shape[1]
    d = meta[0]
    while d >= 0:
        if meta[2] >= node_stop:
            meta[0] = d
            return 1
        k = pos[d]
        if k < 0 or d + colr[d, k] <= meta[1]:  # exhausted, or no colour class left can beat best
            d -= 1
            if d >= 0:  # the branch on ordr[d, pos[d]] is done: drop that vertex from P[d]
                v = ordr[d, pos[d]]
                P[d, v >> 6] &= ~(_ONE << np.uint64(v & 63))
                pos[d] -= 1
            continue
        v = ordr[d, k]
        cur[d] = v
        nonempty = False
        for w in range(W):
            P[d + 1, w] = P[d, w] & nbr[v, w]
            if P[d + 1, w] != 0:
                nonempty = True
        if not nonempty:
            if d + 1 > meta[1]:
                meta[1] = d + 1
                best[: d + 1] = cur[: d + 1]
            P[d, v >> 6] &= ~(_ONE << np.uint64(v & 63))
            pos[d] -= 1
            continue
        meta[2] += 1
        pos[d + 1] = _colour_sort(nbr, P[d + 1], meta[1] - d, ordr[d + 1], colr[d + 1], U, Q) - 1
        d += 1
    meta[0] = -1
    return 0


def k_core(adj: np.ndarray, k: int) -> np.ndarray:
    """Vertices of the k-core (every kept vertex has >= k kept neighbours); bool (N,)."""
    keep = np.ones(len(adj), dtype=bool)
    deg = adj.sum(axis=1)
    while True:
        drop = keep & (deg < k)
        if not drop.any():
            return keep
        keep &= ~drop
        deg = deg - adj[:, drop].sum(axis=1)


def _bitsets(adj: np.ndarray) -> np.ndarray:
    """(r, W) uint64 rows of an (r, m) bool array: bit ``j % 64`` of word ``j // 64`` of row
    ``i`` is ``adj[i, j]``, ``W = ceil(m / 64)``."""
    r, m = adj.shape
    W = max(1, -(-m // 64))
    padded = np.zeros((r, 64 * W), dtype=bool)
    padded[:, :m] = adj
    return np.packbits(padded, axis=1, bitorder="little").view("<u8").astype(np.uint64)


def max_clique(
    adj: np.ndarray, node_budget: int = 200_000, time_budget_s: float | None = None
) -> tuple[np.ndarray, bool]:
    """Maximum clique of an undirected graph.

    Args:
        adj: (N, N) symmetric bool adjacency with a false diagonal.
        node_budget: maximum number of search-tree nodes.
        time_budget_s: maximum seconds of search (None: no limit).

    Returns:
        (sorted vertex indices of the clique, whether the search was exact). Past a budget the
        best clique found so far (at least the greedy clique, see the module docstring) is
        returned with False.
    """
    t_start = time.perf_counter()
    adj = np.ascontiguousarray(adj, dtype=bool)
    n = len(adj)
    if n == 0:
        return np.zeros(0, dtype=np.int64), True
    starts = np.argsort(-adj.sum(axis=1), kind="stable")[:GREEDY_STARTS].astype(np.int64)
    best = greedy_clique(adj, starts)
    verts = np.flatnonzero(k_core(adj, max(len(best) - 1, 0)))
    if len(verts) <= len(best):
        return np.sort(best), True
    sub = adj[np.ix_(verts, verts)]
    # order by degree (descending): the low bits, coloured first, are the high-degree vertices
    order = np.argsort(-sub.sum(axis=1), kind="stable")
    sub = sub[np.ix_(order, order)]
    local_to_global = verts[order]
    global_to_local = np.full(n, -1, dtype=np.int64)
    global_to_local[local_to_global] = np.arange(len(local_to_global))
    m = len(sub)
    nbr = _bitsets(sub)
    W = nbr.shape[1]
    U, Q = np.zeros(W, np.uint64), np.zeros(W, np.uint64)

    # the root (one node): colour every vertex; the number of colours bounds the clique size
    root = _bitsets(np.ones((1, m), dtype=bool))[0]
    ordr0, colr0 = np.zeros(m, np.int32), np.zeros(m, np.int32)
    cnt = _colour_sort(nbr, root, len(best) + 1, ordr0, colr0, U, Q)
    if cnt == 0:
        return np.sort(best), True
    levels = int(colr0[cnt - 1]) + 2
    P = np.zeros((levels, W), dtype=np.uint64)
    P[0] = root
    ordr, colr = np.zeros((levels, m), np.int32), np.zeros((levels, m), np.int32)
    ordr[0], colr[0] = ordr0, colr0
    pos = np.full(levels, -1, dtype=np.int64)
    pos[0] = cnt - 1
    cur = np.zeros(levels, dtype=np.int64)
    best_local = np.zeros(levels, dtype=np.int64)
    best_local[: len(best)] = global_to_local[best]
    meta = np.array([0, len(best), 1], dtype=np.int64)
    exact = True
    while True:
        node_stop = min(int(meta[2]) + _CHUNK_NODES, node_budget + 1)
        if _branch_and_bound(nbr, P, ordr, colr, pos, cur, best_local, meta, U, Q, node_stop) == 0:
            break
        if meta[2] > node_budget or (time_budget_s is not None and time.perf_counter() - t_start > time_budget_s):
            exact = False
            break
    return np.sort(local_to_global[best_local[: meta[1]]]), exact
