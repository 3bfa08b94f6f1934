"""Re-deciding a cluster of merged crossings around a simulation vertex, for the conforming
tetrahedralization only (docs/split.md, "A cutting edge within τ of a vertex").

When a cutting edge e passes within the paper's tolerance τ of a simulation vertex v (but
farther than δ), the registration (section 1) registers e against several edges (v, w) of
v at once (edge_edge pairs): every crossing near v is placed on e. The polygons of the two
cutting triangles beside e then coincide in the cells around v, or both hold the chord
those points make in a face — a registered cut no manifold region structure embeds. The
virtual-node split is unaffected (the same edges are severed either way).

Here such a cluster (two or more edge_edge points of one cutting edge on edges of one
vertex, in cells the region formation refused) is re-decided from the stored coordinates:
each edge (v, w) is attributed to the cutting triangle beside e it properly crosses (exact
orientations, ``predicates.classic``'s filtered orient3d) and becomes an edge_triangle
point at the crossing; every face of a cell around v that e properly crosses gets a
triangle_edge point. Only the combinatorics are decided exactly; the new weights are
rounded, and every simplex built on them is checked exactly as any other. A cluster with
a degenerate sign (e through an edge or vertex, a crossing on e) is left as it was.
"""
from __future__ import annotations

import numpy as np

__all__ = ["declump"]

#: a re-decided crossing whose weight off the cutting edge is below this is where the
#: edge_edge pair put it (the two edges do cross, up to rounding): it is kept
_ON_EDGE = 1e-12


def _signs(Z: np.ndarray, quads) -> np.ndarray:
    from predicates.registration.split.tetra_faces import positive

    return positive(np.array(quads, dtype=np.int64).reshape(-1, 4), Z).astype(np.int64)


def _det(Z, a, b, c, d) -> float:
    e1, e2, e3 = Z[b] - Z[a], Z[c] - Z[a], Z[d] - Z[a]
    return float((e1 * np.cross(e2, e3)).sum())


def _crosses(Z: np.ndarray, seg, tri):
    """+1 when segment ``seg`` properly crosses triangle ``tri`` (exact signs), 0 when it
    misses it, None when a sign is 0 (degenerate: leave the cluster alone)."""
    a, b = seg
    t0, t1, t2 = tri
    s = _signs(Z, [(t0, t1, t2, a), (t0, t1, t2, b), (a, b, t0, t1), (a, b, t1, t2),
                   (a, b, t2, t0)])
    if s[0] * s[1] > 0:
        return 0
    around = s[2:]
    if (around > 0).all() or (around < 0).all():
        return None if s[0] * s[1] == 0 else 1
    if (around >= 0).all() or (around <= 0).all():
        return None  # through an edge or a vertex of tri
    return 0


def _clusters(cs, cells: np.ndarray, refused, ee: int) -> dict:
    """{(cutting edge, vertex): [edge_edge points]} with two or more points, on the
    edges of the refused cells."""
    verts = set(cells[list(refused)].ravel().tolist())
    out: dict = {}
    for h in np.flatnonzero(cs.kind == ee).tolist():
        s = [int(x) for x in cs.sim[h] if x >= 0]
        e = tuple(sorted(int(x) for x in cs.cut[h] if x >= 0))
        for v in s:
            if v in verts:
                out.setdefault((e, v), []).append(h)
    return {k: hs for k, hs in out.items() if len(hs) >= 2}


def _beside(cut_cells: np.ndarray, e) -> list:
    rows = np.flatnonzero(np.isin(cut_cells, e).sum(axis=1) == 2)
    return [tuple(int(x) for x in cut_cells[r]) for r in rows.tolist()]


def _edge_point(Z, n, v, w, tri):
    """(sim weights on (v, w), cut weights on tri) of the crossing of (v, w) with tri
    (ids into Z; tri's ids offset by n)."""
    dv, dw = _det(Z, *tri, v), _det(Z, *tri, w)
    mu = dv / (dv - dw)
    x = (1.0 - mu) * Z[v] + mu * Z[w]
    lam = np.array([_det(Z, v, w, tri[1], tri[2]), _det(Z, v, w, tri[2], tri[0]),
                    _det(Z, v, w, tri[0], tri[1])])
    return x, (1.0 - mu, mu), lam / lam.sum()


