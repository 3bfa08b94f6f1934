"""2D segment crossing from four orientation signs: user code, not part of fperr.

``seg_seg_cross(A, B, C, D)`` hits when the segments AB and CD cross: C and D on
different sides of the line AB, and A and B on different sides of the line CD. Its
decisions are the signs of four orientation determinants, with no tolerance: declared
"sign exact or undecided" (``sign_filter``), each sign decides only when
|F[o]| > θ = 7εL² (derived from the sign bound E_sign[o] = 6εL² + 8ε²L²: E without the
last rounding, docs/proofs.md "Sign tests"); a lane with a smaller |F[o]| is undecided
(a filtered predicate decides it exactly). ``fperr verify --predicates
segment_crossing`` (with ``PYTHONPATH=docs/examples``) decides θ ≥ (1 + ε)·E_sign for
every ε ≤ 1e-5.
"""
from predicates.core import predicate
from predicates.vector import cross2, sub
from proofs.user_predicates import PredicateTolerances


def orient(ctx, name, P, Q, R):
    """(Q − P) × (R − P): twice the signed area of PQR, positive when R is left of PQ."""
    return ctx.name(name, cross2(sub(Q, P), sub(R, P)))


@predicate(dim=2, points="ABCD")
def seg_seg_cross(ctx, A, B, C, D, tol):
    """Hit when AB and CD cross (the four orientation signs differ pairwise)."""
    o_abc, o_abd = orient(ctx, "o_ABC", A, B, C), orient(ctx, "o_ABD", A, B, D)
    o_cda, o_cdb = orient(ctx, "o_CDA", C, D, A), orient(ctx, "o_CDB", C, D, B)
    if ctx.reject(ctx.any(ctx.same_sign(o_abc, o_abd), ctx.same_sign(o_cda, o_cdb)),
                  line=1):
        return ctx.miss()
    return ctx.hit(())


FPERR_TOLERANCES = PredicateTolerances(dim=2, predicates=[seg_seg_cross],
                                       sign_filter=[seg_seg_cross])
