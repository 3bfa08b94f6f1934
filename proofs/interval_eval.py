"""Rigorous interval evaluation of sympy expressions (mpmath.iv, outward rounding) and
exact signs of constants, for :mod:`proofs.decide` (step 3: dominance and the sign of q
on the pieces between roots). Never used to sample: an enclosure either proves a sign
or the caller refines.
"""
from __future__ import annotations

from fractions import Fraction

import mpmath
import sympy
from mpmath import iv

_PREC = 160          # bits of interval arithmetic to start with
_MAX_PREC = 4000

def _iv(expr: sympy.Expr, env: dict):
    """Interval enclosure of a sympy expression (outward-rounded mpmath.iv)."""
    if expr.is_Symbol:
        return env[expr]
    if expr.is_Integer:
        return iv.mpf(int(expr))
    if expr.is_Rational:
        return iv.mpf(int(expr.p)) / iv.mpf(int(expr.q))
    if expr.is_Float:
        return iv.mpf(str(expr))
    if expr is sympy.pi:
        return iv.pi
    if expr.is_Add:
        out = iv.mpf(0)
        for a in expr.args:
            out = out + _iv(a, env)
        return out
    if expr.is_Mul:
        out = iv.mpf(1)
        for a in expr.args:
            out = out * _iv(a, env)
        return out
    if expr.is_Pow:
        b, e = expr.args
        if e.is_Integer:
            x = _iv(b, env)
            n = int(e)
            if n >= 0:
                return _ipow(x, n)
            return iv.mpf(1) / _ipow(x, -n)
        if e.is_Rational:
            x = _iv(b, env)
            if e == sympy.Rational(1, 2):
                return iv.sqrt(x)
            if e == sympy.Rational(-1, 2):
                return iv.mpf(1) / iv.sqrt(x)
            return iv.exp(iv.log(x) * (iv.mpf(int(e.p)) / iv.mpf(int(e.q))))
    if isinstance(expr, sympy.Abs):
        x = _iv(expr.args[0], env)
        return abs(x)
    if isinstance(expr, (sympy.Min, sympy.Max)):
        xs = [_iv(a, env) for a in expr.args]
        pick = min if isinstance(expr, sympy.Min) else max
        return iv.mpf([pick(x.a for x in xs), pick(x.b for x in xs)])
    raise TypeError(f"cannot evaluate {expr!r} in interval arithmetic")


def _ipow(x, n: int):
    """x**n for an interval x and integer n ≥ 0 (even powers of intervals through 0)."""
    if n == 0:
        return iv.mpf(1)
    out = x
    for _ in range(n - 1):
        out = out * x
    if n % 2 == 0 and x.a < 0 < x.b:
        return iv.mpf([0, out.b])
    return out


def interval(expr: sympy.Expr, env: dict | None = None, prec: int = _PREC):
    """Enclosure of ``expr`` (sympy) with the symbols of ``env`` bound to intervals
    given as Fractions or (lo, hi) pairs of Fractions."""
    with mpmath.workprec(prec):
        old = iv.prec
        iv.prec = prec
        try:
            e = {}
            for k, v in (env or {}).items():
                lo, hi = (v, v) if not isinstance(v, tuple) else v
                e[k] = iv.mpf([_enclose(lo).a, _enclose(hi).b])
            return _iv(expr, e)
        finally:
            iv.prec = old


def _enclose(q: Fraction):
    """An interval holding the rational q (iv division rounds outward)."""
    return iv.mpf(int(q.numerator)) / iv.mpf(int(q.denominator)) if q.denominator != 1 \
        else iv.mpf(int(q.numerator))


def sign(expr: sympy.Expr, env: dict | None = None) -> int:
    """The exact sign of a constant (or of ``expr`` at an exact point), by interval
    arithmetic at increasing precision, with an exact zero test as last resort."""
    prec = _PREC
    while prec <= _MAX_PREC:
        x = interval(expr, env, prec)
        if x.a > 0:
            return 1
        if x.b < 0:
            return -1
        if x.a == 0 and x.b == 0:
            return 0
        prec *= 2
    value = expr.subs({k: sympy.Rational(v.numerator, v.denominator)
                       for k, v in (env or {}).items()})
    if sympy.simplify(value) == 0:
        return 0
    mp = sympy.minimal_polynomial(value, sympy.Dummy("x"))
    if mp.is_Symbol:
        return 0
    raise ArithmeticError(f"sign of {expr} undecided at {_MAX_PREC} bits")
