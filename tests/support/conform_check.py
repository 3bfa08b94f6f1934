"""Exact checks of a conforming simplicial mesh of the split (docs/split.md, "The
conforming tetrahedralization"), independent of the code under test: orientations in
``Fraction`` (after a float filter whose margin is far above rounding), face incidences,
closed piece boundaries, and exact reference volumes of the cut pieces."""
from __future__ import annotations

import collections
from fractions import Fraction

import numpy as np

from exact_clip import _clip, fr, mesh_volume


def _det_exact(P) -> Fraction:
    P = [[Fraction(float(x)) for x in p] for p in P]
    E = [[a - b for a, b in zip(p, P[0])] for p in P[1:]]
    if len(E) == 2:
        return E[0][0] * E[1][1] - E[0][1] * E[1][0]
    return (E[0][0] * (E[1][1] * E[2][2] - E[1][2] * E[2][1])
            - E[0][1] * (E[1][0] * E[2][2] - E[1][2] * E[2][0])
            + E[0][2] * (E[1][0] * E[2][1] - E[1][1] * E[2][0]))


def orientation_signs(points, cells) -> np.ndarray:
    """The exact orientation sign of every simplex on its stored float coordinates."""
    X = points[cells]
    E = X[:, 1:] - X[:, :1]
    if cells.shape[1] == 4:
        v = (E[:, 0, 0] * (E[:, 1, 1] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 1])
             - E[:, 0, 1] * (E[:, 1, 0] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 0])
             + E[:, 0, 2] * (E[:, 1, 0] * E[:, 2, 1] - E[:, 1, 1] * E[:, 2, 0]))
    else:
        v = E[:, 0, 0] * E[:, 1, 1] - E[:, 0, 1] * E[:, 1, 0]
    scale = np.abs(E).max(axis=(1, 2)) ** (cells.shape[1] - 1)
    sign = np.sign(v).astype(np.int64)
    unsure = np.flatnonzero(np.abs(v) <= 1e-6 * scale)  # far above rounding: exact below
    for k in unsure.tolist():
        e = _det_exact(X[k])
        sign[k] = (e > 0) - (e < 0)
    return sign


def _faces(cells):
    d = cells.shape[1] - 1
    if d == 3:
        idx = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]
    else:
        idx = [(1, 2), (2, 0), (0, 1)]
    return [tuple(row[k] for k in f) for row in cells.tolist() for f in idx]


