"""Volume (area in 2D) and first moment of every fragment of the split (docs/split.md,
"Volumes and moments"), by the divergence theorem on the fragment's boundary: the parts
of its cell's faces on its side and the cut polygons inside the cell
(:mod:`~predicates.registration.split.surface`).

Each face of a split cell, oriented outward, is a cycle of nodes: its corners and the
registered points on its edges, in order along them. The edges of the cut polygons that
lie in the face (chords), chained through registered points inside the face into
polylines from one boundary node to another, split the cycle into regions; a region
belongs to the fragment of its off-cut corners. A chord a→b of a cut polygon is
traversed a→b by the region in front of the polygon (its normal's side) and b→a by the
one behind, so the polygon bounds the fragment behind it as it is and the fragment in
front reversed (the two sides of a closed, consistently oriented surface); polygons
with no chord take their sides from the polygons they share an edge with, and polygons
whose sides stay unknown (a crack tip inside one fragment) bound nothing. In 2D the
faces are the cell's edges, cut into segments at the registered points, and the cut
segments' left side is the region behind them. All of this is combinatorial; only the
final sums are floating point (tetrahedra coned from the cell's first corner over the
boundary triangles: a face region as a star from its face's smallest vertex, a cut
polygon as a fan from its smallest point; exact up to the rounding of the registered
points). The plain cells are summed vectorised
(:mod:`~predicates.registration.split.plain_cells`), the others cell by cell.

A cell is **reported** (``unresolved``: its fragments' volumes NaN) where this fails,
instead of double counting: an edge crossed twice (the virtual-node approximation
cannot give that material to the fragment that owns it, docs/split.md), a region with
corners of two fragments or of none, a fragment boundary that does not close. Cells with
one fragment keep their whole volume (a crack tip inside a cell removes none) unless an
edge of theirs is crossed twice.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FragmentVolumes", "fragment_boundaries", "fragment_volumes", "simplex_measure"]


@dataclass
class FragmentVolumes:
    """``volume`` (F,) and ``moment`` (F, d) (∫ x dV) of every new cell of the split;
    ``cell_volume`` (C,) / ``cell_moment`` (C, d) of the original cells; ``unresolved`` (k,) the original cells
    reported (their fragments NaN); ``piece_volume`` (P,) / ``piece_moment`` (P, d):
    sums over the resolved fragments of each piece; ``unclaimed`` (C,): the volume of
    each cell that no fragment of it owns (material behind an edge crossed twice; NaN
    for unresolved cells)."""

    volume: np.ndarray
    moment: np.ndarray
    cell_volume: np.ndarray
    cell_moment: np.ndarray
    unresolved: np.ndarray
    piece_volume: np.ndarray
    piece_moment: np.ndarray
    unclaimed: np.ndarray

    def claim_report(self) -> np.ndarray:
        """The cells where the virtual-node split leaves material to no fragment (an
        edge crossed twice: the virtual node default would give the whole cell to each
        fragment, double counting) and those reported unresolved."""
        return np.flatnonzero((self.unclaimed != 0) | np.isnan(self.unclaimed))


class _Unresolved(Exception):
    pass


def simplex_measure(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed volume (area in 2D) and first moment of simplices X (k, d+1, d),
    elementwise in a fixed order (no BLAS)."""
    E = X[:, 1:] - X[:, :1]
    if X.shape[2] == 3:
        v = (E[:, 0, 0] * (E[:, 1, 1] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 1])
             - E[:, 0, 1] * (E[:, 1, 0] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 0])
             + E[:, 0, 2] * (E[:, 1, 0] * E[:, 2, 1] - E[:, 1, 1] * E[:, 2, 0])) / 6
    else:
        v = (E[:, 0, 0] * E[:, 1, 1] - E[:, 0, 1] * E[:, 1, 0]) / 2
    cen = X[:, 0]
    for k in range(1, X.shape[1]):
        cen = cen + X[:, k]
    return v, v[:, None] * cen / X.shape[1]


