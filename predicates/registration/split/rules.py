"""The rules of the virtual-node split (docs/split.md), vectorised with numpy.

Everything here is derived from the registered pairs only (paper, section 1: the
hierarchical registration), so the split inherits their consistency: a simulation edge
is either severed in every cell that contains it or in none, a vertex is on the cut in
every cell or in none. See ``docs/split.md`` for the rules, their sources (Molino, Bao
and Fedkiw 2004; Wang, Jiang, Schroeder and Teran, adaptive VNA) and approximations.

The only loops are over constants (the d+1 corners or the C(d+1, 2) local edges of one
cell, the kinds) or over rounds of the vectorised union-find, never over cells or edges.
Where speed matters, columns are gathered as 1D arrays (``take``) rather than rows of a
(k, 3) array, and short rows are sorted by a network of ``minimum`` / ``maximum``.
"""
from __future__ import annotations

import itertools

import numpy as np

from predicates.registration.spatial.boxgrid import any_corner, expand

__all__ = ["LOCAL_EDGES", "any_corner", "cell_hits", "components", "fragments", "glue", "on_cut_vertices",
           "match_rows", "row_components", "row_keys", "rows_touched", "severed_edges",
           "sort_rows"]

#: The local edges (pairs of corner positions) of a triangle (2D) and a tetrahedron (3D).
LOCAL_EDGES = {d: tuple(itertools.combinations(range(d + 1), 2)) for d in (2, 3)}

#: Compare-exchange networks (column pairs) sorting rows of w = 1, 2, 3, 4 values.
NETWORKS = {1: (), 2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 1)),
            4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2))}


def sort_rows(x: np.ndarray) -> np.ndarray:
    """``np.sort(x, axis=-1)`` for integer arrays whose last axis has 1–4 entries (an
    edge, a face, a cell), by a sorting network of column-wise ``minimum`` / ``maximum``:
    several times faster than ``np.sort`` along so short an axis (a call per row), and
    exact (integers). Other widths and dtypes: ``np.sort``."""
    x = np.asarray(x)
    w = x.shape[-1]
    if w not in NETWORKS or x.dtype.kind not in "iu":
        return np.sort(x, axis=-1)
    cols = [x[..., j].copy() for j in range(w)]
    for i, j in NETWORKS[w]:
        lo = np.minimum(cols[i], cols[j])
        np.maximum(cols[i], cols[j], out=cols[j])
        cols[i] = lo
    return np.stack(cols, axis=-1)


def row_keys(rows: np.ndarray, n: int) -> np.ndarray:
    """One comparable key per row of ``rows`` (k, w) of ids in 0..n−1: equal rows get
    equal keys. An exact int64 when n^w < 2^62, else the row's bytes (a void scalar:
    sorts consistently, compares by equality)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    w = rows.shape[1]
    if float(max(n, 1)) ** w < 2.0 ** 62:
        key = np.zeros(len(rows), dtype=np.int64)
        for c in range(w):
            key = key * max(n, 1) + rows[:, c]
        return key
    return rows.view(np.dtype((np.void, 8 * w))).ravel()


def match_rows(rows: np.ndarray, table: np.ndarray, n: int):
    """Every pair (i, j) with ``rows[i] == table[j]`` (ids in 0..n−1). Only the rows
    whose first id starts some row of the table are searched (a look-up per row), each
    by one binary search in the table's sorted distinct keys — no sort of ``rows``."""
    if len(rows) == 0 or len(table) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.zeros(n, dtype=bool)
    starts[table[:, 0]] = True
    cand = np.flatnonzero(starts[rows[:, 0]])
    if float(max(n, 1)) ** rows.shape[1] < 2.0 ** 62:
        kr, kt = row_keys(rows, n)[cand], row_keys(table, n)  # keys, then a 1D gather
    else:  # ids renumbered among the table's: int64 keys, not byte strings, if they fit
        used = np.zeros(n, dtype=bool)
        used[table.ravel()] = True
        cand = cand[used[rows[cand]].all(axis=1)]
        rank = np.cumsum(used) - 1
        base = int(rank[-1]) + 1
        kr, kt = row_keys(rank[rows[cand]], base), row_keys(rank[table], base)
    order = np.argsort(kt, kind="stable")
    ukey, first, count = np.unique(kt[order], return_index=True, return_counts=True)
    at = np.minimum(np.searchsorted(ukey, kr), len(ukey) - 1)
    hit = np.flatnonzero(ukey[at] == kr)
    i, k = expand(first[at[hit]], count[at[hit]])
    return cand[hit[i]], order[k]


