"""Assembling the conforming simplices (docs/split.md, "The conforming
tetrahedralization"; :mod:`~predicates.registration.split.conform`): the cells the cut
does not touch kept whole, the filled fragments, point ids compacted, and the cut faces
with the cutting cell they lie on and the simplex on each side of them."""
from __future__ import annotations

import numpy as np

from predicates.registration.levels.complex import row_ids
from predicates.registration.split.tetra_faces import OUTWARD, positive

__all__ = ["assemble", "face_table"]


def _oriented_faces(S: np.ndarray) -> np.ndarray:
    """(T, d+1, d): the outward faces of positive simplices S (T, d+1)."""
    if S.shape[1] == 3:
        return S[:, [[0, 1], [1, 2], [2, 0]]]
    return S[:, np.array(OUTWARD)]


def face_table(S: np.ndarray, wanted) -> dict:
    """{sorted face: [(simplex, its outward face as a tuple)]} of positive simplices S,
    for the sorted faces in ``wanted`` only."""
    F = _oriented_faces(S).reshape(-1, S.shape[1] - 1)
    key = np.sort(F, axis=1)
    want = np.array(sorted(set(wanted)), dtype=np.int64).reshape(-1, S.shape[1] - 1)
    table: dict = {tuple(r): [] for r in want.tolist()}
    if len(want) == 0:
        return table
    allk = np.concatenate([want, key])
    inv = row_ids(allk)
    hit = np.flatnonzero(np.isin(inv[len(want):], inv[:len(want)]))
    for r in hit.tolist():
        table[tuple(key[r].tolist())].append((r // S.shape[1], tuple(F[r].tolist())))
    return table


def _same_cycle(a, b) -> bool:
    """Same oriented simplex (a segment: same order; a triangle: a rotation)."""
    k = len(a)
    if k == 2:
        return tuple(a) == tuple(b)
    return any(tuple(a[i:] + a[:i]) == tuple(b) for i in range(k))


def _on_face_cuts(res, cs, ctx, faces) -> list:
    """(None, None, simplex oriented like the cutting cell, q) for the polygons lying in a
    face of their cell: the face's triangles among the polygon's points."""
    from predicates.registration.split.tetra_faces import gid

    T, n, X, d, cells = ctx["T"], ctx["n"], ctx["X"], ctx["d"], ctx["cells"]
    Q = np.asarray(res.cut_points, dtype=np.float64)
    K = np.asarray(res.cut_cells, dtype=np.int64)
    out = []
    for q in np.flatnonzero(cs.on_face).tolist():
        c = int(cs.cell[q])
        ids = {gid(("h", T.canon[h]), T, n) for h in cs.polygon(q).tolist()}
        prims = frozenset().union(*(T.prim[h] for h in cs.polygon(q).tolist()))
        if len(prims) != d:
            continue
        face = tuple(sorted(prims))
        tris = faces.get((c, face))
        if tris is None:
            k = [j for j in range(d + 1) if cells[c][j] not in prims][0]
            sign = positive(cells[c][None], X)[0]
            row = [int(v) for j, v in enumerate(cells[c]) if j != k]
            odd = (k % 2 == 1) if d == 3 else (k == 1)
            tris = [tuple(row) if (sign > 0) != odd else tuple(row[::-1])]
        for t in tris:
            if set(t) <= ids:
                out.append((None, None, _like_cut(t, X, cs, Q, K[cs.cut_cell[q]], n, d), q))
    return out


def _like_cut(t, X, cs, Q, tri, n, d):
    """The simplex t oriented like the cutting cell ``tri`` (float normals of two
    coplanar simplices: their dot product is ±|n₁||n₂|, far from 0)."""
    P = np.array([X[v] if v < n else cs.points[v - n] for v in t])
    if d == 2:
        a, b = P[1] - P[0], Q[tri[1]] - Q[tri[0]]
        return t if a[0] * b[0] + a[1] * b[1] > 0 else t[::-1]
    na = np.cross(P[1] - P[0], P[2] - P[0])
    nb = np.cross(Q[tri[1]] - Q[tri[0]], Q[tri[2]] - Q[tri[0]])
    return t if (na * nb).sum() > 0 else t[::-1]


def _kept(ctx, sm):
    """Simplices of the cells the cut does not touch (positively oriented)."""
    cells, X = ctx["cells"], ctx["X"]
    keep = np.flatnonzero(~ctx["touched"])
    S = cells[keep].copy()
    neg = positive(S, X) < 0
    S[neg, 0], S[neg, 1] = cells[keep][neg, 1], cells[keep][neg, 0]
    return S, keep, ctx["start"][keep]


def _cut_records(cuts, table, S):
    """cut faces, q, (behind, in front) simplices for every cut simplex."""
    faces, qs, sides = [], [], []
    for _, _, t, q in cuts:
        hits = table.get(tuple(sorted(t)), [])
        behind = [s for s, f in hits if _same_cycle(list(f), list(t))]
        front = [s for s, f in hits if not _same_cycle(list(f), list(t))]
        faces.append(t)
        qs.append(q)
        sides.append((behind[0] if len(behind) == 1 else -1,
                      front[0] if len(front) == 1 else -1))
    return faces, qs, sides


def _pieces(S: np.ndarray, cut_keys) -> tuple:
    """Pieces: the simplices connected through faces that are not cut faces, numbered
    by their first simplex. Returns (piece per simplex, count)."""
    from predicates.registration.split.rules import components

    d = S.shape[1] - 1
    F = np.sort(_oriented_faces(S).reshape(-1, d), axis=1)
    cut = np.array(sorted(set(cut_keys)), dtype=np.int64).reshape(-1, d)
    inv = row_ids(np.concatenate([cut, F]))
    fid = inv[len(cut):]
    o = np.argsort(fid, kind="stable")
    same = np.flatnonzero(fid[o][1:] == fid[o][:-1])
    a, b = o[same] // (d + 1), o[same + 1] // (d + 1)
    keep = ~np.isin(fid[o][same], inv[:len(cut)])
    lab = components(len(S), a[keep], b[keep])
    _, piece = np.unique(lab, return_inverse=True)
    return piece.ravel(), int(piece.max(initial=-1)) + 1


def assemble(res, sm, cs, ctx, filled: dict, Y: np.ndarray, cuts: list, faces: dict,
             where: list):
    """The fields of the :class:`~predicates.registration.split.conform.ConformingMesh`:
    ``filled`` {region: simplices}, ``where`` [(cell, fragment or −1)] per region."""
    d, n = ctx["d"], ctx["n"]
    S0, keep, f0 = _kept(ctx, sm)
    regs = sorted(filled)
    S1 = np.array([s for r in regs for s in filled[r]], dtype=np.int64).reshape(-1, d + 1)
    r1 = np.repeat(np.array(regs, dtype=np.int64), [len(filled[r]) for r in regs])
    W = np.array(where, dtype=np.int64).reshape(-1, 2)
    S = np.concatenate([S0, S1])
    origin = np.concatenate([keep, W[r1, 0]]).astype(np.int64)
    frag = np.concatenate([f0, W[r1, 1]]).astype(np.int64)
    region = np.concatenate([len(W) + np.arange(len(keep)), r1])
    cuts += _on_face_cuts(res, cs, ctx, faces)
    keys = [tuple(sorted(c[2])) for c in cuts]
    cf, qs, cut_sides = _cut_records(cuts, face_table(S, keys), S)
    piece, n_pieces = _pieces(S, keys)
    side = np.zeros(len(W) + len(keep), dtype=np.int64)
    for b, f in cut_sides:
        for t, sgn in ((b, -1), (f, 1)):
            if t >= 0:
                g = region[t]
                side[g] = sgn if side[g] in (0, sgn) else 2
    used = np.unique(np.concatenate([S.ravel(), np.array(cf, dtype=np.int64).ravel()]))
    new = np.full(len(Y), -1, dtype=np.int64)
    new[used] = np.arange(len(used))
    nh = len(cs.points)
    kind = np.where(used < n, 0, np.where(used < n + nh, 1, 2)).astype(np.int8)
    qs = np.array(qs, dtype=np.int64)
    return dict(
        dim=d, points=Y[used], point_kind=kind, point_hit=np.where(kind == 1, used - n, -1),
        cells=new[S], cell_origin=origin, fragment=frag, piece=piece, side=side[region],
        n_pieces=n_pieces, cut_faces=new[np.array(cf, dtype=np.int64).reshape(-1, d)],
        cut_cell=cs.cut_cell[qs] if len(qs) else np.zeros(0, np.int64),
        input_cut_cell=cs.input_cut_cell[qs] if len(qs) else np.zeros(0, np.int64),
        cut_sides=np.array(cut_sides, dtype=np.int64).reshape(-1, 2),
        split_piece=np.where(frag >= 0, sm.piece[np.maximum(frag, 0)], -1))


def open_nodes(S: np.ndarray, cut_faces: np.ndarray) -> np.ndarray:
    """(T, d+1) node ids of the simplices S with the cut opened: the (simplex, corner)
    slots of one point joined across every shared face that is not a cut face (the
    virtual node algorithm's node rule, Molino et al., on the conforming simplices).
    Around the front of a crack ending inside the mesh the simplices stay joined (one
    node), elsewhere along the crack each side gets its own. Nodes numbered by their
    first slot."""
    from predicates.registration.split.rules import components

    T, k = S.shape
    d = k - 1
    pos = np.array(OUTWARD if d == 3 else ((0, 1), (1, 2), (2, 0)), dtype=np.int64)
    F = S[:, pos].reshape(-1, d)
    slot = (np.arange(T)[:, None, None] * k + pos[None]).reshape(-1, d)
    o = np.argsort(F, axis=1)
    F = np.take_along_axis(F, o, axis=1)
    slot = np.take_along_axis(slot, o, axis=1)
    cut = np.sort(np.asarray(cut_faces, dtype=np.int64).reshape(-1, d), axis=1)
    inv = row_ids(np.concatenate([cut, F]))
    fid = inv[len(cut):]
    r = np.argsort(fid, kind="stable")
    same = np.flatnonzero(fid[r][1:] == fid[r][:-1])
    same = same[~np.isin(fid[r][same], inv[:len(cut)])]
    a, b = slot[r[same]], slot[r[same + 1]]
    lab = components(T * k, a.ravel(), b.ravel())
    _, node = np.unique(lab, return_inverse=True)
    return node.reshape(T, k)