def incidence(cm, boundary_point) -> dict:
    """Counts of the face incidences: ``bad_interior`` (faces of two simplices of
    different pieces that are not cut faces), ``cut_unpaired`` (cut faces without one
    simplex on each side with the same nodes), ``over`` (faces of > 2 simplices),
    ``stray`` (faces of one simplex neither on the mesh's boundary nor cut).
    ``boundary_point(p)``: the original boundary faces point p lies on (a set)."""
    d = cm.dim
    F = _faces(cm.cells)
    owner = collections.defaultdict(list)
    for i, f in enumerate(F):
        owner[tuple(sorted(f))].append((i // (d + 1), f))
    cut = {tuple(sorted(f)) for f in cm.cut_faces.tolist()}
    out = dict(bad_interior=0, cut_unpaired=0, over=0, stray=0, cut_faces=len(cut),
               faces=len(owner))
    for key, own in owner.items():
        if len(own) > 2:
            out["over"] += 1
        elif len(own) == 2:
            (s, f), (t, g) = own
            if key in cut:
                if f == g or sorted(f) != sorted(g):
                    out["cut_unpaired"] += 1
            elif cm.piece[s] != cm.piece[t]:
                out["bad_interior"] += 1
        else:
            if key in cut:
                out["cut_unpaired"] += 1
            elif not set.intersection(*(boundary_point(p) for p in key)):
                out["stray"] += 1
    return out


def piece_boundaries(cm) -> dict:
    """Per piece, the edges (2D: vertices) of its boundary not used exactly once in each
    direction: ``open`` (unmatched) and ``nonmanifold`` (used more than once one way)."""
    out = {"open": 0, "nonmanifold": 0}
    for p in range(cm.n_pieces):
        F = _faces(cm.cells[cm.piece == p])
        cnt = collections.Counter(tuple(sorted(f)) for f in F)
        bnd = [f for f in F if cnt[tuple(sorted(f))] == 1]
        if cm.dim == 3:
            edges = collections.Counter((f[i], f[(i + 1) % 3]) for f in bnd for i in range(3))
        else:  # a segment a→b: vertex a leaves once, b is entered once
            edges = collections.Counter((f[0], "out") for f in bnd)
            edges.update((f[1], "in") for f in bnd)
        for (a, b), k in edges.items():
            rev = edges.get((b, a), 0) if cm.dim == 3 else edges.get(
                (a, "in" if b == "out" else "out"), 0)
            if k > 1 or rev > 1:
                out["nonmanifold"] += 1
            elif rev != 1:
                out["open"] += 1
    return out


def boundary_locator(res, cs):
    """p -> the set of original boundary faces (sorted vertex tuples) point p of a
    conforming mesh lies on, from its registered primitive."""
    cells = np.asarray(res.sim_cells)
    d = cells.shape[1] - 1
    cnt = collections.Counter(tuple(sorted(f)) for c in cells.tolist()
                              for f in _sub(c, d))
    bfaces = [f for f, k in cnt.items() if k == 1]
    by_vertex = collections.defaultdict(set)
    for f in bfaces:
        for v in f:
            by_vertex[v].add(f)

    def locate(cm, p):
        if cm.point_kind[p] == 0:
            return set(by_vertex.get(int(p), set()))
        if cm.point_kind[p] == 2:
            return set()
        ids = [int(i) for i in cs.sim[cm.point_hit[p]] if i >= 0]
        return {f for f in by_vertex.get(ids[0], set()) if set(ids) <= set(f)}
    return locate


def _sub(c, d):
    import itertools
    return itertools.combinations(c, d)


def below_surface_volume(Q, K) -> Fraction:
    """The exact volume of {x in [0,1]³ : x below the surface (Q, K)} for a surface that
    is a graph z = f(x, y) over the unit square, 0 ≤ f ≤ 1: Σ over its triangles of the
    integral of their linear z over their xy-projection clipped to the square (a point
    of the square the projections leave uncovered counts 0: at most rounding far)."""
    total = Fraction(0)
    for t in np.asarray(K).tolist():
        poly = [fr(Q[i]) for i in t]
        for side in (lambda x: x[0], lambda x: 1 - x[0], lambda x: x[1], lambda x: 1 - x[1]):
            poly = _clip(poly, side) if poly else poly
        for i in range(1, len(poly) - 1):
            a, b, c = poly[0], poly[i], poly[i + 1]
            area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            total += abs(area2) / 2 * (a[2] + b[2] + c[2]) / 3
    return total


def closed_surface_volume(Q, K) -> Fraction:
    return abs(mesh_volume(Q, K)[0])


def polygon_area(Q) -> Fraction:
    P = [fr(q) for q in Q]
    s = sum(P[i][0] * P[(i + 1) % len(P)][1] - P[(i + 1) % len(P)][0] * P[i][1]
            for i in range(len(P)))
    return abs(s) / 2


def exact_mesh_volume(P, cells) -> Fraction:
    return sum(abs(_det_exact(P[c])) for c in np.asarray(cells)) / (
        6 if np.asarray(cells).shape[1] == 4 else 2)


def polygon_area_3d(T) -> float:
    """The area of a triangle in 3D from its float corners, in Fraction arithmetic up to
    the final square root: √(Σ (exact cross product components)²) / 2."""
    P = [[Fraction(float(x)) for x in p] for p in T]
    a = [x - y for x, y in zip(P[1], P[0])]
    b = [x - y for x, y in zip(P[2], P[0])]
    c = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return float(sum(x * x for x in c)) ** 0.5 / 2
