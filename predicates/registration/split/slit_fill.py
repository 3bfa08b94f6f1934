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
from itertools import islice

import numpy as np

from predicates.registration.split.enclosed import (area2, connected, exact_coords,
                                                    orient2 as _orient)
from predicates.registration.split.tetra_faces import positive

__all__ = ["crossing_segments", "fill_slit_region", "paired_edges"]


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
    ear clipping finds none that passes the exact checks (module docstring). A boundary
    in several pieces (a crack floating inside the cell, a hole) is first joined into
    one walk by bridges (:func:`_bridged`); each choice is kept only if the checks pass."""
    edges = [tuple(e) for e in edges]
    if _walk(edges, Z) is not None:
        return _clipped(edges, Z)
    for joined in _bridged(edges, Z):
        tris = _clipped(joined, Z)
        if tris is not None:
            return tris
    return None


def _clear(v, a, edges: list, F: dict) -> bool:
    """The closed segment v–a meets the boundary only at v and a, exactly: no other point
    on it, no edge crossing it (orientations of the stored coordinates, as Fractions)."""
    (vx, vy), (ax, ay) = F[v], F[a]
    for p in F:
        if p in (v, a) or _orient(F, v, a, p) != 0:
            continue
        if min(vx, ax) <= F[p][0] <= max(vx, ax) and min(vy, ay) <= F[p][1] <= max(vy, ay):
            return False
    for p, q in edges:
        if {p, q} & {v, a}:
            continue
        if _cross(F, v, a, p, q):
            return False
    return True


def _cross(F: dict, a, b, p, q) -> bool:
    """The open segments a–b and p–q cross at one interior point of both, exactly."""
    return (_orient(F, a, b, p) * _orient(F, a, b, q) < 0
            and _orient(F, p, q, a) * _orient(F, p, q, b) < 0)


def _bridged(edges: list, Z: np.ndarray):
    """Candidate edge lists with every other piece of the boundary joined to the outer
    one (the single piece enclosing positive area) by a bridge traversed both ways, from
    the first pair of points (smallest ids first) whose segment is clear (:func:`_clear`);
    yields one list per choice of the first bridge (the later ones greedy). Nothing when
    the outer piece is not unique."""
    F = exact_coords(sorted({p for e in edges for p in e}), Z)
    pieces = sorted(connected(edges), key=lambda g: min(p for e in g for p in e))
    comps = [sorted({p for e in g for p in e}) for g in pieces]
    outer = [c for c, g in zip(comps, pieces) if area2(g, F) > 0]
    if len(outer) != 1 or len(comps) > 8:
        return
    rest = [c for c in comps if c is not outer[0]]
    first = ((v, a) for v in outer[0] for a in rest[0] if _clear(v, a, edges, F))
    for v, a in islice(first, 16):  # lazily: each test is a pass over the boundary
        joined, main = edges + [(v, a), (a, v)], set(outer[0]) | set(rest[0])
        for comp in rest[1:]:
            pick = next(((u, b) for u in sorted(main) for b in comp
                         if _clear(u, b, joined, F)), None)
            if pick is None:
                break
            joined += [pick, pick[::-1]]
            main |= set(comp)
        else:
            yield joined


def _clipped(edges: list, Z: np.ndarray):
    """Ear clipping of the one walk of ``edges``, kept if the exact checks pass."""
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


def crossing_segments(edges: list, Z: np.ndarray):
    """Two boundary edges without a common point that meet — their open segments cross,
    or an end of one lies inside the other — exactly (orientations of the stored
    coordinates as Fractions), or None."""
    edges = sorted({tuple(sorted(e)) for e in edges})
    F = exact_coords({p for e in edges for p in e}, Z)

    def inside(p, a, b):  # p in the open segment a–b
        return _orient(F, a, b, p) == 0 and min(F[a], F[b]) < F[p] < max(F[a], F[b])

    for i, (a, b) in enumerate(edges):
        for p, q in edges[i + 1:]:
            if {a, b} & {p, q}:
                continue
            if _cross(F, a, b, p, q) or inside(p, a, b) or inside(q, a, b) or inside(
                    a, p, q) or inside(b, p, q):
                return (a, b), (p, q)
    return None