def _resolve(Z, n, v, hs, cs, tris) -> list:
    """The cluster's points that properly cross one cutting triangle beside e, as rows
    (point, simulation edge, its weights, triangle, weights on it, place); the others —
    the two edges do cross, exactly or up to rounding — are kept as registered."""
    rows = []
    for h in hs:
        w = next(int(x) for x in cs.sim[h] if x >= 0 and x != v)
        found = [_crosses(Z, (v, w), tuple(n + p for p in t)) for t in tris]
        if None in found or sum(found) != 1:
            continue
        t = tris[found.index(1)]
        x, sw, cw = _edge_point(Z, n, v, w, tuple(n + p for p in t))
        if cw.min() > _ON_EDGE:
            rows.append((h, (v, w), sw, t, cw, x))
    return rows


def _face_points(Z: np.ndarray, n: int, e, faces, have: set):
    """Rows (sim face, its weights, e, weights on e, point) where e properly crosses a
    face; None when degenerate."""
    rows = []
    for F in faces:
        if any(c == e and set(sp) <= set(F) for sp, c in have):
            continue  # e's crossing there is registered already (on F or on its edge)
        r = _crosses(Z, (n + e[0], n + e[1]), F)
        if r is None:
            return None
        if not r:
            continue
        d0, d1 = _det(Z, *F, n + e[0]), _det(Z, *F, n + e[1])
        nu = d0 / (d0 - d1)
        x = (1.0 - nu) * Z[n + e[0]] + nu * Z[n + e[1]]
        a, b = n + e[0], n + e[1]
        lam = np.array([_det(Z, a, b, F[1], F[2]), _det(Z, a, b, F[2], F[0]),
                        _det(Z, a, b, F[0], F[1])])
        rows.append((F, lam / lam.sum(), e, (1.0 - nu, nu), x))
    return rows


def declump(res, cs, refused: list):
    """The cut surface of ``res`` with the clusters around the vertices of the
    ``refused`` cells re-decided (module docstring): a
    :class:`~predicates.registration.split.surface.CutSurface` with the new points after
    the registered ones, or None when there is none."""
    from predicates.registration.split.surface import cut_surface

    kinds = list(res.kinds)
    if res.dim != 3 or "edge_edge" not in kinds:
        return None
    X = np.asarray(res.sim_points, dtype=np.float64)
    n = len(X)
    Z = np.concatenate([X, np.asarray(res.cut_points, dtype=np.float64)])
    cells = np.asarray(res.sim_cells, dtype=np.int64)
    cut_cells = np.asarray(res.cut_cells, dtype=np.int64)
    table = [a.copy() for a in (cs.points, cs.kind, cs.sim, cs.sim_weights, cs.cut,
                                cs.cut_weights)]
    extra, added, changed = [], set(), False
    prims = [(tuple(sorted(int(x) for x in s if x >= 0)),
              tuple(sorted(int(x) for x in c if x >= 0))) for s, c in zip(cs.sim, cs.cut)]
    for (e, v), hs in _clusters(cs, cells, refused, kinds.index("edge_edge")).items():
        tris = _beside(cut_cells, e)
        around = cells[(cells == v).any(axis=1)]
        faces = sorted({tuple(sorted(int(x) for x in row if x != u))
                        for row in around.tolist() for u in row if u != v})
        moved = _resolve(Z, n, v, hs, cs, tris) if len(tris) == 2 else None
        # the (simulation, cutting) primitives of the points kept as they are
        have = None if moved is None else (
            set(prims) - {prims[h] for h, *_ in moved} | added)
        new = None if not moved else _face_points(Z, n, e, faces, have)
        if new is None:
            continue
        for h, s, sw, t, cw, x in moved:
            table[0][h], table[1][h] = x, kinds.index("edge_triangle")
            table[2][h], table[3][h] = [*s, -1, -1], [*sw, 0.0, 0.0]
            table[4][h], table[5][h] = list(t), cw
        for F, fw, e2, ew, x in new:
            added.add((F, e2))
            extra.append((x, kinds.index("triangle_edge"), [*F, -1], [*fw, 0.0],
                          [*e2, -1], [*ew, 0.0]))
        changed = True
    if not changed:
        return None
    for k in range(6):
        if extra:
            table[k] = np.concatenate([table[k], np.array([r[k] for r in extra],
                                                          dtype=table[k].dtype)])
    return cut_surface(res, hits=tuple(table))
