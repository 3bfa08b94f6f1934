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

from fractions import Fraction

import sympy

from .state import State, rabs, rmax, rsqrt
from .symbols import eps as _EPS

__all__ = ["NoRule", "State"]

ONE = Fraction(1)
ZERO = Fraction(0)


class InvalidBound(ValueError):
    """A bound was requested for a quantity whose estimate is not valid (v = 0)."""


class NoRule(Exception):
    """No rule applies to these inputs; the result is invalid (section 2)."""


def _mean(c1, x1, c2, x2):
    return (c1 * x1 + c2 * x2) / (c1 + c2)


def rule_A(x: State) -> State:
    """A: x = −x1."""
    return State(x._c, x._p, False, x._a, x._b, x.r)


def rule_B(x: State, y: State) -> State:
    """B: x = x1 + x2, restriction p1 = p2."""
    if x._p != y._p:
        raise NoRule(f"sum of powers L^{x._p} and L^{y._p} (rules B/C need p1 = p2)")
    c = x._c + y._c
    if c == 0:  # both operands exactly 0 (c = 0): the sum is 0, and the means are 0/0
        return State(c, x._p, x.n and y.n, ONE, ZERO, False)
    a = 1 + _mean(x._c, x._a, y._c, y._a)
    b = (1 + x._c * (x._a + x._b) + y._c * (y._a + y._b)) / c
    return State(c, x._p, x.n and y.n, a, b, False)


def rule_C(x: State, y: State) -> State:
    """C: x = x1 + x2, restriction n1, n2, r1, r2 and p1 = p2."""
    if not (x.n and y.n and x.r and y.r) or x._p != y._p:
        raise NoRule("rule C needs n1, n2, r1, r2 and p1 = p2")
    a = 1 + rmax(x._a, y._a)
    b = 1 + rmax(x._a + x._b, y._a + y._b)
    return State(x._c + y._c, x._p, True, a, b, True)


def rule_D(x: State, y: State) -> State:
    """D: x = x1 − x2, restriction p1 = p2."""
    if x._p != y._p:
        raise NoRule(f"difference of powers L^{x._p} and L^{y._p} (rules D/E need p1 = p2)")
    s = rule_B(x, y)
    return State(s._c, s._p, False, s._a, s._b, False)


def rule_E(x: State, y: State) -> State:
    """E: x = x1 − x2 of two exact quantities of equal power: one rounding, relative."""
    if x._p != y._p or any(v != 0 for v in (x._a, x._b, y._a, y._b)):
        raise NoRule("rule E needs p1 = p2 and exact inputs")
    return State(x._c + y._c, x._p, False, ONE, ZERO, True)


def rule_F(x: State, y: State, same: bool) -> State:
    """F: x = x1·x2; n when s1 = s2 (a square) or both factors are non-negative."""
    a = 1 + x._a + y._a
    b = (1 + x._a) * (1 + y._a) + x._b + y._b
    return State(x._c * y._c, x._p + y._p, same or (x.n and y.n), a, b, x.r and y.r)


def rule_G(x: State, y: State) -> State:
    """G: x = x1/x2, restriction r1 and r2; c = 1 by the normalisation convention (*)."""
    if not (x.r and y.r):
        raise NoRule("division needs relative errors on both operands (rule G: r1 and r2)")
    a = 1 + x._a + y._a
    b = (1 + x._a) * (1 + y._a) + x._b + y._b + y._a**2
    return State(ONE, x._p - y._p, x.n and y.n, a, b, True)


def rule_S(x: State, y: State) -> State:
    """S: x = x1·2^k (y the exact constant ±2^k): no rounding, the state scaled.

    Multiplying a binary floating-point number by a power of two only changes its
    exponent, so F[x1·2^k] = F[x1]·2^k exactly unless the result underflows or overflows,
    which section 2's model (and the safe scale range) excludes (docs/proofs.md,
    "Quotients and roots")."""
    v = y._c
    if not _power_of_two(y):
        raise NoRule("rule S needs an exact constant ±2^k")
    return State(x._c * v, x._p, x.n and y.n, x._a, x._b, x.r)


def rule_SD(x: State, y: State) -> State:
    """SD: x = x1/2^k, exact like rule S (the constant's reciprocal is a power of two)."""
    if not _power_of_two(y):
        raise NoRule("rule SD needs an exact constant ±2^k")
    return State(x._c / y._c, x._p, x.n and y.n, x._a, x._b, x.r)


def _power_of_two(y: State) -> bool:
    """y is an exact, ε-free constant whose magnitude is 2^k (k any integer)."""
    c = y._c
    if y._p != 0 or y._a != 0 or y._b != 0 or not y.r or not isinstance(c, Fraction) \
            or c <= 0:
        return False
    num, den = c.numerator, c.denominator
    return num & (num - 1) == 0 and den & (den - 1) == 0