class _Tables:
    """The registered points by simulation primitive and the cut polygons by cell."""

    def __init__(self, cs, n_cells: int, hits: np.ndarray | None = None):
        """``hits``: only these points (every point on the primitives of the cells it
        will be asked about; ``prim`` and ``canon`` are then dicts)."""
        self.vertex_hit, self.edge_hits = {}, {}
        self.prim, self.canon = ([], []) if hits is None else ({}, {})
        rows = range(len(cs.sim)) if hits is None else hits.tolist()
        for h, ids, w in zip(rows, cs.sim[rows].tolist(), cs.sim_weights[rows].tolist()):
            s = [i for i in ids if i >= 0]
            if hits is None:
                self.prim.append(frozenset(s))
                self.canon.append(self.vertex_hit.setdefault(s[0], h) if len(s) == 1 else h)
            else:
                self.prim[h] = frozenset(s)
                self.canon[h] = self.vertex_hit.setdefault(s[0], h) if len(s) == 1 else h
            if len(s) == 2:
                b = max(s)
                self.edge_hits.setdefault((min(s), b), []).append((w[ids.index(b)], h))
        for k in self.edge_hits:
            self.edge_hits[k].sort()
        keep = np.flatnonzero(~cs.on_face)
        order = keep[np.argsort(cs.cell[keep], kind="stable")]
        self.poly_order = order
        self.poly_bounds = np.searchsorted(cs.cell[order], np.arange(n_cells + 1))

    def polygons(self, cs, c: int) -> list:
        q = self.poly_order[self.poly_bounds[c]:self.poly_bounds[c + 1]]
        return [[self.canon[h] for h in cs.polygon(i).tolist()] for i in q.tolist()]

    def edge(self, a: int, b: int) -> list:
        """The registered points strictly inside edge a→b, in order from a."""
        pts = [h for _, h in self.edge_hits.get((min(a, b), max(a, b)), [])]
        return pts if a < b else pts[::-1]


def crossed_twice(cs, cells: np.ndarray) -> np.ndarray:
    """(C,) bool: cells with an edge holding two or more registered points inside it."""
    e = cs.sim[(cs.sim >= 0).sum(axis=1) == 2][:, :2]
    if len(e) == 0:
        return np.zeros(len(cells), dtype=bool)
    keys, cnt = np.unique(np.sort(e, axis=1), axis=0, return_counts=True)
    twice = keys[cnt > 1]
    out = np.zeros(len(cells), dtype=bool)
    if len(twice) == 0:
        return out
    bad = {tuple(r) for r in twice.tolist()}
    verts = np.zeros(int(max(cells.max(initial=0), twice.max()) + 1), dtype=bool)
    verts[twice.ravel()] = True
    for c in np.flatnonzero(verts[cells].sum(axis=1) >= 2).tolist():
        row = sorted(cells[c].tolist())
        out[c] = any((row[i], row[j]) in bad for i in range(len(row))
                     for j in range(i + 1, len(row)))
    return out


def _on_cut_side(res, cs) -> np.ndarray:
    """The registered points as Σ wᵢ·yᵢ on their cutting primitives: on the cutting
    surface up to rounding, so that the cut polygons of a cutting cell tile it exactly
    (a point the registration merged stays on the cut, within σ of the simulation
    primitive it is registered on)."""
    Q = np.asarray(res.cut_points, dtype=np.float64)
    ids = np.where(cs.cut >= 0, cs.cut, 0)
    acc = cs.cut_weights[:, 0, None] * Q[ids[:, 0]]
    for j in range(1, ids.shape[1]):
        acc = acc + cs.cut_weights[:, j, None] * Q[ids[:, j]]
    return acc


_FACES = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]
_OUTWARD = {(2, True): (0, 1, 2), (2, False): (0, 2, 1), (3, True): _FACES,
            (3, False): [f[::-1] for f in _FACES]}


