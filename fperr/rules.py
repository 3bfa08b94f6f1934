"""Rules A–K of the paper's section 2, as a table of pure functions on the state.

Each rule maps the input states to the result's (c, p, n, a, b, r) or raises
:class:`NoRule` when its restriction does not hold. Where several rules apply to an
operator, the more restricted one is listed first and wins (C before B, E before D),
as section 2 prescribes. The rules follow the paper's table exactly, with the two
absolute values the PDF conversion lost restored: rule I is x = |x1|, and rule H's b
is 1 + b1/2 + |a1/2 − a1²/8| (without the bars b can go negative for a1 > 4, which
would be unsound).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

ONE = sympy.Integer(1)
ZERO = sympy.Integer(0)


class InvalidBound(ValueError):
    """A bound was requested for a quantity whose estimate is not valid (v = 0)."""


class NoRule(Exception):
    """No rule applies to these inputs; the result is invalid (section 2)."""


@dataclass(frozen=True)
class State:
    """The paper's per-quantity state, minus the string s (kept on :class:`Tracked`).

    c, p: magnitude bound c·L^p.  n: guaranteed non-negative.  a, b: relative error
    1 + aε + bε².  r: error relative to the quantity itself (else to c·L^p).
    """

    c: sympy.Expr
    p: sympy.Rational
    n: bool
    a: sympy.Expr
    b: sympy.Expr
    r: bool


def _mean(c1, x1, c2, x2):
    return (c1 * x1 + c2 * x2) / (c1 + c2)


def rule_A(x: State) -> State:
    """A: x = −x1."""
    return State(x.c, x.p, False, x.a, x.b, x.r)


def rule_B(x: State, y: State) -> State:
    """B: x = x1 + x2, restriction p1 = p2."""
    if x.p != y.p:
        raise NoRule(f"sum of powers L^{x.p} and L^{y.p} (rules B/C need p1 = p2)")
    c = x.c + y.c
    a = 1 + _mean(x.c, x.a, y.c, y.a)
    b = (1 + x.c * (x.a + x.b) + y.c * (y.a + y.b)) / c
    return State(c, x.p, x.n and y.n, a, b, False)


def rule_C(x: State, y: State) -> State:
    """C: x = x1 + x2, restriction n1, n2, r1, r2 and p1 = p2."""
    if not (x.n and y.n and x.r and y.r) or x.p != y.p:
        raise NoRule("rule C needs n1, n2, r1, r2 and p1 = p2")
    a = 1 + sympy.Max(x.a, y.a)
    b = 1 + sympy.Max(x.a + x.b, y.a + y.b)
    return State(x.c + y.c, x.p, True, a, b, True)


def rule_D(x: State, y: State) -> State:
    """D: x = x1 − x2, restriction p1 = p2."""
    if x.p != y.p:
        raise NoRule(f"difference of powers L^{x.p} and L^{y.p} (rules D/E need p1 = p2)")
    s = rule_B(x, y)
    return State(s.c, s.p, False, s.a, s.b, False)


def rule_E(x: State, y: State) -> State:
    """E: x = x1 − x2 of two exact quantities of equal power: one rounding, relative."""
    if x.p != y.p or any(v != 0 for v in (x.a, x.b, y.a, y.b)):
        raise NoRule("rule E needs p1 = p2 and exact inputs")
    return State(x.c + y.c, x.p, False, ONE, ZERO, True)


def rule_F(x: State, y: State, same: bool) -> State:
    """F: x = x1·x2; n when s1 = s2 (a square) or both factors are non-negative."""
    a = 1 + x.a + y.a
    b = (1 + x.a) * (1 + y.a) + x.b + y.b
    return State(x.c * y.c, x.p + y.p, same or (x.n and y.n), a, b, x.r and y.r)


def rule_G(x: State, y: State) -> State:
    """G: x = x1/x2, restriction r1 and r2; c = 1 by the normalisation convention (*)."""
    if not (x.r and y.r):
        raise NoRule("division needs relative errors on both operands (rule G: r1 and r2)")
    a = 1 + x.a + y.a
    b = (1 + x.a) * (1 + y.a) + x.b + y.b + y.a**2
    return State(ONE, x.p - y.p, x.n and y.n, a, b, True)


def rule_P(x: State, y: State, factor=None) -> State:
    """P: x = x1·2^k, x1 scaled by an exact power of two (a rule-J constant ±2^k): no
    rounding (the significand is unchanged; underflow and overflow are excluded by the
    premise on L, predicates.tolerances.safe_scale_range), c scaled by 2^k."""
    if factor is None or isinstance(factor, bool):
        raise NoRule("rule P needs an exact power-of-two constant factor")
    return State(x.c * abs(factor), x.p, x.n and factor > 0, x.a, x.b, x.r)


def rule_Q(x: State, y: State, factor=None) -> State:
    """Q: x = x1 / 2^k, an exact power-of-two divisor: rule P with 2^−k."""
    if factor is None or isinstance(factor, bool):
        raise NoRule("rule Q needs an exact power-of-two constant divisor")
    return rule_P(x, y, 1 / factor)


def rule_H(x: State) -> State:
    """H: x = √x1, restriction n1 and r1."""
    if not (x.n and x.r):
        raise NoRule("square root needs a non-negative operand with relative error (rule H)")
    a = 1 + x.a / 2
    b = 1 + x.b / 2 + sympy.Abs(x.a / 2 - x.a**2 / 8)
    return State(sympy.sqrt(x.c), x.p / 2, True, a, b, x.r)


def rule_I(x: State) -> State:
    """I: x = |x1|."""
    return State(x.c, x.p, True, x.a, x.b, x.r)


def rule_J(value: sympy.Expr, exact: bool) -> State:
    """J: x = # (a numeric constant). An inexact constant is rounded once: a = 1."""
    return State(sympy.Abs(value), sympy.Integer(0), bool(value >= 0),
                 ZERO if exact else ONE, ZERO, True)


def rule_K(c=sympy.Rational(1, 2), p=sympy.Integer(1)) -> State:
    """K: x = coord, exact, |x| ≤ L/2 (coordinates are shifted to the pair's box)."""
    return State(sympy.sympify(c), sympy.sympify(p), False, ZERO, ZERO, True)