def rule_GL(x: State, y: State, floor_y: sympy.Expr, floor_x=None) -> State:
    """GL: x = x1/x2 where a passed check bounds the computed divisor: |F[x2]| > f·L^p2.

    With E[x2] = e2·L^p2 and D = f − e2 > 0 (a premise the verifier checks), the exact
    |x2| ≥ D·L^p2, so |x| ≤ (c1/D)·L^(p1−p2): a true magnitude bound (not rule G's
    c = 1*). The error (docs/proofs.md, "Quotients and roots"):

    * x1 with a relative bound R1 (r1, or its own floor: :func:`relative_from_floor`):
      x2/F[x2] = 1 + η with |η| = |x2 − F[x2]|/|F[x2]| ≤ e2/f, so the quotient is
      relative with R = (1 + R1)(1 + e2/f)(1 + ε) − 1, exactly;
    * otherwise |F[x] − x| ≤ L^(p1−p2)·[(e1/f + c1·e2/(f·D))(1 + ε) + (c1/D)·ε].

    Either is stored as aε (a = that bound/ε, b = 0): an error in ε that need not be
    O(ε), exact all the same."""
    e2 = _e(y)
    D = floor_y - e2
    c = x._c / D
    if x.r or floor_x is not None:
        xr = x if x.r else relative_from_floor(x, floor_x)
        R1 = xr.a * _EPS + xr.b * _EPS**2
        R = (1 + R1) * (1 + e2 / floor_y) * (1 + _EPS) - 1
        return State(c, x._p - y._p, x.n and y.n, R / _EPS, ZERO, True)
    rel = (1 + _EPS) * (D * (x._a * _EPS + x._b * _EPS**2) + e2) / floor_y + _EPS
    return State(c, x._p - y._p, x.n and y.n, rel / _EPS, ZERO, False)


def _e(x: State) -> sympy.Expr:
    """e with E[x] = e·L^p."""
    return x._c * (x._a * _EPS + x._b * _EPS**2)


def relative_from_floor(x: State, floor: sympy.Expr) -> State:
    """x with its error made relative to itself by |F[x]| > f·L^p: |x| ≥ D·L^p with
    D = f − e (premise D > 0), so |F[x] − x| ≤ e·L^p ≤ (e/D)·|x|; aε = e/D (b = 0)."""
    e = _e(x)
    return State(x._c, x._p, x.n, e / (floor - e) / _EPS, ZERO, True)


def rule_HL(x: State, floor: sympy.Expr) -> State:
    """HL: x = √x1 of a non-negative x1 whose computed value passed |F[x1]| > f·L^p.

    With D = f − e1 > 0 (premise), x1 ≥ D·L^p and F[x1] > f·L^p, so
    |√F[x1] − √x1| = |F[x1] − x1|/(√F[x1] + √x1) ≤ e1·L^p/(√f + √D)/L^(p/2) and,
    relative to √x1 ≥ √D·L^(p/2): R1 = e1/(√(f·D) + D); with the rounding of the root
    R = R1·(1 + ε) + ε, exactly. c = √c1, p = p1/2 as rule H."""
    if not x.n:
        raise NoRule("square root needs a non-negative operand (rule H)")
    e = _e(x)
    D = floor - e
    R1 = e / (sympy.sqrt(floor * D) + D)
    R = R1 * (1 + _EPS) + _EPS
    return State(rsqrt(x._c), x._p / 2, True, R / _EPS, ZERO, True)


def rule_H(x: State) -> State:
    """H: x = √x1, restriction n1 and r1."""
    if not (x.n and x.r):
        raise NoRule("square root needs a non-negative operand with relative error (rule H)")
    a = 1 + x._a / 2
    b = 1 + x._b / 2 + rabs(x._a / 2 - x._a**2 / 8)
    return State(rsqrt(x._c), x._p / 2, True, a, b, x.r)


def rule_I(x: State) -> State:
    """I: x = |x1|."""
    return State(x._c, x._p, True, x._a, x._b, x.r)


def rule_J(value: sympy.Expr, exact: bool) -> State:
    """J: x = # (a numeric constant). An inexact constant is rounded once: a = 1."""
    return State(sympy.Abs(value), sympy.Integer(0), bool(value >= 0),
                 ZERO if exact else ONE, ZERO, True)


def rule_K(c=sympy.Rational(1, 2), p=sympy.Integer(1)) -> State:
    """K: x = coord, exact, |x| ≤ L/2 (coordinates are shifted to the pair's box)."""
    return State(sympy.sympify(c), sympy.sympify(p), False, ZERO, ZERO, True)

