"""The classic geometric predicates as filtered predicates: a worked example.

orient2d, orient3d, incircle and insphere, each written once as a ``@predicate``
(:mod:`predicates.core`) in the evaluation order of Shewchuk's ``predicates.c`` (and
CGAL's static filters): coordinate differences first, then the usual determinant
expansion. Each *hits* when its determinant is positive, with Shewchuk's conventions:

* ``orient2d(A, B, C)``: C left of the directed line AB (ABC counter-clockwise);
* ``orient3d(A, B, C, D)``: D below the plane of A, B, C (ABC counter-clockwise seen
  from above);
* ``incircle(A, B, C, D)``: D inside the circle through the counter-clockwise A, B, C;
* ``insphere(A, B, C, D, E)``: E inside the sphere through A, B, C, D with
  ``orient3d(A, B, C, D)`` positive.

``FILTERED[name]`` is the filtered batch version (:mod:`predicates.filtered`): the exact
answer on every lane, decided natively where the derived bound allows. :func:`sign`
gives the exact sign (−1, 0, +1): exchanging A and B negates each determinant exactly,
so sign = [det(A, B, …) > 0] − [det(B, A, …) > 0], both answers exact.
"""
from __future__ import annotations

import numpy as np

from .core import predicate
from .filtered import FilteredPredicate, filtered


def _sign_test(ctx, det):
    if ctx.reject(det <= 0, line=1):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=2, points="ABC", section="classic")
def orient2d(ctx, A, B, C, tol):
    """Hit when ABC turns counter-clockwise: det = (A − C) × (B − C) > 0."""
    acx, bcx = A[0] - C[0], B[0] - C[0]
    acy, bcy = A[1] - C[1], B[1] - C[1]
    return _sign_test(ctx, ctx.name("det", acx * bcy - acy * bcx))


@predicate(dim=3, points="ABCD", section="classic")
def orient3d(ctx, A, B, C, D, tol):
    """Hit when D lies below the plane of A, B, C (Shewchuk's orient3d > 0)."""
    adx, bdx, cdx = A[0] - D[0], B[0] - D[0], C[0] - D[0]
    ady, bdy, cdy = A[1] - D[1], B[1] - D[1], C[1] - D[1]
    adz, bdz, cdz = A[2] - D[2], B[2] - D[2], C[2] - D[2]
    det = (adx * (bdy * cdz - bdz * cdy) + bdx * (cdy * adz - cdz * ady)
           + cdx * (ady * bdz - adz * bdy))
    return _sign_test(ctx, ctx.name("det", det))


@predicate(dim=2, points="ABCD", section="classic")
def incircle(ctx, A, B, C, D, tol):
    """Hit when D is inside the circle through the counter-clockwise A, B, C."""
    adx, bdx, cdx = A[0] - D[0], B[0] - D[0], C[0] - D[0]
    ady, bdy, cdy = A[1] - D[1], B[1] - D[1], C[1] - D[1]
    alift = adx * adx + ady * ady
    blift = bdx * bdx + bdy * bdy
    clift = cdx * cdx + cdy * cdy
    det = (alift * (bdx * cdy - cdx * bdy) + blift * (cdx * ady - adx * cdy)
           + clift * (adx * bdy - bdx * ady))
    return _sign_test(ctx, ctx.name("det", det))


@predicate(dim=3, points="ABCDE", section="classic")
def insphere(ctx, A, B, C, D, E, tol):
    """Hit when E is inside the sphere through A, B, C, D (orient3d(A, B, C, D) > 0)."""
    aex, bex, cex, dex = A[0] - E[0], B[0] - E[0], C[0] - E[0], D[0] - E[0]
    aey, bey, cey, dey = A[1] - E[1], B[1] - E[1], C[1] - E[1], D[1] - E[1]
    aez, bez, cez, dez = A[2] - E[2], B[2] - E[2], C[2] - E[2], D[2] - E[2]
    ab = aex * bey - bex * aey
    bc = bex * cey - cex * bey
    cd = cex * dey - dex * cey
    da = dex * aey - aex * dey
    ac = aex * cey - cex * aey
    bd = bex * dey - dex * bey
    abc = aez * bc - bez * ac + cez * ab
    bcd = bez * cd - cez * bd + dez * bc
    cda = cez * da + dez * ac + aez * cd
    dab = dez * ab + aez * bd + bez * da
    alift = aex * aex + aey * aey + aez * aez
    blift = bex * bex + bey * bey + bez * bez
    clift = cex * cex + cey * cey + cez * cez
    dlift = dex * dex + dey * dey + dez * dez
    det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd)
    return _sign_test(ctx, ctx.name("det", det))


#: The raw predicates by name (each also runs natively, instrumented, in mpmath).
PREDICATES = {p.name: p for p in (orient2d, orient3d, incircle, insphere)}

#: The filtered batch predicates (semi-static: each lane's own scale).
FILTERED: dict[str, FilteredPredicate] = {name: filtered(p) for name, p in PREDICATES.items()}


def sign(f: FilteredPredicate, *points) -> np.ndarray:
    """The exact sign (−1, 0, +1) of a classic determinant, per lane: the filtered
    answers for (A, B, …) and (B, A, …) (exchanging A and B negates it exactly)."""
    if f.pred not in PREDICATES.values():
        raise ValueError(f"sign() needs one of {', '.join(PREDICATES)} (exchanging A and B "
                         f"must negate the determinant exactly), got {f.name}")
    pos = f(*points).hit
    neg = f(points[1], points[0], *points[2:]).hit
    return pos.astype(np.int8) - neg.astype(np.int8)
