"""The instrumented context: a predicate run on :class:`fperr.Tracked` (rules A–K).

Every named quantity and every check is recorded and ``reject`` never returns early, so
one run covers every line of the algorithm (section 2's error analysis, done by
execution). See :mod:`fperr.contexts` for the protocol.
"""
from __future__ import annotations

from fractions import Fraction

import sympy

from . import guards
from . import tracked as _t
from .checks import Check
from .contexts import Context
from .exact import to_fraction
from .symbols import eps as _eps


class TrackedContext(Context):
    """The instrumented run: inputs are :class:`fperr.Tracked`; every named quantity and
    every check is recorded; ``reject`` never returns early so every line is analysed.

    After a run: ``quantities`` (label → Tracked, in order of computation), ``checks``
    (list of :class:`fperr.checks.Check` with ``line``), ``weights`` (returned Tracked).
    Number-format facts: ``eps`` is the symbol ε, ``bits`` None (any format with
    ε ≤ 1e-5); constants follow rule J.
    """

    format = "tracked"
    eps = _eps  # symbolic unit roundoff

    def __init__(self):
        self.quantities: dict[str, _t.Tracked] = {}
        self.checks: list[Check] = []
        self.weights: tuple = ()

    def fresh(self, n_weights, lanes=None):
        c = TrackedContext()
        c.n_weights = n_weights
        return c

    def name(self, label, x):
        if isinstance(x, _t.Tracked):
            x.name = label
            self.quantities[label] = x
        return x

    def const(self, x):
        return _t.const(x)

    def sqrt(self, x):
        return _t.sqrt(x)

    def coords(self, point, label):
        if isinstance(point, str) or point is None:
            raise TypeError("instrumented points are tuples of Tracked coordinates")
        return tuple(point)

    # -- number-type decisions: Tracked values have no numeric value -------------------
    def from_fraction(self, q, rounding: str = "nearest"):
        """A rule-J constant (rounded once unless 17 bits hold it, see fperr.exact)."""
        return _t.const(to_fraction(q))

    def to_fraction(self, x) -> Fraction:
        raise TypeError(f"an instrumented quantity has no exact value: {x!r}")

    def convert(self, x):
        if isinstance(x, _t.Tracked):
            return x
        raise TypeError("instrumented runs take Tracked values only: coordinates from "
                        "fperr.coord, tolerances from predicates.tracked_tolerances(dim)")

    def eps_multiple(self, q, power: int = 1):
        q = to_fraction(q)
        return _t.const(sympy.Rational(q.numerator, q.denominator) * _eps ** power)

    # -- decisions: records ---------------------------------------------------------------
    def _flatten(self, cond):
        if isinstance(cond, Check):
            return [cond]
        if isinstance(cond, (list, tuple)):
            return [c for x in cond for c in self._flatten(x)]
        raise TypeError(f"instrumented condition must be a Tracked comparison, got {cond!r}")

    def reject(self, cond, line=None) -> bool:
        for c in self._flatten(cond):
            c.line = line
            self.checks.append(c)
            guards.record_rejection(c)  # afterwards lhs > rhs: a floor for lhs
        for pair in _sign_pairs(cond):
            # rejected "same sign" leaves opposite computed signs, "differ" equal ones
            guards.relate_signs(pair.x, pair.y, 1 if pair.same else 0)
        return False

    def any(self, *conds):
        return list(conds)

    def same_sign(self, x, y):
        return _SignPair(x, y, True)

    def differ_sign(self, x, y):  # the same two sign tests are recorded
        return _SignPair(x, y, False)

    def hit(self, weights):
        self.weights = tuple(weights)
        return None, self.weights

    def miss(self):  # pragma: no cover - reject never asks for it
        raise AssertionError("the instrumented run never returns early")


class _SignPair(list):
    """The two sign tests of ``same_sign``/``differ_sign`` (a list of checks, as
    before) that also remember which relation they test."""

    def __init__(self, x, y, same: bool):
        zero = _t.const(0)
        super().__init__([Check(x, zero, ">", label="sign"), Check(y, zero, ">", label="sign")])
        self.x, self.y, self.same = x, y, same


def _sign_pairs(cond):
    stack, out = [cond], []
    while stack:
        c = stack.pop()
        if isinstance(c, _SignPair):
            out.append(c)
        elif isinstance(c, (list, tuple)):
            stack.extend(c)
    return out
