"""The four classic sign predicates as filtered predicates (:mod:`predicates.filtered`):
orient2d, orient3d, incircle and insphere, the usual determinant expansions with the
differences first (the evaluation order of CGAL's and Shewchuk's filters). A worked
example of the public API; ``benchmarks/filtered_bench.py`` measures them."""
from __future__ import annotations

from predicates.filtered import sign_predicate
from predicates.vector import cross2, sub, triple

__all__ = ["incircle", "insphere", "orient2d", "orient3d"]


@sign_predicate(dim=2, points="ABC")
def orient2d(A, B, C):
    """> 0 when C is left of the directed line AB (twice the signed area of ABC)."""
    return cross2(sub(B, A), sub(C, A))


@sign_predicate(dim=3, points="ABCD")
def orient3d(A, B, C, D):
    """> 0 when D is on the side of the plane ABC that (B − A) × (C − A) points to: six
    times the signed volume ((B − A) × (C − A))·(D − A)."""
    return triple(sub(B, A), sub(C, A), sub(D, A))


@sign_predicate(dim=2, points="ABCD")
def incircle(A, B, C, D):
    """> 0 when D is inside the circle through A, B, C (counter-clockwise)."""
    a, b, c = sub(A, D), sub(B, D), sub(C, D)
    la, lb, lc = (p[0] * p[0] + p[1] * p[1] for p in (a, b, c))
    return la * cross2(b, c) + lb * cross2(c, a) + lc * cross2(a, b)


@sign_predicate(dim=3, points="ABCDE")
def insphere(A, B, C, D, E):
    """> 0 when E is inside the sphere through A, B, C, D (positively oriented)."""
    a, b, c, d = sub(A, E), sub(B, E), sub(C, E), sub(D, E)
    la, lb, lc, ld = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2] for p in (a, b, c, d))
    return (ld * triple(a, b, c) - lc * triple(a, b, d)) + (lb * triple(a, c, d)
                                                         - la * triple(b, c, d))
