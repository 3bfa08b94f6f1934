"""Triangulating one polygon of the cut by a rule on global ids (docs/split.md, "The
conforming tetrahedralization"): the polygon is given as global point ids with their
registered barycentric weights on a frame of three simplex vertices (the simulation face
it lies in, or the cutting triangle), and is triangulated in that frame, never on the
rounded coordinates.

Why the frame. The registered points of a face lie *on* it only up to rounding, but
their weights (paper, section 1: each registered pair carries its barycentric weights on
both primitives) place them in the face exactly: a point registered on an edge has
weight 0 on the opposite corner, so three points of one edge are exactly collinear in the
frame, and a triangle of them is recognised as degenerate instead of becoming a ±tiny
sliver in 3D. Orientations are signs of 3×3 determinants of the (homogeneous) weight
rows, decided exactly (:func:`det_sign`).

The rule (ear clipping, deterministic): the polygon is put counter-clockwise in the frame
(corners in increasing global id) and rotated to start at its smallest id; the first
vertex, in that order, that is a strictly convex ear (positive determinant) with no other
vertex of the polygon in its closed triangle is cut off — an ear that is nearly straight
(:func:`_flat`) only when no other is left; repeat. The result depends only
on the cyclic sequence of ids and their weights, so the two cells sharing a face (and the
two fragments sharing a cut polygon) get the same triangles.
"""
from __future__ import annotations

__all__ = ["NoEar", "det_sign", "dyadic_integers", "triangulate"]

#: |fl(det) − det| ≤ 5u·(1 + u)² · perm for the expansion below (u = 2⁻⁵³: two products
#: and a difference per minor, a product and a sum of three): 2⁻⁵⁰·perm is a safe filter
_FILTER = 2.0 ** -50


class NoEar(Exception):
    """The polygon has no non-degenerate triangulation in its frame (its vertices are
    collinear there, or it is not simple)."""


def det_sign(a, b, c) -> int:
    """The exact sign of det[a; b; c] for rows of three floats (homogeneous weights):
    floating point when |det| exceeds the error bound of its expansion, else in exact
    integers (:func:`dyadic_integers`)."""
    m0 = b[1] * c[2] - b[2] * c[1]
    m1 = b[0] * c[2] - b[2] * c[0]
    m2 = b[0] * c[1] - b[1] * c[0]
    d = a[0] * m0 - a[1] * m1 + a[2] * m2
    perm = (abs(a[0]) * (abs(b[1] * c[2]) + abs(b[2] * c[1]))
            + abs(a[1]) * (abs(b[0] * c[2]) + abs(b[2] * c[0]))
            + abs(a[2]) * (abs(b[0] * c[1]) + abs(b[1] * c[0])))
    if abs(d) > _FILTER * perm:
        return 1 if d > 0 else -1
    A, B, C = (dyadic_integers(r) for r in (a, b, c))
    e = (A[0] * (B[1] * C[2] - B[2] * C[1]) - A[1] * (B[0] * C[2] - B[2] * C[0])
         + A[2] * (B[0] * C[1] - B[1] * C[0]))
    return (e > 0) - (e < 0)


def dyadic_integers(values) -> list:
    """Floats as integers: all of them times the one power of two that clears every
    denominator (``as_integer_ratio``'s are powers of two). A positive factor per row of
    a determinant keeps its sign, and Python integers skip Fraction's gcd per operation
    (~10x faster; collinear points, whose determinant is exactly 0, always come here)."""
    ratios = [float(x).as_integer_ratio() for x in values]
    den = max(q for _, q in ratios)
    return [p * (den // q) for p, q in ratios]


def _inside(p, a, b, c) -> bool:
    """p in the closed triangle abc (counter-clockwise, homogeneous weights > 0)."""
    return det_sign(a, b, p) >= 0 and det_sign(b, c, p) >= 0 and det_sign(c, a, p) >= 0


def _near(p, a, b, c) -> bool:
    """p in the closed triangle abc or within the flatness margin of it."""
    return all(det_sign(x, y, p) >= 0 or _flat(x, y, p) for x, y in ((a, b), (b, c), (c, a)))


def _flat(a, b, c) -> bool:
    """An ear nearly straight in the frame (|det| ≤ 1e-9 of its weights' scale): points
    a registration placed on one line up to its tolerances, which in 3D would make a
    sliver of either orientation; taken only when no other ear is left."""
    m0 = b[1] * c[2] - b[2] * c[1]
    m1 = b[0] * c[2] - b[2] * c[0]
    m2 = b[0] * c[1] - b[1] * c[0]
    return abs(a[0] * m0 - a[1] * m1 + a[2] * m2) <= 1e-9


def _ear(ring: list, w: dict, flat_ok: bool):
    """The first ear of the ring: strictly convex with no other vertex in it; unless
    ``flat_ok``, also not flat and with no vertex near it (points on one registered line
    are taken as on it)."""
    n = len(ring)
    inside = _inside if flat_ok else _near
    for i in range(n):
        a, b, c = ring[i - 1], ring[i], ring[(i + 1) % n]
        if det_sign(w[a], w[b], w[c]) <= 0 or (not flat_ok and _flat(w[a], w[b], w[c])):
            continue
        if any(inside(w[p], w[a], w[b], w[c]) for p in ring if p not in (a, b, c)):
            continue
        return i
    return None


def _ears(ids: list, w: dict) -> list:
    out, ring = [], list(ids)
    while len(ring) > 3:
        i = _ear(ring, w, False)
        i = _ear(ring, w, True) if i is None else i
        if i is None:
            raise NoEar(f"no ear in the polygon {ring}")
        out.append((ring[i - 1], ring[i], ring[(i + 1) % len(ring)]))
        del ring[i]
    if det_sign(*(w[p] for p in ring)) <= 0:
        raise NoEar(f"a degenerate last triangle {ring}")
    out.append(tuple(ring))
    return out


def triangulate(ids: list, weights: dict, orientation: int) -> list:
    """Triangles (tuples of ids) of the polygon ``ids`` (cyclic, no repeats), oriented
    like it. ``weights[i]``: point i's three homogeneous weights on the frame;
    ``orientation``: +1 when ``ids`` runs counter-clockwise in the frame, −1 otherwise
    (known from where the polygon comes from). Raises :class:`NoEar` (module
    docstring)."""
    ring = list(ids) if orientation > 0 else list(ids)[::-1]
    k = ring.index(min(ring))
    tris = _ears(ring[k:] + ring[:k], weights)
    return tris if orientation > 0 else [t[::-1] for t in tris]