def on_cut_vertices(res, n: int) -> np.ndarray:
    """(n,) bool: simulation vertices registered ON the cut — the simulation primitive of
    a vertex_vertex, vertex_edge or (3D) vertex_triangle pair."""
    on = np.zeros(n, dtype=bool)
    for kind in res.kinds:
        p = res[kind]
        if p.sim.shape[1] == 1 and len(p):
            on[p.sim[:, 0]] = True
    return on


def rows_touched(cells: np.ndarray, combos: np.ndarray, touched: np.ndarray,
                 rows_ok: np.ndarray | None = None):
    """The rows (cell, combination of corners) of ``cells`` whose every vertex is
    ``touched`` (a bool per vertex), or where ``rows_ok`` ((C, len(combos)) bool) is set,
    in (cell, combination) order: their flat indices cell·len(combos) + combination and
    their vertex ids sorted. Only those can be a registered primitive: the others are
    never built, sorted or searched. Column by column (1D gathers)."""
    combos = np.asarray(combos)
    C, m = cells.shape
    if rows_ok is None:
        ok = [touched.take(cells[:, k]) for k in range(m)]
        rows_ok = np.stack([np.logical_and.reduce([ok[k] for k in c]) for c in combos], 1)
    flat = np.flatnonzero(rows_ok.ravel())
    cell, combo = np.divmod(flat, len(combos))
    at = cell * m
    flat_cells = cells.ravel()
    cols = [flat_cells.take(at + combos[:, i].take(combo)) for i in range(combos.shape[1])]
    return flat, sort_rows(np.stack(cols, axis=1))


def severed_edges(res, cells: np.ndarray, n: int) -> np.ndarray:
    """(C, E) bool: local edge e of cell c is crossed by the cut — its simulation edge is
    the simulation primitive of a registered edge_vertex, edge_edge or (3D) edge_triangle
    pair. An edge crossed twice is severed all the same (docs/split.md)."""
    d = cells.shape[1] - 1
    E = np.array(LOCAL_EDGES[d])
    flag = np.zeros(len(cells) * len(E), dtype=bool)
    crossed = [res[k].sim for k in res.kinds if res[k].sim.shape[1] == 2 and len(res[k])]
    if crossed:
        crossed = sort_rows(np.concatenate(crossed))
        touched = np.zeros(n, dtype=bool)
        touched[crossed.ravel()] = True
        flat, local = rows_touched(cells, E, touched)
        flag[flat[match_rows(local, crossed, n)[0]]] = True
    return flag.reshape(len(cells), len(E))


def _corner_labels(off: np.ndarray, severed: np.ndarray) -> np.ndarray:
    """(k, m) int8: per corner the smallest corner of its component of off-cut corners
    through unsevered edges (min-label propagation), m for an on-cut corner."""
    m = off.shape[1]
    lab = np.where(off, np.arange(m, dtype=np.int8), np.int8(m))
    E = LOCAL_EDGES[m - 1]
    conn = ~severed & np.stack([off[:, a] & off[:, b] for a, b in E], axis=1)
    for _ in range(m - 1):  # a component of m corners has paths of at most m - 1 edges
        for e, (a, b) in enumerate(E):
            lo = np.minimum(lab[:, a], lab[:, b])
            lab[:, a] = np.where(conn[:, e], lo, lab[:, a])
            lab[:, b] = np.where(conn[:, e], lo, lab[:, b])
    return lab


def fragments(cells: np.ndarray, on_cut: np.ndarray, severed: np.ndarray):
    """The fragments of every cell: the connected components of its OFF-cut vertices
    through its unsevered edges (Molino et al. 2004: one copy of the element
    per material component). A cell whose vertices are all on the cut is one fragment.

    Returns ``cell_origin`` (F,), ``frag_of`` (C, d+1): the fragment (new cell) holding
    each off-cut corner as material, −1 for on-cut corners, and ``material`` (F, d+1):
    off-cut corners of the fragment's own component, and every on-cut corner (a vertex on
    the cut lies on the closure of every fragment that touches it)."""
    C, m = cells.shape
    off = ~on_cut[cells]
    # a cell with every corner off the cut and no severed edge is one component,
    # labelled 0 everywhere: only the others need the propagation
    lab = np.zeros((C, m), dtype=np.int8)
    plain = np.logical_and.reduce([off[:, k] for k in range(m)])
    plain &= ~np.logical_or.reduce([severed[:, e] for e in range(severed.shape[1])])
    some = np.flatnonzero(~plain)
    lab[some] = _corner_labels(off.take(some, axis=0), severed.take(some, axis=0))
    rep = off & (lab == np.arange(m))
    rep[~any_corner(~on_cut, cells), 0] = True  # all corners on the cut: one fragment
    cell_origin, rep_corner = np.nonzero(rep)  # new cells ordered by (cell, representative)
    new_id = np.full((C, m), -1, dtype=np.int64)
    new_id[cell_origin, rep_corner] = np.arange(len(cell_origin))
    frag_of = np.where(off, np.take_along_axis(new_id, np.minimum(lab, m - 1), axis=1), -1)
    # column by column: 1D gathers of the (cell_origin) rows
    own = np.arange(len(cell_origin))
    material = np.stack([(frag_of[:, k].take(cell_origin) == own)
                         | on_cut[cells[:, k].take(cell_origin)] for k in range(m)], axis=1)
    return cell_origin.astype(np.int64), frag_of, material


