"""Inconsistency counters of a registration (section 1 of the paper: a consistent
registration locates every cutting vertex once and walks every cutting edge through
the simulation mesh), vectorised with numpy: rows of vertex ids are compared as whole
rows (``void`` views), never in Python loops over pairs.

Used by :class:`~predicates.registration.result.intersection.IntersectionResult` and by the demo's
robust-against-naive table.
"""
from __future__ import annotations

import itertools

import numpy as np

from predicates.registration.result.pairs import any_corner

__all__ = ["broken_edges", "broken_walks", "cell_faces", "location_counts", "rows_in"]


def _void(rows: np.ndarray) -> np.ndarray:
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    return rows.view(np.dtype((np.void, 8 * rows.shape[1]))).ravel()


def rows_in(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """For every row of ``rows`` (n, w) of ids ≥ −1: is it a row of ``table`` (m, w)?"""
    if len(rows) == 0 or len(table) == 0:
        return np.zeros(len(rows), dtype=bool)
    base = int(max(rows.max(), table.max())) + 2
    w = rows.shape[1]
    if base ** w < 2 ** 62:  # one int64 key per row: a fast integer isin
        def key(a):
            k = np.zeros(len(a), dtype=np.int64)
            for c in range(w):
                k = k * base + (a[:, c].astype(np.int64) + 1)
            return k
        # only rows of either side whose first id starts a row of the other are kept;
        # the smaller side is sorted, the other looked up by binary search
        first_t = np.zeros(base, dtype=bool)
        first_t[table[:, 0].astype(np.int64) + 1] = True
        cand = np.flatnonzero(first_t[rows[:, 0].astype(np.int64) + 1])
        first_r = np.zeros(base, dtype=bool)
        first_r[rows[cand, 0].astype(np.int64) + 1] = True
        table = table[first_r[table[:, 0].astype(np.int64) + 1]]
        out = np.zeros(len(rows), dtype=bool)
        if len(cand) == 0 or len(table) == 0:
            return out
        kr, kt = key(rows[cand]), key(table)
        if len(kt) <= len(kr):
            kt = np.unique(kt)
            out[cand] = kt[np.minimum(np.searchsorted(kt, kr), len(kt) - 1)] == kr
            return out
        ukr, inv = np.unique(kr, return_inverse=True)
        pos = np.minimum(np.searchsorted(ukr, kt), len(ukr) - 1)
        found = np.zeros(len(ukr), dtype=bool)
        found[pos[ukr[pos] == kt]] = True
        out[cand] = found[inv.ravel()]
        return out
    return np.isin(_void(rows), _void(table))


def _padded(rows: np.ndarray, width: int) -> np.ndarray:
    """Rows sorted ascending, left-padded with −1 to ``width`` columns."""
    out = np.full((len(rows), width), -1, dtype=np.int64)
    out[:, width - rows.shape[1]:] = np.sort(rows, axis=1)
    return out


def cell_faces(cells: np.ndarray) -> np.ndarray:
    """Every face (vertex, edge, ..., the cell itself) of every cell as a sorted row
    left-padded with −1 to the cell's width (repeated where cells share faces)."""
    k = cells.shape[1]
    parts = [_padded(cells[:, list(c)].reshape(-1, r), k)
             for r in range(1, k + 1) for c in itertools.combinations(range(k), r)]
    return np.concatenate(parts)


def location_counts(res, side: str = "cut") -> np.ndarray:
    """For every point of the ``side`` mesh ("cut" or "sim"): in how many registered
    pairs that vertex is itself the primitive."""
    n = len(res.cut_points if side == "cut" else res.sim_points)
    counts = np.zeros(n, dtype=np.int64)
    for k in res.kinds:
        p = res.pairs[k]
        ids = p.cut if side == "cut" else p.sim
        if ids.shape[1] == 1:
            counts += np.bincount(ids[:, 0], minlength=n)
    return counts


def _events(res, width: int):
    """(edge a, edge b, t, padded sim primitive, located cut vertex) of every pair whose
    cutting primitive is a vertex (t unused) or an edge (t = weight of b, the larger id),
    in kind order then row order (the order ties keep)."""
    loc_v, loc_p, ea, eb, et, ep = [], [], [], [], [], []
    for kind in res.kinds:
        p = res.pairs[kind]
        if len(p) == 0:
            continue
        if p.cut.shape[1] == 1:
            loc_v.append(p.cut[:, 0])
            loc_p.append(_padded(p.sim, width))
        elif p.cut.shape[1] == 2:
            a, b = p.cut.min(axis=1), p.cut.max(axis=1)
            t = np.where(p.cut[:, 0] == a, p.cut_weights[:, 1], p.cut_weights[:, 0])
            ea.append(a), eb.append(b), et.append(t.astype(np.float64))
            ep.append(_padded(p.sim, width))
    cat = (lambda xs, shape: np.concatenate(xs) if xs else np.zeros(shape, np.int64))
    return (cat(loc_v, 0), cat(loc_p, (0, width)), cat(ea, 0), cat(eb, 0),
            cat(et, 0).astype(np.float64), cat(ep, (0, width)))


def _union(x: np.ndarray, y: np.ndarray, width: int):
    """Row-wise union of two padded id rows: (padded union, fits in ``width``)."""
    u = np.sort(np.concatenate([x, y], axis=1), axis=1)
    dup = np.zeros_like(u, dtype=bool)
    dup[:, 1:] = u[:, 1:] == u[:, :-1]
    u[dup] = -1
    u.sort(axis=1)
    fits = np.all(u[:, : u.shape[1] - width] < 0, axis=1)
    return u[:, u.shape[1] - width:], fits


def broken_walks(res) -> int:
    """The number of :func:`broken_edges`."""
    return len(broken_edges(res))


def broken_edges(res) -> np.ndarray:
    """(k, 2) cutting edges (vertex ids, sorted) whose registered events do not form a walk through the simulation
    mesh (see :meth:`IntersectionResult.broken_walks`): between consecutive events the
    edge runs inside one cell, so consecutive event primitives must lie in a common
    cell. Only edges whose both endpoints are located exactly once are checked."""
    width = res.sim_cells.shape[1]
    loc_v, loc_p, ea, eb, et, ep = _events(res, width)
    n = len(res.cut_points)
    count = np.bincount(loc_v, minlength=n) if len(loc_v) else np.zeros(n, np.int64)
    where = np.full((n, width), -1, dtype=np.int64)
    once = count[loc_v] == 1
    where[loc_v[once]] = loc_p[once]
    cc = res.cut_cells
    edges = np.unique(np.sort(np.concatenate(
        [cc[:, list(c)] for c in itertools.combinations(range(cc.shape[1]), 2)]), axis=1),
        axis=0) if len(cc) else np.zeros((0, 2), np.int64)
    edges = edges[(count[edges[:, 0]] == 1) & (count[edges[:, 1]] == 1)]
    if len(edges) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    # events of the checked edges, endpoints at t = -inf / +inf
    m = len(edges)
    ekey = edges[:, 0] * n + edges[:, 1]  # ascending: edges are unique rows, sorted
    key = ea * n + eb
    eid = np.minimum(np.searchsorted(ekey, key), m - 1)
    keep = ekey[eid] == key
    E = np.concatenate([np.arange(m), eid[keep], np.arange(m)])
    T = np.concatenate([np.full(m, -np.inf), et[keep], np.full(m, np.inf)])
    P = np.concatenate([where[edges[:, 0]], ep[keep], where[edges[:, 1]]])
    order = np.lexsort((T, E))  # stable: ties keep kind/row order
    E, P = E[order], P[order]
    same = E[1:] == E[:-1]
    u, fits = _union(P[:-1][same], P[1:][same], width)
    # only the cells with a vertex of some union can hold one: the cost follows the cut
    on = np.zeros(len(res.sim_points) + 1, dtype=bool)
    on[u[u >= 0]] = True
    near = res.sim_cells[any_corner(on, res.sim_cells)]
    ok = fits & rows_in(u, cell_faces(near))
    return edges[np.unique(E[:-1][same][~ok])]
