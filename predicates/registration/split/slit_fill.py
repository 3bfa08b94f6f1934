"""Filling a 2D region whose boundary holds a slit: a crack ending inside the cell
(docs/split.md, "The conforming tetrahedralization", "A crack tip inside a cell").

Such a region's boundary runs along the crack on both sides (edges a→b and b→a), so no
cone fills it: of the two triangles a cone puts on the slit's two sides, one is negative
whatever the apex. The boundary is instead walked as one *weakly simple* polygon (the
slit traversed up to the tip and back, its points repeated: at each point the walk takes
the outgoing edge first clockwise from the way it came, i.e. it keeps the region on its
left and turns into a slit before passing it) and triangulated by ear clipping on the
exact orientation of the stored coordinates: an ear is a strictly positive corner (a, b,
c) with a ≠ c and no other point of the polygon in its closed triangle. When the slit is
a straight segment from an edge to the tip inside a convex cell this is the fan from the
tip over the region's boundary; a bent slit or a non-convex region gets the same
construction.

Correct by check, not by trust: the triangles are returned only when every one is
positive by exact orientation and their edges pair up to exactly the boundary (each
boundary edge, the slit's two sides each once, is the edge of one triangle with its
orientation, every other edge shared by two triangles with opposite orientations). By
the winding-number argument of :mod:`~predicates.registration.split.conform` they then
tile the region once, and none crosses the slit (its edges are triangle edges on both
sides); the slit's two sides belong to different triangles, so the cut opens there
(``ConformingMesh.opened``) except at the tip.
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from predicates.registration.split.tetra_faces import positive

__all__ = ["fill_slit_region", "paired_edges"]


def _pseudo_angle(dx: float, dy: float) -> float:
    """A value in [0, 4) increasing with the angle of (dx, dy) (no transcendental
    function: the same on every CPU); it only orders the walk, the result is checked."""
    s = abs(dx) + abs(dy)
    p = dy / s
    if dx >= 0:
        return p if p >= 0 else 4.0 + p
    return 2.0 - p


def _walk(edges: list, Z: np.ndarray):
    """The boundary edges as one cyclic sequence of point ids keeping the region on the
    left (module docstring), or None when they form more than one cycle."""
    left = Counter(tuple(e) for e in edges)
    out_of: dict = {}
    for a, b in sorted(left):
        out_of.setdefault(a, []).append(b)
    start = min(left)
    ring, (u, v) = [start[0]], start
    left[start] -= 1
    while True:
        ring.append(v)
        back = _pseudo_angle(*(Z[u] - Z[v]))
        best, key = None, None
        for w in out_of.get(v, []):
            if left[(v, w)] <= 0:
                continue
            k = (back - _pseudo_angle(*(Z[w] - Z[v]))) % 4.0
            k = 4.0 if (w == u or k == 0.0) else k
            if key is None or k < key:
                best, key = w, k
        if best is None:
            break
        left[(v, best)] -= 1
        u, v = v, best
    if ring[-1] != ring[0] or any(k > 0 for k in left.values()):
        return None
    return ring[:-1]


def _signs(rows: list, Z: np.ndarray) -> np.ndarray:
    return positive(np.array(rows, dtype=np.int64).reshape(-1, 3), Z)


def _ear(ring: list, Z: np.ndarray):
    """The first occurrence i whose corner (ring[i-1], ring[i], ring[i+1]) is an ear."""
    n = len(ring)
    for i in range(n):
        a, b, c = ring[i - 1], ring[i], ring[(i + 1) % n]
        if a == c or len({a, b, c}) < 3 or _signs([(a, b, c)], Z)[0] <= 0:
            continue
        others = sorted(set(ring) - {a, b, c})
        if others:
            rows = [(x, y, p) for p in others for x, y in ((a, b), (b, c), (c, a))]
            inside = (_signs(rows, Z).reshape(-1, 3) >= 0).all(axis=1)
            if inside.any():
                continue
        return i
    return None


def paired_edges(tris: list, edges: list) -> bool:
    """Every boundary edge (a, b) is the edge of exactly one triangle with that
    orientation, and every other triangle edge is shared by two with opposite ones."""
    count = Counter((t[k], t[(k + 1) % 3]) for t in tris for k in range(3))
    for e in edges:
        e = tuple(e)
        if count[e] < 1:
            return False
        count[e] -= 1
    count = +count
    return all(count[(b, a)] == k for (a, b), k in count.items())


def fill_slit_region(edges: list, Z: np.ndarray):
    """Positive triangles tiling the 2D region bounded by the directed ``edges`` (the
    region on their left; a slit's two sides both listed), or None when the walk or the
    ear clipping finds none that passes the exact checks (module docstring)."""
    ring = _walk(edges, Z)
    if ring is None:
        return None
    tris = []
    while len(ring) > 3:
        i = _ear(ring, Z)
        if i is None:
            return None
        tris.append((ring[i - 1], ring[i], ring[(i + 1) % len(ring)]))
        del ring[i]
    tris.append(tuple(ring))
    if not paired_edges(tris, edges) or not np.all(_signs(tris, Z) > 0):
        return None
    return tris