def _face_keys(by_id: np.ndarray, n: int) -> np.ndarray:
    """The keys (:func:`row_keys`) of the faces of cells whose vertex ids are sorted
    (``by_id``, (C, m)), face k omitting the k-th smallest: occurrence k·C + c. From
    whole columns (no (C, d) copies) when the key is an exact int64."""
    C, m = by_id.shape
    if float(max(n, 1)) ** (m - 1) >= 2.0 ** 62:
        return np.concatenate([row_keys(np.delete(by_id, k, axis=1), n) for k in range(m)])
    col = [np.ascontiguousarray(by_id[:, j]) for j in range(m)]
    out = np.empty(m * C, dtype=np.int64)
    for k in range(m):
        key = out[k * C:(k + 1) * C]
        key[:] = 0
        for j in range(m):
            if j != k:
                key *= max(n, 1)
                key += col[j]
    return out


def glue(cells: np.ndarray, frag_of: np.ndarray, n: int, first: np.ndarray,
         covered=None):
    """Glue fragments of neighbouring cells across their shared face (Molino et al. 2004:
    copies sharing material on a common face share that face's nodes): through a
    material (off-cut) vertex of the face in both, or — a face whose vertices are all on
    the cut — when ``covered`` (faces (k, d) -> (k,) bool, :mod:`.cover`) says the
    cutting surface does not cover it; such a cell has one fragment, ``first[c]``.
    Returns (g1, g2): glued fragment pairs, each once per face, and (s1, s2): identified
    node slots (slot = fragment·(d+1) + corner), every vertex of the face for every glue.
    Faces shared by more than two cells are glued pairwise along the sorted order."""
    C, m = cells.shape
    n_frag = max(int(frag_of.max(initial=-1)), int(first.max(initial=-1))) + 1
    dt = np.int32 if n_frag * m < 2 ** 31 else np.int64  # slots fit: half the bytes
    order = np.argsort(cells, axis=1, kind="stable")
    by_id = np.take_along_axis(cells, order, axis=1)
    frag_by_id = np.take_along_axis(frag_of, order, axis=1).astype(dt)
    order = order.astype(dt)
    # occurrence k·C + c: the face of cell c omitting its k-th smallest vertex, its
    # vertices by increasing id; column j of L / G: the corner position / fragment (−1:
    # on the cut) of its j-th vertex. Kept as 1D columns: 1D gathers are several times
    # faster than gathers of (k, 3) rows
    cols = [[j for j in range(m) if j != k] for k in range(m)]
    L = [np.concatenate([order[:, c[j]] for c in cols]) for j in range(m - 1)]
    G = [np.concatenate([frag_by_id[:, c[j]] for c in cols]) for j in range(m - 1)]
    fid = _face_keys(by_id, n)
    srt = np.argsort(fid, kind="stable")
    fid = fid.take(srt)
    same = np.flatnonzero(fid[1:] == fid[:-1])
    o1, o2 = srt.take(same), srt.take(same + 1)
    L1, L2 = [x.take(o1) for x in L], [x.take(o2) for x in L]
    F1, F2 = [x.take(o1) for x in G], [x.take(o2) for x in G]
    # witnesses: a material vertex of the face in both cells; a fragment pair already
    # glued through an earlier vertex of the same face is not repeated
    p, g1, g2 = [], [], []
    for j in range(m - 1):
        new = F1[j] >= 0
        for i in range(j):
            new &= (F1[i] != F1[j]) | (F2[i] != F2[j])
        pj = np.flatnonzero(new)
        p.append(pj)
        g1.append(F1[j].take(pj))
        g2.append(F2[j].take(pj))
    on = F1[0] < 0
    for j in range(1, m - 1):
        on &= F1[j] < 0
    q = np.flatnonzero(on)  # every vertex of the face on the cut
    if len(q) and covered is not None:
        k1, c1 = np.divmod(o1[q], C)
        c2 = o2[q] % C
        faces = np.stack([by_id[c1, np.array(cols)[k1, j]] for j in range(m - 1)], axis=1)
        keep = ~covered(faces)
        q, c1, c2 = q[keep], c1[keep], c2[keep]
        p.append(q)
        g1.append(first[c1].astype(dt))
        g2.append(first[c2].astype(dt))
    p, g1, g2 = np.concatenate(p), np.concatenate(g1), np.concatenate(g2)
    s1 = np.concatenate([g1 * m + x.take(p) for x in L1])
    s2 = np.concatenate([g2 * m + x.take(p) for x in L2])
    return (g1, g2), (s1, s2)


