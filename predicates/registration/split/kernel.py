"""A point of the kernel of a fragment (docs/split.md, "The conforming
tetrahedralization"): the set of points from which the whole boundary is seen from
inside, i.e. the intersection of the inner half-spaces of its boundary simplices. A
fragment that is not convex (the outside of a curved cut inside a cell) is filled by
a cone from such a point. The kernel is a convex polytope; its vertices are found by
brute force over triples of the boundary's planes (a fragment has a few dozen boundary
triangles), solved by Cramer's rule elementwise (no BLAS), and their mean, strictly
inside when the kernel has an interior, is returned. The cone from it is then checked
exactly like any other (:mod:`~predicates.registration.split.conform`): this point only
proposes, it decides nothing.
"""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["kernel_point"]


def _planes(tris, Y):
    """Unit outward normals and offsets (n·x ≤ o inside) of the boundary, distinct."""
    P = Y[np.array(tris, dtype=np.int64)]
    if P.shape[1] == 2:  # 2D: an edge a→b of a counter-clockwise boundary
        e = P[:, 1] - P[:, 0]
        N = np.stack([e[:, 1], -e[:, 0]], 1)
    else:
        N = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    ln = np.sqrt((N * N).sum(axis=1))
    ok = ln > 0
    N = N[ok] / ln[ok, None]
    off = (N * P[ok, 0]).sum(axis=1)
    key = np.round(np.column_stack([N, off]), 12)
    _, first = np.unique(key, axis=0, return_index=True)
    first.sort()
    return N[first], off[first]


def _solve(N, off, combos):
    """Intersection points of the plane triples (lines pairs in 2D), Cramer's rule."""
    A = N[combos]  # (k, d, d)
    b = off[combos]
    if N.shape[1] == 2:
        det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
        x = (b[:, 0] * A[:, 1, 1] - b[:, 1] * A[:, 0, 1])
        y = (A[:, 0, 0] * b[:, 1] - A[:, 1, 0] * b[:, 0])
        return np.stack([x, y], 1), det
    c12 = np.cross(A[:, 1], A[:, 2])
    c20 = np.cross(A[:, 2], A[:, 0])
    c01 = np.cross(A[:, 0], A[:, 1])
    det = (A[:, 0] * c12).sum(axis=1)
    num = b[:, 0, None] * c12 + b[:, 1, None] * c20 + b[:, 2, None] * c01
    return num, det


def kernel_point(tris, Y, limit: int = 60):
    """A point strictly inside the kernel of the closed boundary ``tris`` (outward
    simplices of point ids into ``Y``), or None when none is found (an empty or flat
    kernel, or more than ``limit`` distinct planes)."""
    N, off = _planes(tris, Y)
    d = N.shape[1]
    if len(N) > limit or len(N) <= d:
        return None
    combos = np.array(list(itertools.combinations(range(len(N)), d)), dtype=np.int64)
    num, det = _solve(N, off, combos)
    good = np.abs(det) > 1e-9
    X = num[good] / det[good, None]
    scale = max(1.0, float(np.abs(off).max()))
    inside = np.all((X[:, None, :] * N[None]).sum(axis=2) <= off[None] + 1e-12 * scale,
                    axis=1)
    V = X[inside]
    if len(V) <= d:
        return None
    return V.sum(axis=0) / len(V)
