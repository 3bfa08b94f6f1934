"""Exact-arithmetic runs for benchmarks: the library's :class:`fperr.ExactContext`.

Every number is a ``fractions.Fraction``, so the predicate body runs in exact rational
arithmetic — the cost users pay for "just use exact arithmetic" (see that class for the
one square root, rounded to ``SQRT_BITS`` bits when irrational).
"""
from __future__ import annotations

from fperr import ExactContext
from fperr.contexts import SQRT_BITS  # noqa: F401  (re-exported for the benchmarks)

#: The exact context under the benchmarks' historical name.
FractionContext = ExactContext


def exact_tolerances(tol):
    """The tolerances ``tol`` (any format) as Fractions, for ExactContext runs."""
    from predicates.tolerances import Tolerances
    ctx = ExactContext()
    vals = {k: ctx.convert(v) for k, v in tol.values.items()}
    return Tolerances(tol.dim, tol.L, tol.eps, ctx, vals)