def components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Connected components of the graph on 0..n−1 with edges (a[i], b[i]): the smallest
    member of each node's component (int64); :func:`row_components` of the two columns."""
    return row_components(n, [a, b])


def _hook_round(n: int, cols: list):
    """One round of :func:`row_components` on 0..n−1: the forest (each node's root) and
    the rows still joining several roots, as columns of roots (None: no such row)."""
    parent = np.arange(n, dtype=cols[0].dtype)
    lo = cols[0].copy()
    for c in cols[1:]:
        np.minimum(lo, c, out=lo)
    for c in cols:
        np.minimum.at(parent, c, lo)
    while True:
        nxt = parent.take(parent)
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    roots = [parent.take(c) for c in cols]
    lo = roots[0].copy()
    for r in roots[1:]:
        np.minimum(lo, r, out=lo)
    differ = np.zeros(len(lo), dtype=bool)
    for r in roots:
        differ |= r != lo
    live = np.flatnonzero(differ)
    return parent, ([r.take(live) for r in roots] if len(live) else None)


def row_components(n: int, columns) -> np.ndarray:
    """Connected components of 0..n−1 where the entries of each row (the i-th entries of
    the equally long ``columns``: the nodes of a cell, the two ends of an edge) are joined:
    the smallest member of each node's component (int64).

    Rounds of a vectorised union-find, each on a contracted graph: every node is hooked
    onto the smallest entry of the rows it is in (``np.minimum.at``, so parents only
    decrease and stay in their component: no cycle), and pointer jumping takes each node
    to the root of its tree, the smallest member of the tree. Rows whose entries now
    share one root are done; the others, on their roots renumbered in increasing order,
    are the next, smaller problem (the largest entry of some row was hooked); the
    smallest root of a component is its smallest member. Ids are int32 when they fit
    (half the memory traffic of the gathers), gathered by ``take`` (a third of fancy
    indexing's time on 1D arrays); later rounds touch only the nodes still open."""
    dt = np.int32 if n < 2 ** 31 else np.int64
    cols = [np.ascontiguousarray(c, dtype=dt) for c in columns]
    if not cols or len(cols[0]) == 0:
        return np.arange(n, dtype=np.int64)
    levels = []  # (forest, the roots kept for the next round) per round
    while True:
        parent, roots = _hook_round(n, cols)
        if roots is None:
            break
        kept = np.zeros(n, dtype=bool)
        for r in roots:
            kept[r] = True
        ids = np.flatnonzero(kept)  # increasing: the order of the roots is kept
        rank = np.zeros(n, dtype=dt)
        rank[ids] = np.arange(len(ids), dtype=dt)
        levels.append((parent, ids))
        n, cols = len(ids), [rank.take(r) for r in roots]
    smallest = parent.astype(np.int64)
    while levels:  # back through the rounds: a kept root's answer is its round's
        parent, ids = levels.pop()
        lut = np.arange(len(parent), dtype=np.int64)
        lut[ids] = ids.take(smallest)
        smallest = lut.take(parent)
    return smallest


def cell_hits(cells: np.ndarray, hit_sim: np.ndarray, n: int,
              severed: np.ndarray | None = None):
    """(hit, cell) pairs: hit h lies on the closure of cell c of ``cells`` when the
    simulation primitive of h (its vertex ids, −1 padded in ``hit_sim``) is a face of c.
    Returns (hits, cells) int64 arrays, one entry per pair. ``severed`` ((C, E) bool, of
    :func:`severed_edges`, when ``hit_sim`` holds the registered points): the edges the
    points on edges can lie on, so the others are not searched."""
    m = cells.shape[1]
    owner_hit, owner_cell = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    size = (hit_sim >= 0).sum(axis=1)
    for s in range(1, m + 1):
        h = np.flatnonzero(size == s)
        if h.size == 0 or len(cells) == 0:
            continue
        combos = np.array(list(itertools.combinations(range(m), s)))
        table = sort_rows(hit_sim[h, :s])
        touched = np.zeros(n, dtype=bool)
        touched[table.ravel()] = True
        edges = severed if s == 2 and severed is not None else None
        flat, sub = rows_touched(cells, combos, touched, edges)
        i, j = match_rows(sub, table, n)
        owner_hit.append(h[j])
        owner_cell.append(flat[i] // len(combos))
    return np.concatenate(owner_hit), np.concatenate(owner_cell)
