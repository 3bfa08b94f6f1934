"""Filling a region by a backtracking search over ear tetrahedra (docs/split.md, "The
conforming tetrahedralization"), after the cones and the greedy peeling
(:mod:`~predicates.registration.split.peel`) have failed.

The search keeps the boundary still to fill as a multiset of oriented triangles (a
chain). A step takes the triangle with the fewest candidate apexes (boundary points on
its inner side, exact sign), and tries them in order of boundary faces removed; a dead
end (a triangle no point sees from inside) backtracks. Why any result is valid: a set of
tetrahedra of positive exact orientation whose chain boundary is the region's boundary S
covers every point as often as S winds around it, once inside and never outside (the
argument of :mod:`~.peel`); the search only proposes, and the caller checks every
tetrahedron again with ``predicates.classic``'s filtered orient3d
(:func:`~predicates.registration.split.tetra_faces.positive`).

Signs here come from a float determinant with a static error bound far above its rounding
error (Shewchuk's orient3d bound is 7.8e-16 × the permanent; 1e-14 is used), and from
exact integer arithmetic below it (the coordinates scaled by one power of two): exact,
and cheap on the few dozen points of a region.

:func:`folded_triangle` names why a region cannot be filled at all: a boundary triangle
with no point of the region strictly on its inner side and the boundary winding 0 on both
its sides is a zero-thickness flap of S (registered points the registration merged within
its tolerances σ, τ, δ, placed on the cut, tilt a face region into a cut polygon's plane),
and no set of positive tetrahedra has such a boundary, whatever points are added inside.
"""
from __future__ import annotations

from collections import Counter

import numpy as np

__all__ = ["fan_from_boundary", "folded_triangle", "orient_signs", "paired", "refusal_reason",
           "search_fill"]

_OUT = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
#: far above the rounding error of the float determinant below (Shewchuk: 7.8e-16)
_BOUND = 1e-14


def orient_signs(P: np.ndarray) -> np.ndarray:
    """(k,) exact signs of ((B − A) × (C − A))·(D − A) for tetrahedra P (k, 4, 3): float
    with a static filter, exact integers where the filter cannot decide."""
    v, perm = _filtered(P)
    out = np.sign(v).astype(np.int64)
    for k in np.flatnonzero(np.abs(v) <= _BOUND * perm).tolist():
        out[k] = _exact_sign(P[k])
    return out


def _all_positive(P: np.ndarray) -> bool:
    """Every exact sign of :func:`orient_signs` positive; the exact signs
    are computed only when the filter finds no certainly negative or flat one (a boundary
    point in the plane of many boundary triangles: most of a fan's candidates)."""
    v, perm = _filtered(P)
    sure = np.abs(v) > _BOUND * perm
    if np.any(sure & (v < 0)):
        return False
    return all(_exact_sign(P[k]) > 0 for k in np.flatnonzero(~sure).tolist())


def _exact_sign(T: np.ndarray) -> int:
    """The exact orientation sign of one tetrahedron (4, 3): its coordinates as integers
    scaled by one power of two (:func:`~.polytri.dyadic_integers`), which keeps the
    sign."""
    from predicates.registration.split.polytri import dyadic_integers

    z = dyadic_integers(np.asarray(T, dtype=np.float64).ravel().tolist())
    Q = [z[0:3], z[3:6], z[6:9], z[9:12]]
    e = [[a - b for a, b in zip(p, Q[0])] for p in Q[1:]]
    det = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
           - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
           + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
    return (det > 0) - (det < 0)


def _filtered(P: np.ndarray):
    """(float determinants, their permanents) of tetrahedra P (k, 4, 3)."""
    E = P[:, 1:] - P[:, :1]
    m0 = E[:, 1, 1] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 1]
    m1 = E[:, 1, 0] * E[:, 2, 2] - E[:, 1, 2] * E[:, 2, 0]
    m2 = E[:, 1, 0] * E[:, 2, 1] - E[:, 1, 1] * E[:, 2, 0]
    v = E[:, 0, 0] * m0 - E[:, 0, 1] * m1 + E[:, 0, 2] * m2
    A = np.abs(E)
    perm = (A[:, 0, 0] * (A[:, 1, 1] * A[:, 2, 2] + A[:, 1, 2] * A[:, 2, 1])
            + A[:, 0, 1] * (A[:, 1, 0] * A[:, 2, 2] + A[:, 1, 2] * A[:, 2, 0])
            + A[:, 0, 2] * (A[:, 1, 0] * A[:, 2, 1] + A[:, 1, 1] * A[:, 2, 0]))
    return v, perm


def _canon(face) -> tuple:
    k = face.index(min(face))
    return tuple(face[k:]) + tuple(face[:k])


def paired(tets, tris) -> bool:
    """Every triangle of ``tris`` (outward) is the outward face of exactly one of the
    tetrahedra and every other face of them is shared by two with opposite
    orientations: the tetrahedra's boundary is ``tris`` as triangles, not only as a chain
    (where the two sides of a slit would cancel)."""
    count = Counter(_canon(tuple(t[k] for k in o)) for t in tets for o in _OUT)
    for t in tris:
        key = _canon(tuple(t))
        if count[key] < 1:
            return False
        count[key] -= 1
    count = +count
    return all(count[_canon(f[::-1])] == c for f, c in count.items())


