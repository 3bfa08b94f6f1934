"""The four classic sign predicates, in Shewchuk's evaluation order: user code, not part
of fperr.

``orient2d``, ``orient3d``, ``incircle`` and ``insphere`` as written in Shewchuk's
``predicates.c`` (``orient2dfast``, ``orient3dfast``, ``incirclefast``,
``inspherefast``; CGAL's static filters use the same order), each a sign test of one
determinant: it hits when the determinant is positive. No tolerance: the declarations
say their decisions are "sign exact or undecided" (``sign_filter=True``): the sign of
the computed determinant is the exact one whenever |det| > θ, θ derived from the *sign
bound* E_sign[det] — E without the last rounding (docs/proofs.md, "Sign tests"):

=========  =========================  ==========
predicate  E[det] (first order)       E_sign[det]
=========  =========================  ==========
orient2d   8 ε·L²                     6 ε·L²
orient3d   46 ε·L³                    40 ε·L³
incircle   128 ε·L⁴                   116 ε·L⁴
insphere   1128 ε·L⁵                  1056 ε·L⁵
=========  =========================  ==========

(L: every coordinate within [−L/2, L/2], rule K.) Verified with
``PYTHONPATH=docs/examples fperr verify --predicates sign_predicates``.
"""
from predicates.core import predicate
from proofs.user_predicates import PredicateTolerances


@predicate(dim=2, points="ABC")
def orient2d(ctx, A, B, C, tol):
    """Hit when C is left of the directed line AB: (A−C)×(B−C) > 0 (orient2dfast)."""
    acx, bcx = A[0] - C[0], B[0] - C[0]
    acy, bcy = A[1] - C[1], B[1] - C[1]
    det = ctx.name("det", acx * bcy - acy * bcx)
    if ctx.reject(det <= 0, line=1):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=3, points="ABCD")
def orient3d(ctx, A, B, C, D, tol):
    """Hit when D is below the plane of ABC, counter-clockwise seen from above
    (Shewchuk's sign: det > 0; orient3dfast)."""
    adx, bdx, cdx = A[0] - D[0], B[0] - D[0], C[0] - D[0]
    ady, bdy, cdy = A[1] - D[1], B[1] - D[1], C[1] - D[1]
    adz, bdz, cdz = A[2] - D[2], B[2] - D[2], C[2] - D[2]
    det = ctx.name("det", adx * (bdy * cdz - bdz * cdy)
                   + bdx * (cdy * adz - cdz * ady)
                   + cdx * (ady * bdz - adz * bdy))
    if ctx.reject(det <= 0, line=1):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=2, points="ABCD")
def incircle(ctx, A, B, C, D, tol):
    """Hit when D is inside the circle through the counter-clockwise A, B, C
    (incirclefast)."""
    adx, ady = A[0] - D[0], A[1] - D[1]
    bdx, bdy = B[0] - D[0], B[1] - D[1]
    cdx, cdy = C[0] - D[0], C[1] - D[1]
    abdet = adx * bdy - bdx * ady
    bcdet = bdx * cdy - cdx * bdy
    cadet = cdx * ady - adx * cdy
    alift = adx * adx + ady * ady
    blift = bdx * bdx + bdy * bdy
    clift = cdx * cdx + cdy * cdy
    det = ctx.name("det", alift * bcdet + blift * cadet + clift * abdet)
    if ctx.reject(det <= 0, line=1):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=3, points="ABCDE")
def insphere(ctx, A, B, C, D, E, tol):
    """Hit when E is inside the sphere through A, B, C, D, orient3d(A, B, C, D) > 0
    (inspherefast)."""
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
    det = ctx.name("det", (dlift * abc - clift * dab) + (blift * cda - alift * bcd))
    if ctx.reject(det <= 0, line=1):
        return ctx.miss()
    return ctx.hit(())


FPERR_TOLERANCES = [
    PredicateTolerances(dim=2, predicates=[orient2d, incircle], sign_filter=True),
    PredicateTolerances(dim=3, predicates=[orient3d, insphere], sign_filter=True),
]