def _fans(pieces, n: int, d: int):
    """(fragment, node ids of a boundary simplex) for the pieces' polygons or segments;
    node id v for vertices, n + h for points. A face region is a star from its face's
    smallest vertex (one triangle per region edge, none on the edges through it): a
    region bent by a merged point (off its face by up to σ) is then triangulated alike by
    both cells sharing it, and the chords cancel between the regions of a face. A cut
    polygon (planar) is a fan from its smallest node, the same for both its sides."""
    out = []
    for f, poly, apex in pieces:
        ids = [x[1] if x[0] == "v" else n + x[1] for x in poly]
        if d == 2:
            out.append((f, ids[0], ids[1]))
        elif apex is not None:
            out += [(f, apex, a, b) for a, b in zip(ids, ids[1:] + ids[:1])
                    if apex != a and apex != b]
        else:
            k = ids.index(min(ids))
            ids = ids[k:] + ids[:k]
            out += [(f, ids[0], ids[i], ids[i + 1]) for i in range(1, len(ids) - 1)]
    return out


def _measures(A, S, origin, Y, F, d, check=None):
    """Volume, moment and closure residual (|Σ vector area| / Σ |area|) per fragment of
    the boundary simplices S (k, d) of fragments A (k,) coned from ``origin`` (k,); the
    residual only from the rows ``check`` (all when None; 0 for fragments without)."""
    if d == 3:
        v, m, _ = _tet_measures(Y, origin, S, areas=False)
    else:
        v, m = simplex_measure(np.concatenate([Y[origin][:, None], Y[S]], axis=1))
        m = m.T
    vol = np.bincount(A, v, F)
    mom = np.stack([np.bincount(A, m[k], F) for k in range(d)], axis=1)
    r = slice(None) if check is None else np.flatnonzero(check)
    A, S, origin = A[r], S[r], origin[r]
    if d == 3:
        va = _tet_measures(Y, origin, S)[2]
    else:
        e = Y[S[:, 1]] - Y[S[:, 0]]
        va = [e[:, 1], -e[:, 0]]
    tot = np.stack([np.bincount(A, va[k], F) for k in range(d)], axis=1)
    mag = np.bincount(A, np.sqrt(sum(a * a for a in va)), F)
    res = np.sqrt((tot * tot).sum(axis=1)) / np.maximum(mag, 1e-300)
    return vol, mom, res


def _triangle_measures(X, tris):
    """:func:`simplex_measure` of the triangles ``tris`` on coordinate columns (the same
    operations in the same order)."""
    cols = [np.ascontiguousarray(X[:, j]) for j in range(2)]
    p = [[c[tris[:, i]] for c in cols] for i in range(3)]
    e = [[p[i][j] - p[0][j] for j in range(2)] for i in (1, 2)]
    v = (e[0][0] * e[1][1] - e[0][1] * e[1][0]) / 2
    return v, np.stack([v * ((p[0][j] + p[1][j]) + p[2][j]) / 3 for j in range(2)], axis=1)


def _pair_measures(pairs, origin, Y, F):
    """Volume and moment per fragment of the pairs (f, g, p, q, r) coned from
    ``origin``: (p, q, r) to f, (p, r, q) to g. The determinant of the second is exactly
    the negated first (IEEE products commute, a − b = −(b − a)); its centroid is summed
    in its own order, so both are the values :func:`_tet_measures` gives each row."""
    v, m, _ = _tet_measures(Y, origin, pairs[:, 2:], areas=False)
    cols = [np.ascontiguousarray(Y[:, j]) for j in range(3)]
    p = [[c[pairs[:, i]] for c in cols] for i in (2, 3, 4)]
    x0 = [c[origin] for c in cols]
    w = -v
    m2 = [w * (((x0[j] + p[0][j]) + p[2][j]) + p[1][j]) / 4 for j in range(3)]
    vol = np.bincount(pairs[:, 0], v, F) + np.bincount(pairs[:, 1], w, F)
    mom = np.stack([np.bincount(pairs[:, 0], m[j], F) + np.bincount(pairs[:, 1], m2[j], F)
                    for j in range(3)], axis=1)
    return vol, mom


