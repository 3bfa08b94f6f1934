"""Faces with every vertex on the cut: is the face itself cut (docs/split.md, rule 3)?

A simulation face (a triangle in 3D, an edge in 2D) whose vertices are all registered on
the cut may lie in the cutting surface (a cut along mesh faces: a multi-material
interface) or only touch it at its vertices (a face across a sharp corner of the cut).
The decision is taken once per face, from the registered pairs on its closure only (the
paper's registration decides every primitive once), so both cells on the face agree:

* an **edge** (a, b) of the face *lies on the cut* when every two consecutive registered
  points along it (a, the points of the pairs whose simulation primitive is the edge,
  ordered by their weight, b) lie on one common cutting cell: each is registered with a
  cutting primitive, and some cutting cell holds both primitives. The closure of a
  cutting cell is convex, so the segment between the two points lies in that cell;
* a 2D face (an edge) is **covered** when it lies on the cut;
* a 3D face is **covered** when its three edges lie on the cut and either one cutting
  triangle holds all three vertices' primitives (then the face lies in that triangle)
  or the cut's own mesh passes through the face (a registered point on it other than
  its vertices: coplanar cutting triangles meeting across the face).

The limit (docs/split.md, "Approximations"): three cutting triangles forming a tent over
the face, each through one of its edges, with a further cutting vertex or edge on one of
the face's edges, would be taken for a covering.
"""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["covered_faces"]


class _CutIncidence:
    """Cutting cells around cutting primitives (the cutting mesh as registered)."""

    def __init__(self, cut_cells: np.ndarray):
        self.of_vertex: dict = {}
        for c, row in enumerate(np.asarray(cut_cells).tolist()):
            for v in row:
                self.of_vertex.setdefault(v, set()).add(c)

    def common(self, ids) -> bool:
        """Is there a cutting cell holding every vertex id of ``ids``?"""
        sets = [self.of_vertex.get(v, set()) for v in set(ids)]
        return bool(sets) and bool(set.intersection(*sets))


def _points_by_primitive(res, verts: np.ndarray):
    """{sorted simulation primitive: [(parameter, cutting primitive ids)]} for the pairs
    whose simulation primitive has all its vertices in ``verts`` (a bool mask). The
    parameter orders the points along an edge: the weight of its larger vertex id."""
    out: dict = {}
    for kind in res.kinds:
        p = res[kind]
        if not len(p):
            continue
        rows = np.flatnonzero(verts[p.sim].all(axis=1))
        sim, cut = p.sim[rows].tolist(), p.cut[rows].tolist()
        w = np.asarray(p.sim_weights, dtype=np.float64)[rows].tolist()
        for s, c, ws in zip(sim, cut, w):
            key = tuple(sorted(s))
            t = ws[s.index(key[-1])] if len(s) == 2 else 0.0
            out.setdefault(key, []).append((t, tuple(c)))
    return out


def _edge_on_cut(a: int, b: int, pts: dict, inc: _CutIncidence) -> bool:
    key = (min(a, b), max(a, b))
    chain = [[c for _, c in pts.get((key[0],), [])]]
    chain += [[c] for _, c in sorted(pts.get(key, []))]
    chain.append([c for _, c in pts.get((key[1],), [])])
    return all(any(inc.common(x + y) for x in X for y in Y)
               for X, Y in zip(chain[:-1], chain[1:]))


def _face_covered(face: tuple, pts: dict, inc: _CutIncidence) -> bool:
    if not all(_edge_on_cut(a, b, pts, inc) for a, b in itertools.combinations(face, 2)):
        return False
    if len(face) == 2:
        return True
    if pts.get(face) or any(pts.get(e) for e in itertools.combinations(face, 2)):
        return True
    prims = [[c for _, c in pts.get((v,), [])] for v in face]
    return any(inc.common(x + y + z) for x in prims[0] for y in prims[1] for z in prims[2])


def covered_faces(res, faces: np.ndarray) -> np.ndarray:
    """(k,) bool: for faces (k, d) of simulation vertex ids, all registered on the cut,
    whether the cutting surface covers the face (module docstring). Loops in Python over
    these faces only (they exist only where the cut runs along the mesh's faces)."""
    faces = np.sort(np.asarray(faces, dtype=np.int64), axis=1)
    out = np.zeros(len(faces), dtype=bool)
    if len(faces) == 0:
        return out
    verts = np.zeros(len(res.sim_points), dtype=bool)
    verts[faces.ravel()] = True
    pts = _points_by_primitive(res, verts)
    inc = _CutIncidence(res.cut_cells)
    for i, f in enumerate(faces.tolist()):
        out[i] = _face_covered(tuple(f), pts, inc)
    return out
