"""The regions of one cell cut by the cut polygons (docs/split.md, "The conforming
tetrahedralization"): the connected parts of the cell minus the cut surface, as closed
shells of *patches* — the regions of its faces cut by the chords (part 1,
:mod:`~predicates.registration.split.regions`) and the two sides of every cut polygon
(the back: the polygon as it is; the front: reversed).

Patches are oriented outward from the region they bound, so two patches of one region
meet along an edge traversed once each way. At an edge (2D: a point) where exactly two
patches meet, they are glued. Where more meet (a chord: two face regions and a polygon's
two sides; an edge shared by two cut polygons: four sides), a face region is glued to the
polygon side running the other way — never to the face region across the chord, which
the cut separates — and a polygon side to the other polygon's side, never to its own
other side; the two sides of a polygon are glued only along an edge where nothing else
meets: the boundary of the cut inside the cell, a crack tip, around which the material
stays connected. Anything else (a non-manifold cut) is :class:`Unresolved`. Unlike the
fragments of the virtual-node split, regions follow the geometry: the material between
two crossings of one edge, or a cap of the cut bulging into a cell, is a region of its
own.
"""
from __future__ import annotations

from predicates.registration.split.regions import Unresolved

__all__ = ["cell_regions"]


def _joints(cyc, d: int):
    """(joint, +1 / −1) of a patch: its edges (3D) or its end points (2D)."""
    if d == 2:
        return [(cyc[0], +1), (cyc[1], -1)]
    out = []
    for a, b in zip(cyc, cyc[1:] + cyc[:1]):
        out.append(((a, b), +1) if a < b else ((b, a), -1))
    return out


def _pairs(fwd, bwd, kind):
    """The gluing of the patches meeting at one joint (module docstring)."""
    if len(fwd) == 1 and len(bwd) == 1:
        return [(fwd[0], bwd[0])]
    out = []
    for f in fwd:
        ok = [b for b in bwd if not (kind[f][0] == "face" and kind[b][0] == "face")
              and not (kind[f][0] == "cut" and kind[b][0] == "cut"
                       and kind[f][1] == kind[b][1])]
        if len(ok) != 1:
            raise Unresolved("a joint where the cut is not a manifold")
        out.append((f, ok[0]))
    if len({b for _, b in out}) != len(out):
        raise Unresolved("a joint glued twice")
    return out


def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def cell_regions(face_patches, polys, d: int):
    """[(region, node cycle)]: ``face_patches`` the face regions (3D) or edge segments
    (2D) of the cell as node cycles oriented outward, ``polys`` its cut polygons (node
    cycles, the cut's orientation). Regions numbered 0.. in order of first patch."""
    patches = [list(p) for p in face_patches]
    kind = [("face", i) for i in range(len(patches))]
    for q, P in enumerate(polys):
        patches += [list(P), list(P[::-1]) if d == 3 else [P[1], P[0]]]
        kind += [("cut", q), ("cut", q)]
    at: dict = {}
    for i, cyc in enumerate(patches):
        for j, s in _joints(cyc, d):
            at.setdefault(j, ([], []))[0 if s > 0 else 1].append(i)
    parent = list(range(len(patches)))
    for j in sorted(at, key=repr):
        fwd, bwd = at[j]
        if len(fwd) != len(bwd):
            raise Unresolved("a patch edge without its partner")
        for a, b in _pairs(fwd, bwd, kind):
            parent[_find(parent, a)] = _find(parent, b)
    roots, out = {}, []
    for i, cyc in enumerate(patches):
        r = roots.setdefault(_find(parent, i), len(roots))
        out.append((r, cyc))
    return out