def _tet_measures(Y, origin, S, areas: bool = True):
    """:func:`simplex_measure` of the tetrahedra (origin, S) and the vector areas of
    their faces S, on coordinate columns (the same operations in the same order,
    without strided (k, 4, 3) temporaries)."""
    cols = [np.ascontiguousarray(Y[:, j]) for j in range(3)]
    x0 = [c[origin] for c in cols]
    pts = [[c[S[:, i]] for c in cols] for i in range(3)]
    E = [[p[j] - x0[j] for j in range(3)] for p in pts]
    v = (E[0][0] * (E[1][1] * E[2][2] - E[1][2] * E[2][1])
         - E[0][1] * (E[1][0] * E[2][2] - E[1][2] * E[2][0])
         + E[0][2] * (E[1][0] * E[2][1] - E[1][1] * E[2][0])) / 6
    m = [v * (((x0[j] + pts[0][j]) + pts[1][j]) + pts[2][j]) / 4 for j in range(3)]
    if not areas:
        return v, m, None
    a = [pts[1][j] - pts[0][j] for j in range(3)]
    b = [pts[2][j] - pts[0][j] for j in range(3)]
    va = [(a[1] * b[2] - a[2] * b[1]) / 2, (a[2] * b[0] - a[0] * b[2]) / 2,
          (a[0] * b[1] - a[1] * b[0]) / 2]
    return v, m, va


def _per_cell_rows(res, sm, cs, cells, rest, start, nfrag, sgn, d):
    """The boundary simplices of the fragments of the cells ``rest``, cell by cell by
    the rules of :mod:`~predicates.registration.split.regions`, and the cells where
    those do not apply."""
    from predicates.registration.split.regions import Unresolved, cell_pieces

    n, on_cut = len(res.sim_points), sm.on_cut
    todo = np.flatnonzero(rest)
    near = np.zeros(n, dtype=bool)
    near[cells[todo].ravel()] = True
    T = _Tables(cs, len(cells), np.flatnonzero((near[cs.sim] | (cs.sim < 0)).all(axis=1)))
    fans, bad = [], set()
    for c in todo.tolist():
        corners = cells[c].tolist()
        frag = {v: start[c] + j for j in range(nfrag[c]) for k, v in enumerate(corners)
                if sm.material[start[c] + j, k] and not on_cut[v]}
        try:
            pc = cell_pieces(corners, frag, on_cut, T, T.polygons(cs, c),
                             _OUTWARD[d, bool(sgn[c] > 0)])
        except Unresolved:
            bad.add(c)
            continue
        fans += _fans(pc, n, d)
    return np.array(fans, dtype=np.int64).reshape(len(fans), d + 1), bad


def _todo(sm, cs, cells, nfrag, twice):
    """Every cell whose faces carry registered points: with the points on the cutting
    side, a face is shared with the same (slightly bent) regions by both its cells."""
    todo = (nfrag > 1) | twice | sm.severed.any(axis=1) | sm.on_cut[cells].any(axis=1)
    todo[cs.cell[~cs.on_face]] = True
    return todo


def fragment_boundaries(res, sm, cs, *, per_cell: bool = False):
    """The triangles (segments in 2D) bounding the fragments of the cut cells: (rows
    (k, d+1) int64 — fragment, then node ids: v for vertex v, n + h for point h — the
    cut cells (C,) bool, the cells where the rules do not apply (a set), the plain
    cells (C,) bool). The plain tetrahedra
    (:mod:`~predicates.registration.split.plain_cells`) vectorised, the rest cell by
    cell by :mod:`~predicates.registration.split.regions`; ``per_cell=True``: every cut
    cell cell by cell (the reference the vectorised rows are tested against)."""
    cells = np.asarray(res.sim_cells, dtype=np.int64)
    X = np.asarray(res.sim_points, dtype=np.float64)
    v = simplex_measure(X[cells])[0] if len(cells) else np.zeros(0)
    rows, pairs, todo, bad, plain = _boundaries(res, sm, cs, cells,
                                                np.where(v < 0, -1.0, 1.0), per_cell)
    if len(pairs):  # 3D only
        rows = np.concatenate([rows, pairs[:, [0, 2, 3, 4]], pairs[:, [1, 2, 4, 3]]])
    return rows, todo, bad, plain


