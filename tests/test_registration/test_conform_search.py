"""The fallbacks of the conforming tetrahedralization (predicates.registration.split.
search, docs/split.md "The conforming tetrahedralization") against exact arithmetic: the
backtracking search and the fan from a boundary point fill non-convex regions with
tetrahedra positive in ``Fraction`` whose faces pair up to exactly the given boundary and
whose volumes add up to the exact volume; a folded boundary (a zero-thickness flap) is
recognised and never filled."""
from __future__ import annotations

from collections import Counter
from fractions import Fraction

import numpy as np

from conform_check import orientation_signs
from predicates.registration.split.search import (fan_from_boundary, folded_triangle,
                                                  orient_signs, paired, search_fill)

OUT = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
KUHN = ((0, 1, 3, 7), (0, 1, 5, 7), (0, 2, 3, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 4, 6, 7))


def _canon(f):
    k = f.index(min(f))
    return tuple(f[k:]) + tuple(f[:k])


def _positive(P, tets):
    tets = np.array(tets, dtype=np.int64)
    s = orientation_signs(P, tets)
    return np.where(s < 0, tets[:, [1, 0, 2, 3]].T, tets.T).T


def _union_of_cubes(origins):
    """Points and positive Kuhn tetrahedra of unit cubes at the given integer origins,
    with the oriented boundary (faces used once)."""
    pts, index, tets = [], {}, []
    for o in origins:
        ids = []
        for k in range(8):
            x = (o[0] + (k & 1), o[1] + ((k >> 1) & 1), o[2] + ((k >> 2) & 1))
            if x not in index:
                index[x] = len(pts)
                pts.append(x)
            ids.append(index[x])
        tets += [tuple(ids[k] for k in t) for t in KUHN]
    P = np.array(pts, dtype=np.float64)
    tets = _positive(P, tets).tolist()
    count = Counter(_canon(tuple(t[k] for k in f)) for t in tets for f in OUT)
    tris = [f for f, c in count.items() if count[_canon(f[::-1])] == 0 for _ in range(c)]
    return P, tris


def _exact_volume(P, tets) -> Fraction:
    out = Fraction(0)
    for t in tets:
        Q = [[Fraction(float(x)) for x in P[v]] for v in t]
        e = [[a - b for a, b in zip(q, Q[0])] for q in Q[1:]]
        out += (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
                - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
                + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])) / 6
    return out


def _assert_fills(P, tris, tets, volume):
    assert tets is not None
    assert np.all(orientation_signs(P, np.array(tets, dtype=np.int64)) > 0)
    chain = Counter()
    for t in tets:  # the tetrahedra's boundary as a chain must be exactly ``tris``
        for f in OUT:
            chain[_canon(tuple(t[k] for k in f))] += 1
    for f in list(chain):
        r = _canon(f[::-1])
        m = min(chain[f], chain[r])
        chain[f] -= m
        chain[r] -= m
    assert +chain == Counter(_canon(tuple(t)) for t in tris)
    assert _exact_volume(P, tets) == volume


def test_search_fills_a_non_convex_region():
    """An L of three unit cubes and a U of five (not convex, faces coplanar with
    many of their points)."""
    for origins, vol in (([(0, 0, 0), (1, 0, 0), (0, 1, 0)], 3),
                         ([(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (2, 1, 0)], 5)):
        P, tris = _union_of_cubes(origins)
        _assert_fills(P, tris, search_fill(tris, P, budget=2000), Fraction(vol))


def test_fan_from_a_boundary_point():
    """Two tetrahedra on either side of a triangle abc, their apexes' segment passing
    outside it (not convex): the fan from a, skipping the triangles through a, is the
    two tetrahedra; the L of three cubes has faces coplanar with each of its points and
    no fan (a zero-volume tetrahedron is never returned)."""
    P = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [3, 3, 2], [3, 3, -2]], dtype=np.float64)
    a, b, c, d, e = range(5)
    tris = [(a, b, d), (b, c, d), (c, a, d), (a, e, b), (b, e, c), (c, e, a)]
    _assert_fills(P, tris, fan_from_boundary(tris, P), Fraction(32, 3))
    P, tris = _union_of_cubes([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    assert fan_from_boundary(tris, P) is None


def test_a_folded_boundary_is_recognised_and_not_filled():
    """A tetrahedron whose face abc is fanned from a point m of its plane outside the
    triangle: the triangle (b, c, m) is a flap lying over (a, b, m) and (c, a, m) with the
    opposite orientation (winding 0 on both sides): no positive tetrahedra have it as a
    face."""
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=np.float64)
    a, b, c, d, m = range(5)
    tris = [(a, c, b), (a, b, d), (b, c, d), (c, a, d)]  # outward, abc seen from below
    tris = [(a, m, b), (b, m, c), (c, m, a)] + tris[1:]
    assert folded_triangle(tris, P) == (b, m, c)
    assert search_fill(tris, P) is None
    assert fan_from_boundary(tris, P) is None
    # a tetrahedron's own boundary is not folded
    assert folded_triangle([(a, c, b), (a, b, d), (b, c, d), (c, a, d)], P) is None


def test_orient_signs_exact_on_near_coplanar_points():
    """Points within rounding of one plane: the filter hands them to Fraction."""
    rng = np.random.default_rng(5)
    base = rng.random((200, 3, 3))
    w = rng.random((200, 3))
    w /= w.sum(axis=1, keepdims=True)
    D = (w[:, :, None] * base).sum(axis=1)  # on the plane up to rounding
    P = np.concatenate([base, D[:, None]], axis=1)
    want = []
    for T in P:
        Q = [[Fraction(float(x)) for x in p] for p in T]
        e = [[x - y for x, y in zip(q, Q[0])] for q in Q[1:]]
        det = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
               - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
               + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
        want.append((det > 0) - (det < 0))
    assert orient_signs(P).tolist() == want


def test_paired_rejects_a_filling_that_crosses_a_slit():
    """A tetrahedron with a crack triangle inside it (both sides in the boundary, as a
    region around a crack front has): the tetrahedron alone bounds that boundary as a
    chain (the two sides cancel) but not as triangles, so it is rejected."""
    a, b, c, d, e = range(5)
    box = [(a, c, b), (a, b, d), (b, c, d), (c, a, d)]
    slit = [(a, b, e), (b, a, e)]
    assert paired([(a, b, c, d)], box)
    assert not paired([(a, b, c, d)], box + slit)
