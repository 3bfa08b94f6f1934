"""Regions that enclose others inside one cell: a cut that closes on itself without
touching the cell's boundary (docs/split.md, "A crack entirely inside one triangle",
"An inclusion inside one tetrahedron").

A closed cutting curve (2D) or surface (3D) strictly inside a cell bounds an island,
a piece of its own. The material around it is bounded by the cell's faces *and* the
island's other side, which the regions list apart: a region enclosing negative area or
volume (a hole, a cavity). :func:`merge_enclosed` joins it to the region around it. The
exact primitives on a region's boundary (its pieces, signed measure, orientations) are
here too, for the 2D bridging of :mod:`~.slit_fill`.

Filling the region around a cavity (3D): no cone fills it (the cavity hides part of its
boundary from any apex). When the cavity is convex and the outer boundary is the convex
hull of its points (a tetrahedron's faces), the region is conv(K ∪ outer points) minus
K, which the *beneath-beyond* construction of the convex hull tetrahedralizes: starting
from the cavity K, each outer point v in turn is joined to every face of the current
hull it sees strictly (exact orient3d), and the hull's faces are updated across the
horizon. Every tetrahedron added lies outside the current hull and inside the next one,
so they tile the region once; the result is nevertheless kept only if every one is
positive and their faces pair up to exactly the region's boundary (the caller's check),
so a non-convex cavity or a degenerate configuration is refused, never mis-filled.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from predicates.registration.split.tetra_faces import positive

__all__ = ["area2", "cavity_fill", "connected", "exact_coords", "merge_enclosed", "orient2"]


def exact_coords(points, Z: np.ndarray) -> dict:
    """{point: its stored coordinates as Fractions} (exact arithmetic on them)."""
    return {p: tuple(Fraction(float(x)) for x in Z[p]) for p in points}


def connected(simplices) -> list:
    """The boundary simplices' connected pieces (sharing a point), as lists of tuples."""
    parent: dict = {}

    def root(x):
        while parent.setdefault(x, x) != x:
            x = parent[x]
        return x

    for t in simplices:
        for p in t[1:]:
            parent[root(p)] = root(t[0])
    groups: dict = {}
    for t in simplices:
        groups.setdefault(root(t[0]), []).append(tuple(t))
    return list(groups.values())


def orient2(F: dict, a, b, c) -> Fraction:
    """Twice the signed area of the triangle (a, b, c), exactly."""
    (ax, ay), (bx, by), (cx, cy) = F[a], F[b], F[c]
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def area2(edges, F: dict) -> Fraction:
    """Twice the exact signed area the directed edges enclose (a slit's two sides
    cancel: 0; an outer boundary > 0; a hole < 0)."""
    return sum((F[a][0] * F[b][1] - F[a][1] * F[b][0] for a, b in edges), Fraction(0))


def _volume6(tris, F: dict) -> Fraction:
    """Six times the exact signed volume the outward triangles enclose (the cavity's
    side of a closed surface: < 0)."""
    total = Fraction(0)
    for a, b, c in tris:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = F[a], F[b], F[c]
        total += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return total


def _winding(edges, p, F: dict) -> int:
    """The winding number of the directed ``edges`` around point ``p`` (not on them),
    exactly (crossings of the ray to +x, signs by exact orientation)."""
    w, (_, py) = 0, F[p]
    for a, b in edges:
        ay, by = F[a][1], F[b][1]
        if ay <= py < by and orient2(F, a, b, p) > 0:
            w += 1
        elif by <= py < ay and orient2(F, a, b, p) < 0:
            w -= 1
    return w


def _encloses(host, hole, F: dict, d: int) -> bool:
    """2D: the host's boundary winds around the hole's first point, not on it; 3D: the
    host shares no point with the cavity (the cell's one other region around it)."""
    if d == 2:
        p = hole[0][0]
        return all(p not in e for e in host) and _winding(host, p, F) != 0
    mine = {p for t in hole for p in t}
    return not mine & {p for t in host for p in t}


def merge_enclosed(frag_tris: dict, where: list, Z: np.ndarray, d: int) -> dict:
    """Each region enclosing negative measure (a hole, a cavity) joined to the one
    region of its cell (``where[f][0]``) with positive measure around it
    (:func:`_encloses`, decided exactly); :func:`~.slit_fill.fill_slit_region` then
    bridges a hole, :func:`cavity_fill` fills around a cavity. Unchanged where no
    region or more than one qualifies (a refusal names the cell)."""
    measure = area2 if d == 2 else _volume6
    by_cell: dict = {}
    for f in frag_tris:
        by_cell.setdefault(where[f][0], []).append(f)
    out = dict(frag_tris)
    for fs in (fs for fs in by_cell.values() if len(fs) > d - 1):
        F = exact_coords(sorted({p for f in fs for t in frag_tris[f] for p in t}), Z)
        size = {f: measure(frag_tris[f], F) for f in fs}
        for h in (f for f in fs if size[f] < 0):
            hosts = [f for f in fs if size[f] > 0 and f in out
                     and _encloses(frag_tris[f], frag_tris[h], F, d)]
            if len(hosts) == 1:
                out[hosts[0]] = list(out[hosts[0]]) + list(out.pop(h))
    return out


def cavity_fill(tris, Z: np.ndarray):
    """Tetrahedra filling a region bounded by an outer surface and one cavity (module
    docstring: beneath-beyond from the cavity), or None when the boundary is not two
    pieces, one enclosing positive and one negative volume, or an outer point sees no
    face of the current hull. Unchecked: the caller checks positivity and pairing."""
    pieces = connected(tris)
    if len(pieces) != 2:
        return None
    F = exact_coords(sorted({p for t in tris for p in t}), Z)
    vol = [_volume6(p, F) for p in pieces]
    if not (min(vol) < 0 < max(vol)):
        return None
    outer, cavity = (pieces[0], pieces[1]) if vol[0] > 0 else (pieces[1], pieces[0])
    hull = [t[::-1] for t in cavity]  # the cavity's faces, outward from it
    tets = []
    for v in sorted({p for t in outer for p in t} - {p for t in cavity for p in t}):
        sees = positive(np.array([t + (v,) for t in hull], dtype=np.int64), Z) > 0
        if not sees.any():
            return None
        lit = {e for t, s in zip(hull, sees.tolist()) if s
               for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
        tets += [t + (v,) for t, s in zip(hull, sees.tolist()) if s]
        horizon = [e for e in lit if e[::-1] not in lit]
        hull = [t for t, s in zip(hull, sees.tolist()) if not s] + [
            (a, b, v) for a, b in sorted(horizon)]
    return tets
