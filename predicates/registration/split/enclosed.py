"""Regions that enclose others inside one cell: a cut that closes on itself without
touching the cell's boundary (docs/split.md, "A crack entirely inside one triangle",
"An inclusion inside one tetrahedron").

A closed cutting curve (2D) or surface (3D) strictly inside a cell bounds an island,
a piece of its own. The material around it is bounded by the cell's faces *and* the
island's other side, which the regions list apart: a region enclosing negative area or
volume (a hole, a cavity). :func:`merge_enclosed` joins it to the region around it.

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

__all__ = ["cavity_fill", "merge_enclosed"]


def _exact(points, Z: np.ndarray) -> dict:
    return {p: tuple(Fraction(float(x)) for x in Z[p]) for p in points}


def _volume6(tris, F: dict) -> Fraction:
    """Six times the exact signed volume the outward triangles enclose (the cavity's
    side of a closed surface: < 0)."""
    total = Fraction(0)
    for a, b, c in tris:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = F[a], F[b], F[c]
        total += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return total


def merge_enclosed(frag_tris: dict, where: list, Z: np.ndarray, d: int) -> dict:
    """Each region enclosing negative measure (a hole, a cavity) joined to the region of
    its cell around it: in 2D the one whose boundary winds around it
    (:func:`~.slit_fill.merge_holes`); in 3D the one region of the cell with positive
    volume that shares no point with it (more than one: unchanged, a refusal names the
    cell)."""
    if d == 2:
        from predicates.registration.split.slit_fill import merge_holes

        return merge_holes(frag_tris, where, Z)
    by_cell: dict = {}
    for f in frag_tris:
        by_cell.setdefault(where[f][0], []).append(f)
    out = dict(frag_tris)
    for fs in (fs for fs in by_cell.values() if len(fs) > 2):
        F = _exact(sorted({p for f in fs for t in frag_tris[f] for p in t}), Z)
        vol = {f: _volume6(frag_tris[f], F) for f in fs}
        for h in (f for f in fs if vol[f] < 0):
            mine = {p for t in frag_tris[h] for p in t}
            hosts = [f for f in fs if vol[f] > 0 and f in out
                     and not mine & {p for t in frag_tris[f] for p in t}]
            if len(hosts) == 1:
                out[hosts[0]] = list(out[hosts[0]]) + list(out.pop(h))
    return out


def _pieces(tris) -> list:
    """The triangles' connected pieces (sharing a point), as lists of triangles."""
    parent: dict = {}

    def root(x):
        while parent.setdefault(x, x) != x:
            x = parent[x]
        return x

    for t in tris:
        for p in t[1:]:
            parent[root(p)] = root(t[0])
    groups: dict = {}
    for t in tris:
        groups.setdefault(root(t[0]), []).append(tuple(t))
    return list(groups.values())


def cavity_fill(tris, Z: np.ndarray):
    """Tetrahedra filling a region bounded by an outer surface and one cavity (module
    docstring: beneath-beyond from the cavity), or None when the boundary is not two
    pieces, one enclosing positive and one negative volume, or an outer point sees no
    face of the current hull. Unchecked: the caller checks positivity and pairing."""
    pieces = _pieces(tris)
    if len(pieces) != 2:
        return None
    F = _exact(sorted({p for t in tris for p in t}), Z)
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
