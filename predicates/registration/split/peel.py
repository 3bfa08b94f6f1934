"""Filling a fragment that no single apex sees whole (docs/split.md, "The conforming
tetrahedralization"): a thin shell between an edge of the cell and a curved cut bulging
towards it, for instance, has an empty kernel. Such a fragment is peeled: a tetrahedron
spanned by a boundary triangle and a neighbouring boundary point across one of its edges
(an ear at a convex edge) is cut off, the boundary updated (the tetrahedron's faces that
were boundary disappear, the others become boundary, reversed), until the rest is filled
by a cone (:func:`~predicates.registration.split.conform._cone`).

Why the result is valid. Every tetrahedron is kept only if its exact orientation on the
stored coordinates is positive, and every face created is matched by exactly one other
tetrahedron or is an original boundary face (the front bookkeeping). A complex of
positive tetrahedra with paired faces covers each point as many times as the boundary
winds around it: once inside the fragment, never outside — a tetrahedralization, whatever
order the ears were taken in. A peel that would leave an unfillable rest simply ends in a
refusal; an ear containing another boundary point is not taken (float test with a
margin: it only rejects).
"""
from __future__ import annotations

import numpy as np

__all__ = ["peel"]

_OUT = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))


def _ear_candidates(front):
    """Every tetrahedron (c, b, a, x) of a boundary triangle (a, b, c) and another
    boundary point x."""
    verts = sorted({p for t in front for p in t})
    return [(t[2], t[1], t[0], x) for t in front for x in verts if x not in t]


def _canon(face) -> tuple:
    k = face.index(min(face))
    return tuple(face[k:] + face[:k])


def _scores(C: np.ndarray, vol: np.ndarray, front, Z) -> np.ndarray:
    """The order of preference of the candidate tetrahedra C (k, 4): the most boundary
    faces removed, then the best shape (volume / (Σ squared edge lengths)^(3/2)), then
    id order."""
    cur = {_canon(t) for t in front}
    removed = np.array([sum(_canon(tuple(t[k] for k in f)) in cur for f in _OUT)
                        for t in C.tolist()], dtype=np.int64)
    P = Z[C]
    s2 = np.zeros(len(C))
    for i in range(4):
        for j in range(i + 1, 4):
            e = P[:, i] - P[:, j]
            s2 = s2 + (e * e).sum(axis=1)
    q = vol / np.maximum(s2, 1e-300) ** 1.5
    return np.lexsort((np.arange(len(C)), -q, -removed))


def _empty(tets: np.ndarray, Z: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """(k,) bool: no other point of ``verts`` inside or near tet k (float, margin)."""
    P = Z[tets]  # (k, 4, 3)
    V = Z[verts]  # (m, 3)
    ok = np.ones(len(tets), dtype=bool)
    scale = float(np.abs(P).max()) if P.size else 1.0
    for f in _OUT:
        a, b, c = P[:, f[0]], P[:, f[1]], P[:, f[2]]
        n = np.cross(b - a, c - a)
        s = ((V[None] - a[:, None]) * n[:, None]).sum(axis=2)  # > 0 outside that face
        tol = 1e-9 * scale * np.sqrt((n * n).sum(axis=1))[:, None]
        inside_face = s < tol
        if f == _OUT[0]:
            acc = inside_face
        else:
            acc &= inside_face
    own = (verts[None, :] == tets[:, :, None]).any(axis=1)
    ok &= ~(acc & ~own).any(axis=1)
    return ok


def _remove(front: list, tet) -> list:
    """The boundary of (region − tet): the tet's outward faces that were boundary go,
    the others come in reversed."""
    cur = {tuple(t): i for i, t in enumerate(front)}
    gone, new = set(), []
    for f in _OUT:
        face = tuple(tet[k] for k in f)
        hit = next((cur[r] for r in (face, face[1:] + face[:1], face[2:] + face[:2])
                    if r in cur), None)
        if hit is not None:
            gone.add(hit)
        else:
            new.append(face[::-1])
    return [t for i, t in enumerate(front) if i not in gone] + new


def peel(tris, Y: list, try_cone, limit: int = 200):
    """Tetrahedra filling the closed outward boundary ``tris`` (ids into ``Y``), or None.
    ``try_cone(front)``: the cone filling of a boundary, or None."""
    from predicates.registration.split.tetra_faces import positive

    front, tets = [tuple(t) for t in tris], []
    for _ in range(limit):
        cone = try_cone(front)
        if cone is not None:
            return tets + cone
        cand = _ear_candidates(front)
        if not cand:
            return None
        Z = Y.array
        C = np.array(cand, dtype=np.int64)
        verts = np.array(sorted({p for t in front for p in t}), dtype=np.int64)
        E = Z[C[:, 1:]] - Z[C[:, :1]]
        vol = (E[:, 0] * np.cross(E[:, 1], E[:, 2])).sum(axis=1)
        keep = np.flatnonzero(vol > 0)
        keep = keep[_empty(C[keep], Z, verts)]
        # the preferred ears (:func:`_scores`), the first whose exact orientation is
        # positive
        order = keep[_scores(C[keep], vol[keep], front, Z)]
        tet = next((tuple(int(v) for v in C[k]) for k in order[:8].tolist()
                    if positive(C[k:k + 1], Z)[0] > 0), None)
        if tet is None:
            return None
        tets.append(tet)
        front = _remove(front, tet)
        if not front:
            return tets
    return None
