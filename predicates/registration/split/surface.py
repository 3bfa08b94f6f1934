"""The cutting surface embedded in the simulation mesh (docs/split.md, "The cut
surface"): per simulation cell and cutting cell, the polygon of the cutting cell inside
the simulation cell (3D; a segment in 2D), with the registered points as its vertices.

The intersection of a cutting triangle t with a tetrahedron c is a convex polygon whose
vertices are exactly the intersections of primitives of t with primitives of c — the
pairs the paper's registration (section 1) reports. So the polygon of (c, t) is the set
of registered points whose simulation primitive is a face of c and whose cutting
primitive is a face of t, in cyclic order. The order is taken in t's own barycentric
coordinates (λ1, λ2), counter-clockwise around the points' mean there: that is the
orientation of t (vertices t0, t1, t2), so every polygon is oriented like its cutting
triangle. Points are shared, not copied: two cells sharing a face see the same
registered points on it, so their polygons share their edges there (watertight), and
the polygons of one cutting triangle tile it. A polygon lying in a face of c (a cut
along the mesh's faces) is also the polygon of the cell across that face: it is kept
once, in the lower-numbered cell (``on_face``). 2D: the segment of a cutting segment
inside a triangle, ordered from its first vertex to its second.

Only the registered pairs and the cells near them are visited: cost O(pairs · cells
around a primitive · cutting cells around a primitive) plus one sort of that.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predicates.portable import weighted_sum
from predicates.registration.spatial.boxgrid import expand
from predicates.registration.split import rules as R

__all__ = ["CutSurface", "cut_surface", "hit_table"]


@dataclass
class CutSurface:
    """The embedded cut surface (module docstring). Points (registered pairs, every kind
    in ``kinds`` order, as ``SplitMesh.hit_*``): ``points`` (H, d) Σ wᵢ·xᵢ on the
    simulation primitive, ``kind`` (H,) index into ``kinds``, ``sim`` / ``sim_weights``
    (H, d+1) and ``cut`` / ``cut_weights`` (H, d) (−1 / 0 padded). Polygons (segments in
    2D): the points of polygon q are ``index[offsets[q]:offsets[q+1]]`` in cyclic order;
    ``cell`` (Q,) the simulation cell, ``cut_cell`` (Q,) the cutting cell as registered,
    ``input_cut_cell`` (Q,) the cutting cell as given (the refinement's map),
    ``on_face`` (Q,) lies in a face of its cell."""

    dim: int
    kinds: tuple
    points: np.ndarray
    kind: np.ndarray
    sim: np.ndarray
    sim_weights: np.ndarray
    cut: np.ndarray
    cut_weights: np.ndarray
    offsets: np.ndarray
    index: np.ndarray
    cell: np.ndarray
    cut_cell: np.ndarray
    input_cut_cell: np.ndarray
    on_face: np.ndarray

    def __len__(self) -> int:
        return len(self.cell)

    def polygon(self, q: int) -> np.ndarray:
        """The point indices of polygon ``q``, in cyclic order."""
        return self.index[self.offsets[q]:self.offsets[q + 1]]

    def sizes(self) -> np.ndarray:
        return np.diff(self.offsets)

    def of_cell(self, c: int) -> np.ndarray:
        """The polygons in simulation cell ``c``."""
        return np.flatnonzero(self.cell == c)

    def to_meshio(self, plane: float = 0.0):
        """The polygons as a ``meshio.Mesh`` (one block per polygon size: triangle,
        quad, polygon; 2D: line) with cell data ``cell``, ``cut_cell`` and
        ``input_cut_cell``, point data ``kind`` and ``sim_ids``. 2D points at z =
        ``plane``."""
        import meshio

        X = self.points.astype(np.float64)
        if self.dim == 2:
            X = np.column_stack([X, np.full(len(X), plane)])
        size = self.sizes()
        blocks, data = [], {"cell": [], "cut_cell": [], "input_cut_cell": []}
        names = {2: "line", 3: "triangle", 4: "quad"}
        for k in np.unique(size).tolist():
            q = np.flatnonzero(size == k)
            rows = self.index[self.offsets[q][:, None] + np.arange(k)]
            blocks.append((names.get(k, "polygon"), rows.astype(np.int64)))
            for name in data:
                data[name].append(getattr(self, name)[q].astype(np.int64))
        return meshio.Mesh(X, blocks, cell_data=data,
                           point_data={"kind": self.kind.astype(np.int32),
                                       "sim_ids": self.sim.astype(np.int64)})


def hit_table(res):
    """Every registered point, every kind in ``res.kinds`` order: (points, kind, sim
    ids, sim weights, cut ids, cut weights), −1 / 0 padded to the widest primitive."""
    d = int(res.dim)
    X = np.asarray(res.sim_points, dtype=np.float64)
    cols = [[], [], [], [], [], []]
    for code, k in enumerate(res.kinds):
        p = res[k]
        m, s = p.sim.shape
        if m == 0:
            continue
        ws = np.asarray(p.sim_weights, dtype=np.float64)
        wc = np.asarray(p.cut_weights, dtype=np.float64)
        t = p.cut.shape[1]
        for col, val in zip(cols, (
                weighted_sum(ws, X[p.sim]), np.full(m, code, dtype=np.int32),
                np.pad(p.sim.astype(np.int64), ((0, 0), (0, d + 1 - s)), constant_values=-1),
                np.pad(ws, ((0, 0), (0, d + 1 - s))),
                np.pad(p.cut.astype(np.int64), ((0, 0), (0, d - t)), constant_values=-1),
                np.pad(wc, ((0, 0), (0, d - t))))):
            col.append(val)
    shapes = ((0, d), (0,), (0, d + 1), (0, d + 1), (0, d), (0, d))
    types = (np.float64, np.int32, np.int64, np.float64, np.int64, np.float64)
    return tuple(np.concatenate(c) if c else np.zeros(s, t)
                 for c, s, t in zip(cols, shapes, types))


def _incidence(cells: np.ndarray, prims: np.ndarray, n: int):
    """(hit, cell) pairs, sorted by hit: primitive ``prims[h]`` (−1 padded) is a face
    of ``cells[c]``; only the cells with a vertex of some primitive are visited."""
    on = np.zeros(max(n, 1), dtype=bool)
    on[prims[prims >= 0]] = True
    near = np.flatnonzero(R.any_corner(on, cells))
    h, c = R.cell_hits(cells[near], prims, n)
    c = near[c]
    o = np.lexsort((c, h))
    return h[o], c[o]


def _pairs_of(res, hs, hc):
    """(hit, simulation cell, cutting cell) triples: every cell holding the point's
    simulation primitive × every cutting cell holding its cutting primitive."""
    sim_cells = np.asarray(res.sim_cells, dtype=np.int64)
    cut_cells = np.asarray(res.cut_cells, dtype=np.int64)
    h1, c1 = _incidence(sim_cells, hs, len(res.sim_points))
    h2, t2 = _incidence(cut_cells, hc, len(res.cut_points))
    H = len(hs)
    n1, n2 = np.bincount(h1, minlength=H), np.bincount(h2, minlength=H)
    s1, s2 = np.cumsum(n1) - n1, np.cumsum(n2) - n2
    h, j = expand(np.zeros(H, dtype=np.int64), n1 * n2)
    return h, c1[s1[h] + j // np.maximum(n2[h], 1)], t2[s2[h] + j % np.maximum(n2[h], 1)]


def _local(ids_a: np.ndarray, ids_b: np.ndarray, w_b: np.ndarray | None):
    """For rows of corner ids ``ids_a`` (E, k) and primitive ids ``ids_b`` (E, j): the
    corner bits of the primitive (which corners it holds), and with weights ``w_b`` its
    barycentric coordinates on the k corners."""
    eq = ids_a[:, :, None] == ids_b[:, None, :]
    bits = (eq.any(axis=2) << np.arange(ids_a.shape[1])).sum(axis=1)
    lam = None if w_b is None else (eq * w_b[:, None, :]).sum(axis=2)
    return bits, lam


def _order(g, lam, dim):
    """The cyclic order of the points of each group (sorted by group): counter-clockwise
    in (λ1, λ2) around the group's mean (3D), by λ1 along the segment (2D)."""
    if dim == 2:
        return np.lexsort((lam[:, 1], g))
    cnt = np.bincount(g).astype(np.float64)
    cu = np.bincount(g, lam[:, 1]) / np.maximum(cnt, 1)
    cv = np.bincount(g, lam[:, 2]) / np.maximum(cnt, 1)
    ang = pseudo_angle(lam[:, 1] - cu[g], lam[:, 2] - cv[g])
    return np.lexsort((ang, g))


def pseudo_angle(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A number in [−2, 2] increasing with the angle of (x, y) as ``arctan2(y, x)`` in
    (−π, π] does (0 at the origin), from one addition and one division: correctly
    rounded on every machine, where arctan2's last bit depends on the CPU's libm or
    SIMD (docs/design.md, "The same answer on every machine")."""
    ax, ay = np.abs(x), np.abs(y)
    s = ax + ay
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(s > 0, y / s, 0.0)  # sin-like: in [−1, 1], increasing with |angle| < π/2
    # x ≥ 0: r in [−1, 1]; x < 0: 2 − r above the axis, −2 − r below (y < 0)
    return np.where(x >= 0, r, np.where(y >= 0, 2.0 - r, -2.0 - r))


def cut_surface(res, hits=None) -> CutSurface:
    """The polygons of the cutting surface inside every simulation cell (module
    docstring) from ``res``, an :class:`~predicates.registration.IntersectionResult`;
    ``hits``: its :func:`hit_table` as re-decided by
    :func:`~predicates.registration.split.declump.declump` (default: as registered)."""
    d = int(res.dim)
    pts, kind, hs, hw, hc, hcw = hit_table(res) if hits is None else hits
    h, c, t = _pairs_of(res, hs, hc)
    sim_cells = np.asarray(res.sim_cells, dtype=np.int64)
    cut_cells = np.asarray(res.cut_cells, dtype=np.int64)
    bits, _ = _local(sim_cells[c], hs[h], None)
    _, lam = _local(cut_cells[t], hc[h], hcw[h])
    o = np.lexsort((h, t, c))
    h, c, t, bits, lam = h[o], c[o], t[o], bits[o], lam[o]
    new = np.ones(len(h), dtype=bool)
    new[1:] = (c[1:] != c[:-1]) | (t[1:] != t[:-1])
    start = np.flatnonzero(new)
    g = np.cumsum(new) - 1
    size = np.diff(np.append(start, len(h)))
    full = (1 << (d + 1)) - 1
    face = np.bitwise_or.reduceat(bits, start) if len(start) else bits[:0]
    keep = size >= d
    on_face = face != full
    # a polygon in a face: kept once, in the lower-numbered cell (groups are by cell)
    corner = ((face[:, None] >> np.arange(d + 1)) & 1) > 0
    fk = np.sort(np.where(corner, sim_cells[c[start]], -1), axis=1)
    dup = np.zeros(len(start), dtype=bool)
    sel = np.flatnonzero(on_face & keep)
    if len(sel):
        key = np.column_stack([t[start[sel]], fk[sel]])
        _, first = np.unique(key, axis=0, return_index=True)
        dup[sel] = True
        dup[sel[first]] = False
    keep &= ~dup
    o = _order(g, lam, d)
    o = o[keep[g[o]]]
    qs = np.flatnonzero(keep)
    offsets = np.zeros(len(qs) + 1, dtype=np.int64)
    np.cumsum(size[qs], out=offsets[1:])
    ref = res.refinement
    tq = t[start[qs]]
    origin = tq if ref is None else np.asarray(ref.cut_origin, dtype=np.int64)[tq]
    return CutSurface(dim=d, kinds=tuple(res.kinds), points=pts, kind=kind, sim=hs,
                      sim_weights=hw, cut=hc, cut_weights=hcw, offsets=offsets,
                      index=h[o], cell=c[start[qs]], cut_cell=tq, input_cut_cell=origin,
                      on_face=on_face[qs])
