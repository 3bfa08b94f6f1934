"""A tiny exact-arithmetic context for benchmarks: every number is a ``fractions.Fraction``.

Decisions are exact (Python comparisons of Fractions), so the predicate body runs in
exact rational arithmetic — the cost users pay for "just use exact arithmetic". The one
irrational operation in the predicates is edge-vertex's m = ‖û‖ (a square root): it is
exact when û·û is the square of a rational and otherwise rounded to a 320-bit dyadic
(the only non-exact step; the other eight predicates are fully exact).
"""
from __future__ import annotations

import math
from fractions import Fraction

from fperr import FloatContext

#: Bits of the rounded square root when it is irrational.
SQRT_BITS = 320


class FractionContext(FloatContext):
    """Scalar exact rationals (see module docstring)."""

    eps = 0.0  # no rounding: tolerances may be computed for any format

    def fresh(self, n_weights, lanes=None):
        c = FractionContext()
        c.n_weights = n_weights
        return c

    def const(self, x):
        return Fraction(x)

    def sqrt(self, x):
        x = Fraction(x)
        n, d = x.numerator, x.denominator
        rn, rd = math.isqrt(n), math.isqrt(d)
        if rn * rn == n and rd * rd == d:
            return Fraction(rn, rd)
        nd = n * d
        k = max(0, SQRT_BITS - nd.bit_length() // 2)
        return Fraction(math.isqrt(nd << (2 * k)), d << k)

    def coords(self, point, label):
        return tuple(Fraction(v) for v in point)

    def miss(self):
        return False, (Fraction(0),) * self.n_weights


def exact_tolerances(tol):
    """The tolerances ``tol`` (any format) as Fractions, for FractionContext runs."""
    from predicates.tolerances import Tolerances
    vals = {k: Fraction(float(v)) for k, v in tol.values.items()}
    return Tolerances(tol.dim, tol.L, tol.eps, FractionContext(), vals)