def _boundaries(res, sm, cs, cells, sgn, per_cell):
    from predicates.registration.split.plain_cells import plain_cell_rows, plain_triangle_rows

    d, n, C = sm.dim, len(res.sim_points), len(cells)
    nfrag = np.bincount(sm.cell_origin, minlength=C)
    start = np.cumsum(nfrag) - nfrag
    twice = crossed_twice(cs, cells)
    todo = _todo(sm, cs, cells, nfrag, twice)
    plain, rows = np.zeros(C, dtype=bool), np.zeros((0, d + 1), dtype=np.int64)
    pairs = np.zeros((0, d + 2), dtype=np.int64)
    if not per_cell:
        rule = plain_cell_rows if d == 3 else plain_triangle_rows
        plain, rows, pairs = rule(cs, sm, cells, n, start, nfrag, sgn > 0, todo, twice)
    rest = todo & ~plain
    if not rest.any():
        return rows, pairs, todo, set(), plain
    rest_rows, bad = _per_cell_rows(res, sm, cs, cells, rest, start, nfrag, sgn, d)
    return np.concatenate([rows, rest_rows]), pairs, todo, bad, plain


def fragment_volumes(res, sm, cs=None, *, per_cell: bool = False) -> FragmentVolumes:
    """Volume (area) and first moment of every fragment of the split ``sm`` of ``res``
    (module docstring) from :func:`fragment_boundaries`; ``cs``: its cut surface
    (computed when not given)."""
    from predicates.registration.split.surface import cut_surface

    cs = cut_surface(res) if cs is None else cs
    d, cells = sm.dim, np.asarray(res.sim_cells, dtype=np.int64)
    X = np.asarray(res.sim_points, dtype=np.float64)
    C, F = len(cells), len(sm.cells)
    if d == 3 and C:
        cv, cm, _ = _tet_measures(X, cells[:, 0], cells[:, 1:], areas=False)
        cm = np.stack(cm, axis=1)
    elif C:
        cv, cm = _triangle_measures(X, cells)
    else:
        cv, cm = np.zeros(0), np.zeros((0, d))
    sgn = np.where(cv < 0, -1.0, 1.0)
    cv, cm = cv * sgn, cm * sgn[:, None]
    vol, mom = cv[sm.cell_origin], cm[sm.cell_origin]
    rows, pairs, todo, bad, plain = _boundaries(res, sm, cs, cells, sgn, per_cell)
    split = todo[sm.cell_origin]
    unclaimed = np.zeros(C)
    if len(rows) or len(pairs):
        Y = np.concatenate([X, _on_cut_side(res, cs)])
        A = rows[:, 0]
        cA = sm.cell_origin[A]
        # a plain cell's fragment boundaries are closed by construction (docs/split.md)
        fv, fm, closure = _measures(A, rows[:, 1:], cells[cA, 0], Y, F, d, ~plain[cA])
        if len(pairs):
            pv, pm = _pair_measures(pairs, cells[sm.cell_origin[pairs[:, 0]], 0], Y, F)
            fv, fm = fv + pv, fm + pm
        vol[split], mom[split] = fv[split], fm[split]
        bad.update(sm.cell_origin[split & (closure > 1e-9)].tolist())
        unclaimed = cv - np.bincount(sm.cell_origin, vol, C)
        # fragments may overlap by what the registration's tolerance σ moved points
        # (a degenerate pair merging close points): σ × the cell's size^(d−1)
        neg = np.flatnonzero(unclaimed < -1e-12 * cv)
        slack = float(res.tolerances.values.get("sigma", 0.0)) * cv[neg] ** ((d - 1) / d) * 8
        bad.update(neg[unclaimed[neg] < -slack].tolist())
        unclaimed[np.abs(unclaimed) <= 1e-12 * cv] = 0.0
    unresolved = np.array(sorted(bad), dtype=np.int64)
    unclaimed[unresolved] = np.nan
    gone_cell = np.zeros(C, dtype=bool)
    gone_cell[unresolved] = True
    gone = gone_cell[sm.cell_origin]
    vol[gone], mom[gone] = np.nan, np.nan
    ok = ~gone if len(unresolved) else slice(None)
    pv = np.bincount(sm.piece[ok], vol[ok], sm.n_pieces)
    pm = np.stack([np.bincount(sm.piece[ok], mom[ok, k], sm.n_pieces) for k in range(d)], 1)
    return FragmentVolumes(vol, mom, cv, cm, unresolved, pv, pm, unclaimed)