def _apply(front: Counter, tet) -> tuple:
    """(boundary of the rest after removing ``tet``, number of its faces that were
    boundary): a face of the tet on the boundary goes, any other comes in reversed."""
    rest, removed = Counter(front), 0
    for o in _OUT:
        f = _canon(tuple(tet[k] for k in o))
        if rest[f] > 0:
            rest[f] -= 1
            removed += 1
        else:
            rest[_canon(f[::-1])] += 1
    return +rest, removed


def _candidates(front: Counter, Z: np.ndarray, known: dict):
    """The boundary triangle with the fewest apexes on its inner side, and those ear
    tetrahedra (triangle reversed, apex); ``known`` caches the signs of the search."""
    tris = list(front)
    verts = sorted({p for t in tris for p in t})
    C = [(t[2], t[1], t[0], x) for t in tris for x in verts]
    new = [c for c in C if c not in known]
    if new:
        s = orient_signs(Z[np.array(new, dtype=np.int64)])
        known.update(zip(new, s.tolist()))
    best = None
    for i in range(len(tris)):
        row = [c for c in C[i * len(verts):(i + 1) * len(verts)] if known[c] > 0]
        if best is None or len(row) < len(best):
            best = row
        if not best:
            break
    return best


def search_fill(tris, Z: np.ndarray, budget: int = 200, width: int = 4):
    """Tetrahedra (ids into Z) filling the closed outward boundary ``tris`` by the
    backtracking search (module docstring), or None after ``budget`` steps; at most
    ``width`` apexes are tried per step."""
    steps, known = [budget], {}

    def rec(front):
        if not front:
            return []
        if steps[0] <= 0:
            return None
        steps[0] -= 1
        ranked = sorted(((-_apply(front, t)[1], t) for t in _candidates(front, Z, known)))
        for _, tet in ranked[:width]:
            rest = rec(_apply(front, tet)[0])
            if rest is not None:
                return [tet] + rest
        return None

    return rec(Counter(_canon(tuple(t)) for t in tris))


def fan_from_boundary(tris, Z: np.ndarray):
    """The cone from the first boundary point (increasing id) from which every boundary
    triangle not through it gives a positive tetrahedron, or None. The triangles through
    the apex give no tetrahedron (zero measure); the others' signed cones add up to the
    region, so all positive is a tetrahedralization of it."""
    pts = sorted({p for t in tris for p in t})
    for p in pts:
        cone = [tuple(t[::-1]) + (p,) for t in tris if p not in t]
        if cone and _all_positive(Z[np.array(cone, dtype=np.int64)]):
            return cone
    return None


def _winding(tris, Z: np.ndarray, x: np.ndarray) -> float:
    """The generalised winding number of the closed triangle surface around x (float:
    a diagnosis only, rounded to an integer by the caller)."""
    P = Z[np.array(tris, dtype=np.int64)] - x
    a, b, c = P[:, 0], P[:, 1], P[:, 2]
    la, lb, lc = (np.sqrt((v * v).sum(axis=1)) for v in (a, b, c))
    num = (a * np.cross(b, c)).sum(axis=1)
    den = (la * lb * lc + (a * b).sum(axis=1) * lc + (b * c).sum(axis=1) * la
           + (c * a).sum(axis=1) * lb)
    return float((2 * np.arctan2(num, den)).sum() / (4 * np.pi))


def folded_triangle(tris, Z: np.ndarray):
    """A boundary triangle that is a zero-thickness flap (module docstring), or None."""
    pts = sorted({p for t in tris for p in t})
    C = np.array([(t[2], t[1], t[0], x) for t in tris for x in pts], dtype=np.int64)
    s = orient_signs(Z[C]).reshape(len(tris), len(pts))
    for i in np.flatnonzero((s > 0).sum(axis=1) == 0).tolist():
        P = Z[list(tris[i])]
        n = np.cross(P[1] - P[0], P[2] - P[0])
        ln = float(np.sqrt((n * n).sum()))
        if ln == 0:
            return tuple(tris[i])
        h = 1e-3 * np.sqrt(ln)
        w = [round(_winding(tris, Z, P.mean(axis=0) + sgn * h * n / ln)) for sgn in (-1, 1)]
        if w == [0, 0]:
            return tuple(tris[i])
    return None


def refusal_reason(tris, Z: np.ndarray, cell_tris=None) -> str:
    """Why a region was refused, for the report: a 3D boundary folding onto itself
    (:func:`folded_triangle`), in 2D two boundary segments of its cell's regions
    (``cell_tris``, default its own) crossing (:func:`~.slit_fill.crossing_segments`:
    the cutting curve crosses itself in the cell), else no filler."""
    if len(tris[0]) == 3 and folded_triangle(tris, Z) is not None:
        return ("its boundary folds onto itself (a zero-thickness flap: registered points "
                "merged within the tolerances, placed on the cut), which no positive "
                "tetrahedra can fill")
    if len(tris[0]) == 2:
        from predicates.registration.split.slit_fill import crossing_segments

        if crossing_segments(tris if cell_tris is None else cell_tris, Z) is not None:
            return ("its boundary meets itself: the cutting curve crosses or touches itself "
                    "(or another of its curves) inside the cell, at a point no registered "
                    "pair gives; cut with one curve, then cut the conforming mesh again "
                    "with the other (fperr cut --then, split.progressive.recut)")
    return "no apex, peeling or search fills it with positive simplices"
