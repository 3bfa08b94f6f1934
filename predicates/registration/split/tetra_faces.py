"""The triangulated boundary of every fragment of one cell (docs/split.md, "The
conforming tetrahedralization"), on global point ids.

The fragment boundaries themselves are part 1's (:func:`~predicates.registration.split.
regions.cell_pieces`: the regions of the cell's faces cut by the chords of the cut
polygons, and the cut polygons with their sides). Here every such polygon gets global
point ids — a simulation vertex is its id (also when it is registered on the cut), any
other registered point is n + its index in the hit table, so a point shared by cells is
one point — and is triangulated by the rule of
:mod:`~predicates.registration.split.polytri`: a face region in the barycentric frame of
its simulation face (its sorted vertex ids), a cut polygon in the frame of its cutting
triangle. Both frames read only registered weights, which the cells sharing a face (the
fragments sharing a cut polygon) share, so neighbours get the same triangles.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from predicates.registration.split.polytri import triangulate

__all__ = ["CellBoundary", "OUTWARD", "Points", "cell_boundary", "positive"]

#: the faces of a positively oriented tetrahedron, as corner positions, oriented outward
OUTWARD = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))


@dataclass
class CellBoundary:
    """``tris``: {fragment: [outward simplex of the boundary (gids)]}; ``cut``: [(back
    fragment, front fragment, simplex as the back fragment sees it, polygon q)];
    ``faces``: {sorted face vertex ids: [triangles, outward from this cell]}."""

    tris: dict = field(default_factory=dict)
    cut: list = field(default_factory=list)
    faces: dict = field(default_factory=dict)


class Points:
    """A growing (N, d) float64 array: the points of the conforming mesh, interior
    points appended (and withdrawn) as apexes are tried."""

    def __init__(self, X: np.ndarray):
        self.buf = np.array(X, dtype=np.float64)
        self.n = len(self.buf)

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i):
        return self.buf[:self.n][i]

    def append(self, p) -> int:
        if self.n == len(self.buf):
            self.buf = np.concatenate([self.buf, np.zeros_like(self.buf[:max(self.n, 16)])])
        self.buf[self.n] = p
        self.n += 1
        return self.n - 1

    def pop(self) -> None:
        self.n -= 1

    @property
    def array(self) -> np.ndarray:
        return self.buf[:self.n]


def on_cut_points(res, cs) -> np.ndarray:
    """The registered points as Σ wᵢ·yᵢ on their cutting primitives (fixed order, no
    BLAS): the cut faces then tile every cutting triangle up to rounding, so each piece
    is the polyhedron the cut bounds. A point the registration merged (a degenerate
    pair, within the paper's tolerances σ, τ, δ of its simulation primitive) stays on
    the cut, off its simulation primitive by at most that tolerance; orientations are
    checked on these coordinates all the same."""
    Q = np.asarray(res.cut_points, dtype=np.float64)
    ids = np.where(cs.cut >= 0, cs.cut, 0)
    acc = cs.cut_weights[:, 0, None] * Q[ids[:, 0]]
    for j in range(1, ids.shape[1]):
        acc = acc + cs.cut_weights[:, j, None] * Q[ids[:, j]]
    return acc


def degenerate_on_sim(res, cs) -> tuple:
    """((H,) bool, (H, d) float): the degenerate registered points (their primitives'
    dimensions add up to less than d: a vertex or edge of the cut registered on a vertex,
    edge or face of the mesh within the paper's tolerances σ, τ, δ, section 1) and their
    places Σ wᵢ·xᵢ on their *simulation* primitives (fixed order, no BLAS). Placed on the
    cut (:func:`on_cut_points`), such a point lifts a face region off its face by up to
    the tolerance, and a sliver region between a chord and the point can fold onto the
    cut polygon's plane: a zero-thickness flap no positive tetrahedra fill. Moved to its
    simulation primitive, the face regions through it stay in their faces' planes
    (docs/split.md, "The conforming tetrahedralization")."""
    X = np.asarray(res.sim_points, dtype=np.float64)
    deg = (cs.sim >= 0).sum(axis=1) + (cs.cut >= 0).sum(axis=1) < res.dim + 2
    ids = np.where(cs.sim >= 0, cs.sim, 0)
    acc = cs.sim_weights[:, 0, None] * X[ids[:, 0]]
    for j in range(1, ids.shape[1]):
        acc = acc + cs.sim_weights[:, j, None] * X[ids[:, j]]
    return deg, acc


def gid(node, T, n: int) -> int:
    """The global point id of a node of :mod:`~predicates.registration.split.regions`."""
    if node[0] == "v":
        return int(node[1])
    s = T.prim[node[1]]
    return next(iter(s)) if len(s) == 1 else n + int(node[1])


def _frame_weights(ids, wts, frame) -> tuple:
    """A point's weights (ids, wts: −1 / 0 padded) on the three frame vertices."""
    out = [0.0, 0.0, 0.0]
    for i, w in zip(ids, wts):
        if i >= 0:
            out[frame.index(i)] += float(w)
    return tuple(out)


def _node_weights(nodes, T, cs, frame, n: int) -> dict:
    w = {}
    for nd in nodes:
        g = gid(nd, T, n)
        if nd[0] == "v" or g < n:
            w[g] = tuple(1.0 if f == g else 0.0 for f in frame)
        else:
            w[g] = _frame_weights(cs.sim[nd[1]].tolist(), cs.sim_weights[nd[1]].tolist(),
                                  frame)
    return w


def _parity(order, frame) -> int:
    """+1 when ``order`` is an even permutation of ``frame``."""
    p = [frame.index(v) for v in order]
    inv = sum(p[i] > p[j] for i in range(3) for j in range(i + 1, 3))
    return 1 if inv % 2 == 0 else -1


def _cut_triangles(q: int, cs, cut_cells, n: int, T):
    """The triangles of cut polygon q in its cutting triangle's frame, oriented like it
    (gids)."""
    frame = [int(x) for x in cut_cells[cs.cut_cell[q]]]
    hits = cs.polygon(q).tolist()
    ids = [gid(("h", T.canon[h]), T, n) for h in hits]
    w = {g: _frame_weights(cs.cut[h].tolist(), cs.cut_weights[h].tolist(), frame)
         for g, h in zip(ids, hits)}
    return triangulate(ids, w, 1)


def _classify(poly_nodes, T, corners):
    """The face (sorted vertex ids) a region lies in, or None for a cut polygon."""
    u = frozenset().union(*(T.prim[nd[1]] if nd[0] == "h" else {nd[1]}
                            for nd in poly_nodes))
    if len(u) == 4:
        return None
    for skip in range(4):
        face = tuple(sorted(corners[k] for k in range(4) if k != skip))
        if u <= set(face):
            return face
    raise ValueError("a region outside its cell")


def cell_boundary_3d(corners, pieces, polys, T, cs, cut_cells, n: int,
                     outward) -> CellBoundary:
    """The triangulated boundaries of the fragments of one tetrahedron. ``pieces``: the
    [(fragment, node cycle)] of ``cell_pieces`` (or of the single fragment); ``polys``:
    [(q, canonical hit cycle)] of the cell's cut polygons; ``outward``: its faces as
    corner positions, oriented outward."""
    out = CellBoundary()
    by_nodes = {}
    for q, P in polys:
        by_nodes.setdefault(frozenset(P), []).append((q, P))
    cut_tris, sides = {}, {}
    out_order = {tuple(sorted(corners[k] for k in f)): tuple(corners[k] for k in f)
                 for f in outward}
    for frag, cyc in pieces:
        face = _classify(cyc, T, corners)
        ids = [gid(nd, T, n) for nd in cyc]
        if face is None:
            key = frozenset(nd[1] for nd in cyc)
            q, P = next((q, P) for q, P in by_nodes[key])
            if q not in cut_tris:
                cut_tris[q] = _cut_triangles(q, cs, cut_cells, n, T)
            back = [nd[1] for nd in cyc] == P
            sides.setdefault(q, [None, None])[0 if back else 1] = frag
            tris = cut_tris[q] if back else [t[::-1] for t in cut_tris[q]]
        else:
            w = _node_weights(cyc, T, cs, list(face), n)
            tris = triangulate(ids, w, _parity(out_order[face], list(face)))
            out.faces.setdefault(face, []).extend(tris)
        out.tris.setdefault(frag, []).extend(tris)
    for q, (back, front) in sides.items():
        out.cut += [(back, front, t, q) for t in cut_tris[q]]
    return out


def cell_boundary_2d(corners, pieces, polys, T, cs, n: int) -> CellBoundary:
    """The boundary segments of the fragments of one triangle (already simplices)."""
    out = CellBoundary()
    by_nodes = {frozenset(P): q for q, P in polys}
    sides = {}
    for frag, seg in pieces:
        ids = tuple(gid(nd, T, n) for nd in seg)
        out.tris.setdefault(frag, []).append(ids)
        q = by_nodes.get(frozenset(nd[1] for nd in seg)) if all(
            nd[0] == "h" for nd in seg) else None
        if q is not None and len(set(T.prim[seg[0][1]] | T.prim[seg[1][1]])) == 3:
            P = polys[[p for p, _ in polys].index(q)][1]
            back = [nd[1] for nd in seg] == P
            sides.setdefault(q, [None, None, ids if back else ids[::-1]])[
                0 if back else 1] = frag
    for q, (back, front, ids) in sides.items():
        out.cut.append((back, front, ids, q))
    return out


def cell_boundary(corners, pieces, polys, T, cs, cut_cells, n: int,
                  outward) -> CellBoundary:
    """:func:`cell_boundary_3d` or, for a triangle, :func:`cell_boundary_2d`."""
    if len(corners) == 3:
        return cell_boundary_2d(corners, pieces, polys, T, cs, n)
    return cell_boundary_3d(corners, pieces, polys, T, cs, cut_cells, n, outward)


def ring_pieces(corners, frag: int, on_cut, T, ring):
    """[(frag, segment)] of a triangle kept whole: its edges cut at the registered
    points (2D; the segments of ``cell_pieces`` for a single fragment)."""
    out = []
    for i in range(3):
        a, b = corners[ring[i]], corners[ring[(i + 1) % 3]]
        path = ([("h", T.vertex_hit[a]) if on_cut[a] else ("v", a)]
                + [("h", h) for h in T.edge(a, b)]
                + [("h", T.vertex_hit[b]) if on_cut[b] else ("v", b)])
        out += [(frag, [u, w]) for u, w in zip(path[:-1], path[1:])]
    return out


def positive(cells: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(C,) int8: the exact orientation sign of every simplex on its float coordinates
    (``predicates.classic``'s filtered orient3d / orient2d: exact on every lane).
    Positive means ((B − A) × (C − A))·(D − A) > 0 (2D: (B − A) × (C − A) > 0); Shewchuk's
    orient3d has the opposite sign, orient2d the same."""
    from predicates.classic import FILTERED, sign

    if len(cells) == 0:
        return np.zeros(0, dtype=np.int8)
    P = [X[cells[:, k]] for k in range(cells.shape[1])]
    if X.shape[1] == 3:
        return (-sign(FILTERED["orient3d"], *P)).astype(np.int8)
    return sign(FILTERED["orient2d"], *P).astype(np.int8)
