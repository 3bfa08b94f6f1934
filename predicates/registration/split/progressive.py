"""Progressive cuts (docs/split.md, "Progressive cuts"): a conforming mesh of the split
cut again. The earlier result's simplices become the simulation mesh of a new
registration (paper, section 1) against the next cutting mesh; its conforming simplices
(:mod:`~predicates.registration.split.conform`) keep the earlier cut as faces: a face of
the new simplices whose points all lie, by their registered primitives, in one earlier
cut face is an earlier cut face too. Pieces are then the simplices joined through faces
of neither cut. Nothing is snapped or re-decided: the earlier points are vertices of the
new simulation mesh (ids kept: the original vertices stay 0..n−1), so a virtual corner
(material on the other side of an earlier cut) can never become material again.
"""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["recut"]


def _prims(cm2, cs2, n_prev: int) -> list:
    """The earlier mesh's vertex ids under every point of the new mesh (its registered
    simulation primitive; an earlier point is its own)."""
    out = []
    for p, (k, h) in enumerate(zip(cm2.point_kind.tolist(), cm2.point_hit.tolist())):
        if k == 0:
            out.append(frozenset((p,)))
        elif k == 1:
            out.append(frozenset(i for i in cs2.sim[h].tolist() if i >= 0))
        else:
            out.append(frozenset((-1 - p,)))  # an interior point: in no earlier face
    return out


def _earlier_faces(cm2, cs2, prev) -> tuple:
    """The faces of the new simplices inside an earlier cut face, oriented like it, and
    the earlier cut face each lies in."""
    from predicates.registration.split.conform_parts import _oriented_faces

    d = cm2.dim
    old = {tuple(sorted(f)): i for i, f in enumerate(prev.cut_faces.tolist())}
    prim = _prims(cm2, cs2, len(prev.points))
    F = _oriented_faces(cm2.cells).reshape(-1, d)
    seen, faces, where = set(), [], []
    for f in F.tolist():
        key = tuple(sorted(f))
        if key in seen:
            continue
        u = frozenset().union(*(prim[p] for p in f))
        j = old.get(tuple(sorted(u))) if len(u) == d else None
        if j is None:
            continue
        seen.add(key)
        faces.append(_like(f, prev.cut_faces[j], cm2.points, prev.points))
        where.append(j)
    return faces, where


def _like(f, g, X, Xp):
    """Face f oriented like the coplanar earlier face g (float normals: ±|n||m|)."""
    A, B = X[list(f)], Xp[list(g)]
    if len(f) == 2:
        s = ((A[1] - A[0]) * (B[1] - B[0])).sum()
    else:
        s = (np.cross(A[1] - A[0], A[2] - A[0]) * np.cross(B[1] - B[0], B[2] - B[0])).sum()
    return list(f) if s > 0 else list(f)[::-1]


def recut(prev, cut_points, cut_cells, **options):
    """The conforming mesh ``prev`` (a :class:`~.conform.ConformingMesh`) cut again by
    (``cut_points``, ``cut_cells``): a ConformingMesh whose ``cell_origin`` /
    ``fragment`` / ``split_piece`` are the earliest ones (the original cells), with
    ``previous_cell`` (T,) the simplex of ``prev`` each comes from and ``previous_piece``
    its piece there; ``cut_round`` (K,) 0 for the earlier cut faces (``cut_cell`` then
    indexes ``prev``'s cut faces' cutting cells), 1 for the new ones. ``options``: as
    :func:`predicates.intersect`."""
    from predicates import intersect
    from predicates.registration.split.conform_parts import _cut_records, _pieces, face_table

    res = intersect(prev.points, prev.cells, cut_points, cut_cells, **options)
    sm = res.split()
    cm2 = sm.tetrahedralize()
    cs2 = cm2.surface  # the surface its points index (re-decided clusters included)
    old, where = _earlier_faces(cm2, cs2, prev)
    new = [list(f) for f in cm2.cut_faces.tolist()]
    allf = old + new
    keys = [tuple(sorted(f)) for f in allf]
    recs = [(None, None, tuple(f), 0) for f in allf]
    _, _, sides = _cut_records(recs, face_table(cm2.cells, keys), cm2.cells)
    piece, n_pieces = _pieces(cm2.cells, keys)
    w = np.array(where, dtype=np.int64)
    origin = cm2.cell_origin
    out = dataclasses.replace(
        cm2, cell_origin=prev.cell_origin[origin], fragment=prev.fragment[origin],
        split_piece=prev.split_piece[origin], piece=piece, n_pieces=n_pieces,
        cut_faces=np.array(allf, dtype=np.int64).reshape(-1, cm2.dim),
        cut_cell=np.concatenate([prev.cut_cell[w], cm2.cut_cell]).astype(np.int64),
        input_cut_cell=np.concatenate([prev.input_cut_cell[w],
                                       cm2.input_cut_cell]).astype(np.int64),
        cut_sides=np.array(sides, dtype=np.int64).reshape(-1, 2))
    out.previous_cell = origin
    out.previous_piece = prev.piece[origin]
    out.cut_round = np.concatenate([np.zeros(len(old), np.int64), np.ones(len(new), np.int64)])
    return out
