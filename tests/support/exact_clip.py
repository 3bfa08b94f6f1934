"""Exact clipping in rational arithmetic (every float64 coordinate is a ``Fraction``):
the polygon of a triangle inside a tetrahedron (the segment of a segment inside a
triangle in 2D) with each vertex's supporting primitives, and the volume and first
moments of a tetrahedron clipped by half-spaces — the ground truth of the cut surface
and of the fragments' volumes (docs/split.md)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np


def fr(p) -> tuple:
    return tuple(Fraction(float(x)) for x in p)


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def det3(a, b, c):
    return dot(a, cross(b, c))


def _clip(poly, side):
    """Sutherland–Hodgman: the part of the closed polygon ``poly`` where side(x) ≥ 0."""
    out = []
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        sp, sq = side(p), side(q)
        if sp >= 0:
            out.append(p)
        if (sp > 0 > sq) or (sp < 0 < sq):
            t = sp / (sp - sq)
            out.append(tuple(a + t * (b - a) for a, b in zip(p, q)))
    res = []
    for p in out:  # consecutive duplicates (a clip through a vertex)
        if not res or res[-1] != p:
            res.append(p)
    while len(res) > 1 and res[0] == res[-1]:
        res.pop()
    return res


def simplex_halfspaces(V):
    """The inward half-spaces (n, a) of the simplex V (d+1 points): x inside ⇔ n·(x−a) ≥ 0
    for all."""
    d = len(V[0])
    out = []
    for k in range(d + 1):
        rest = [V[j] for j in range(d + 1) if j != k]
        if d == 3:
            n = cross(sub(rest[1], rest[0]), sub(rest[2], rest[0]))
        else:
            e = sub(rest[1], rest[0])
            n = (-e[1], e[0])
        if dot(n, sub(V[k], rest[0])) < 0:
            n = tuple(-x for x in n)
        out.append((n, rest[0]))
    return out


def barycentric(x, V):
    """Exact barycentric coordinates of x in the simplex V (d+1 points of ℝ^d), or in
    the triangle V (3 points of ℝ^3, x in its plane)."""
    if len(V) == len(x) + 1:
        E = [sub(v, V[0]) for v in V[1:]]
        r = sub(x, V[0])
        if len(x) == 3:
            D = det3(*E)
            lam = [det3(r, E[1], E[2]) / D, det3(E[0], r, E[2]) / D, det3(E[0], E[1], r) / D]
        else:
            D = E[0][0] * E[1][1] - E[0][1] * E[1][0]
            lam = [(r[0] * E[1][1] - r[1] * E[1][0]) / D, (E[0][0] * r[1] - E[0][1] * r[0]) / D]
        return [1 - sum(lam)] + lam
    if len(V) == 2:  # a point of a segment
        e, r = sub(V[1], V[0]), sub(x, V[0])
        t = dot(r, e) / dot(e, e)
        return [1 - t, t]
    n = cross(sub(V[1], V[0]), sub(V[2], V[0]))
    drop = max(range(3), key=lambda i: abs(n[i]))
    keep = [i for i in range(3) if i != drop]
    return barycentric(tuple(x[i] for i in keep), [tuple(v[i] for i in keep) for v in V])


def clipped(cut_pts, cell_pts):
    """The cutting simplex (triangle in 3D, segment in 2D) clipped by the cell, in the
    cutting simplex's orientation: [(point, cell corners holding it, cut corners holding
    it)], each set the corners with a non-zero barycentric coordinate."""
    poly = list(cut_pts)
    for n, a in simplex_halfspaces(cell_pts):
        if len(poly) == 2 and len(cut_pts) == 2:  # a segment: clip its two ends
            sa, sb = dot(n, sub(poly[0], a)), dot(n, sub(poly[1], a))
            if sa < 0 and sb < 0:
                return []
            if sa < 0 or sb < 0:
                t = sa / (sa - sb)
                x = tuple(p + t * (q - p) for p, q in zip(poly[0], poly[1]))
                poly = [x, poly[1]] if sa < 0 else [poly[0], x]
            continue
        poly = _clip(poly, lambda x, n=n, a=a: dot(n, sub(x, a)))
        if not poly:
            return []
    return [(p, frozenset(i for i, w in enumerate(barycentric(p, cell_pts)) if w != 0),
             frozenset(i for i, w in enumerate(barycentric(p, cut_pts)) if w != 0))
            for p in poly]


def polygon_area2(poly) -> Fraction:
    """Twice the area of a planar polygon of ℝ^3 (|Σ pᵢ × pᵢ₊₁|²; compared with 0)."""
    s = (0, 0, 0)
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        s = tuple(x + y for x, y in zip(s, cross(p, q)))
    return dot(s, s)


def _solve(planes):
    """The point on three planes (n, c): n·x = c, exact (Cramer's rule)."""
    (n1, c1), (n2, c2), (n3, c3) = planes
    D = det3(n1, n2, n3)
    if D == 0:
        return None
    c = (c1, c2, c3)
    cols = list(zip(n1, n2, n3))  # cols[k]: the k-th coordinate of the three normals

    def with_c(k):
        m = [list(r) for r in cols]
        m[k] = list(c)
        return det3(*[tuple(m[j][i] for j in range(3)) for i in range(3)])
    return tuple(with_c(k) / D for k in range(3))


def clipped_tet(cell_pts, planes):
    """Volume and first moment (∫x dV) of the tetrahedron ``cell_pts`` ∩ the half-spaces
    ``planes`` [(n, a): n·(x − a) ≥ 0], exact. Every new vertex is solved from three of
    the original planes (no interpolation, so the fractions do not grow) and keeps the
    set of planes it lies on; faces are clipped polygon by polygon, each cut closed by
    the cap on its plane, and the closed surface integrated (divergence theorem: fan
    tetrahedra from the origin)."""
    V = list(cell_pts)
    faces_idx = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
    flip = det3(sub(V[1], V[0]), sub(V[2], V[0]), sub(V[3], V[0])) < 0
    P = []  # planes (n, c): n·x >= c inside
    for f in faces_idx:
        a, b, c = (V[i] for i in f)
        n = cross(sub(b, a), sub(c, a))
        n = n if flip else tuple(-x for x in n)  # inward
        P.append((n, dot(n, a)))
    X = list(V)  # vertex id -> exact point
    on = [{k for k, f in enumerate(faces_idx) if i in f} for i in range(4)]
    ids = {tuple((c.numerator, c.denominator) for c in x): i for i, x in enumerate(V)}
    faces = [(k, list(f[::-1] if flip else f)) for k, f in enumerate(faces_idx)]
    for n, a in planes:
        h = len(P)
        P.append((n, dot(n, a)))
        alive = sorted({x for _, ring in faces for x in ring})
        side = {x: dot(n, X[x]) - P[h][1] for x in alive}
        if all(v >= 0 for v in side.values()):
            continue
        for x, v in side.items():
            if v == 0:
                on[x].add(h)
        new_faces, cap = [], {}
        for k, ring in faces:
            out = []
            for i, p in enumerate(ring):
                q = ring[(i + 1) % len(ring)]
                if side[p] >= 0:
                    out.append(p)
                if (side[p] > 0 > side[q]) or (side[p] < 0 < side[q]):
                    e = min((on[p] & on[q]) - {k})
                    pt = _solve([P[k], P[e], P[h]])
                    key = tuple((c.numerator, c.denominator) for c in pt)  # cheap hash
                    if key not in ids:
                        ids[key] = len(X)
                        X.append(pt)
                        on.append(set())
                    x = ids[key]
                    on[x].update((k, e, h))
                    side[x] = 0
                    out.append(x)
            if len(out) >= 3:
                new_faces.append((k, out))
                for i, p in enumerate(out):  # its edges on the new plane: the cap, reversed
                    q = out[(i + 1) % len(out)]
                    if side[p] == 0 and side[q] == 0:
                        cap[q] = p
        faces = new_faces
        if cap:
            start = next(iter(cap))
            ring, p = [start], cap[start]
            while p != start and len(ring) <= len(cap):
                ring.append(p)
                p = cap[p]
            if len(ring) >= 3:
                faces.append((h, ring))
    faces = [(k, [X[x] for x in ring]) for k, ring in faces]
    vol, mom = Fraction(0), [Fraction(0)] * 3
    for _, pts in faces:
        for i in range(1, len(pts) - 1):
            a, b, c = pts[0], pts[i], pts[i + 1]
            v = det3(a, b, c) / 6
            vol += v
            mom = [m + v * (a[k] + b[k] + c[k]) / 4 for k, m in enumerate(mom)]
    return vol, mom


def mesh_volume(P, T) -> tuple:
    """Exact volume and first moment enclosed by the closed, outward-oriented triangle
    mesh (P, T)."""
    vol, mom = Fraction(0), [Fraction(0)] * 3
    for t in np.asarray(T).tolist():
        a, b, c = (fr(P[i]) for i in t)
        v = det3(a, b, c) / 6
        vol += v
        mom = [m + v * (a[k] + b[k] + c[k]) / 4 for k, m in enumerate(mom)]
    return vol, mom
