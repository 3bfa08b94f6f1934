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


def _prim_rows(cm2, cs2) -> np.ndarray:
    """(P, w) per point of the new mesh: the earlier mesh's vertex ids under it (its
    registered simulation primitive; an earlier point is its own), padded with −1; −2
    throughout for an interior point (in no earlier face)."""
    kind, hit = cm2.point_kind, cm2.point_hit
    sim = np.asarray(cs2.sim, dtype=np.int64)
    if sim.ndim != 2:  # (no registered point: an empty list)
        sim = sim.reshape(-1, cm2.dim + 1)
    U = np.full((len(kind), sim.shape[1]), -1, dtype=np.int64)
    at = np.flatnonzero(kind == 0)
    U[at, 0] = at
    at = np.flatnonzero(kind == 1)
    U[at] = np.maximum(sim[hit[at]], -1)
    U[kind == 2] = -2
    return U


def _earlier_faces(cm2, cs2, prev) -> tuple:
    """The faces of the new simplices inside an earlier cut face, oriented like it, and
    the earlier cut face each lies in: a face whose points' earlier ids together are
    exactly the d ids of an earlier cut face (the last one listed with them), each
    face once, in the order of the new simplices' faces."""
    from predicates.registration.levels.complex import row_ids
    from predicates.registration.split.conform_parts import _oriented_faces

    d = cm2.dim
    F = _oriented_faces(cm2.cells).reshape(-1, d)
    G = np.sort(np.asarray(prev.cut_faces, dtype=np.int64).reshape(-1, d), axis=1)
    if len(F) == 0 or len(G) == 0:
        return [], []
    V = np.sort(_prim_rows(cm2, cs2)[F].reshape(len(F), -1), axis=1)
    new = V >= 0  # the distinct earlier ids of each face's points, ascending
    new[:, 1:] &= V[:, 1:] != V[:, :-1]
    cand = np.flatnonzero((new.sum(axis=1) == d) & (V[:, 0] != -2))
    Q = V[cand][new[cand]].reshape(-1, d)
    inv = row_ids(np.concatenate([G, Q]))
    last = np.full(int(inv.max()) + 1, -1, dtype=np.int64)
    np.maximum.at(last, inv[:len(G)], np.arange(len(G)))
    j = last[inv[len(G):]]
    cand, j = cand[j >= 0], j[j >= 0]
    _, first = np.unique(row_ids(np.sort(F[cand], axis=1)), return_index=True)
    first.sort()
    faces = [_like(f, prev.cut_faces[g], cm2.points, prev.points)
             for f, g in zip(F[cand[first]].tolist(), j[first].tolist())]
    return faces, j[first].tolist()


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
