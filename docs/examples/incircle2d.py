"""A tolerance-based 2D incircle test for Delaunay users: user code, not part of fperr.

Two predicates written in the style of the paper (docs/custom-predicates.md) and the
declaration of their tolerances and geometric facts, which ``fperr verify --predicates
incircle2d`` decides for every ε ≤ 1e-5 (run with ``PYTHONPATH=docs/examples``).

* ``orient2d(A, B, C)``: ABC is robustly counter-clockwise, a = (B−A)×(C−A) > α.
* ``incircle(A, B, C, D)``: ABC is robustly counter-clockwise and D robustly inside its
  circumcircle: det > ω, where det (the lifted 3×3 determinant) = a·π(D), π(D) =
  r² − ‖D − O‖² the power of D with respect to the circle (centre O, radius r).

The fact: when line 1 passes, a > α− (α's window); if also π(D) > π−, then
det > α−·π−, so ω+ ≤ α−·π− makes line 2 accept — written ``omega_hi = alpha_lo*power_lo``
like the paper's κ+ = 2τ−² (the proof needs ω+ ≤ α−·π−; ``fperr synthesize`` sets it
with equality). π is a tolerance of the guarantee only: no code computes it.
"""
from predicates.core import predicate
from predicates.vector import cross2, sub
from proofs.user_predicates import Fact, PredicateTolerances


@predicate(dim=2, points="ABC")
def orient2d(ctx, A, B, C, tol):
    """Hit when ABC is robustly counter-clockwise: (B−A)×(C−A) > α."""
    a = ctx.name("area2", cross2(sub(B, A), sub(C, A)))
    if ctx.reject(a <= tol.alpha, line=1):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=2, points="ABCD")
def incircle(ctx, A, B, C, D, tol):
    """Hit when ABC is robustly counter-clockwise and D robustly inside its circle."""
    a = ctx.name("area2", cross2(sub(B, A), sub(C, A)))
    if ctx.reject(a <= tol.alpha, line=1):          # flat or clockwise: no circle
        return ctx.miss()
    ad, bd, cd = sub(A, D), sub(B, D), sub(C, D)
    alift = ad[0] * ad[0] + ad[1] * ad[1]
    blift = bd[0] * bd[0] + bd[1] * bd[1]
    clift = cd[0] * cd[0] + cd[1] * cd[1]
    det = ctx.name("det", alift * cross2(bd, cd) + blift * cross2(cd, ad)
                   + clift * cross2(ad, bd))
    if ctx.reject(det <= tol.omega, line=2):        # outside, or too near the circle
        return ctx.miss()
    return ctx.hit(())


FPERR_TOLERANCES = PredicateTolerances(
    dim=2,
    predicates=[orient2d, incircle],
    tolerances={
        # name: (T−, T, T+), expressions in eps and L
        "omega": ("150*eps*L^4", "300*eps*L^4", "600*eps*L^4"),
        "alpha": ("20*sqrt(eps)*L^2", "24*sqrt(eps)*L^2", "28*sqrt(eps)*L^2"),
        "power": ("30*sqrt(eps)*L^2", "32*sqrt(eps)*L^2", "34*sqrt(eps)*L^2"),
    },
    facts=[Fact("omega_hi = alpha_lo*power_lo",
                "det = a·π(D) > α−·π− once line 1 passes and π(D) > π−", key="omega+<=alpha-*power-",
                predicate="incircle")],
    order=("omega", "alpha", "power"),   # bottom-up: ω+ is bounded by α−·π−
)
