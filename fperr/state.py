"""The paper's per-quantity state (section 2), with exact rational arithmetic fast.

Most states are rational numbers (magnitudes c·L^p, relative errors 1 + aε + bε²):
those are held as :class:`fractions.Fraction`, whose arithmetic is exact and some 30×
faster than sympy's; a field that is not rational (√2 from rule H, ε in a tolerance's
magnitude, Max of symbolic values) is a sympy expression. Readers always see sympy
(``state.c`` is ``sympy.Rational(1, 2)``, as before); the rules read the raw values
(``state._c``) so that no sympy object is built on the hot path. docs/design.md.
"""
from __future__ import annotations

from fractions import Fraction

import sympy


def raw(x):
    """x as held in a State: a Fraction when rational, else a sympy expression."""
    if isinstance(x, Fraction):
        return x
    if isinstance(x, (int, bool)):
        return Fraction(int(x))
    if isinstance(x, sympy.Basic):
        if x.is_Rational:
            return Fraction(int(x.p), int(x.q))
        if x.is_Float:
            x = sympy.nsimplify(x)
            return raw(x) if x.is_Rational else x
        return x
    return raw(sympy.sympify(x))


def sym(x) -> sympy.Expr:
    """A raw value as sympy (what readers of a State see)."""
    if isinstance(x, Fraction):
        return sympy.Rational(x.numerator, x.denominator)
    return x


def rmax(u, v):
    """max of two raw values: Python's for rationals, sympy.Max otherwise."""
    if isinstance(u, Fraction) and isinstance(v, Fraction):
        return max(u, v)
    return raw(sympy.Max(sym(u), sym(v)))


def rabs(u):
    return abs(u) if isinstance(u, Fraction) else raw(sympy.Abs(u))


def rsqrt(u):
    """√u, a Fraction when u is the square of one."""
    if isinstance(u, Fraction) and u >= 0:
        n, d = _isqrt(u.numerator), _isqrt(u.denominator)
        if n is not None and d is not None:
            return Fraction(n, d)
    return raw(sympy.sqrt(sym(u)))


def _isqrt(k: int):
    from math import isqrt
    r = isqrt(k)
    return r if r * r == k else None


class State:
    """The paper's per-quantity state, minus the string s (kept on ``Tracked``).

    c, p: magnitude bound c·L^p.  n: guaranteed non-negative.  a, b: relative error
    1 + aε + bε².  r: error relative to the quantity itself (else to c·L^p).
    ``c``, ``p``, ``a``, ``b`` are sympy; ``_c``, ``_p``, ``_a``, ``_b`` the raw values.
    """

    __slots__ = ("_c", "_p", "n", "_a", "_b", "r")

    def __init__(self, c, p, n: bool, a, b, r: bool):
        self._c, self._p, self._a, self._b = raw(c), raw(p), raw(a), raw(b)
        self.n, self.r = bool(n), bool(r)

    c = property(lambda self: sym(self._c))
    p = property(lambda self: sym(self._p))
    a = property(lambda self: sym(self._a))
    b = property(lambda self: sym(self._b))

    def _key(self):
        return (self.c, self.p, self.n, self.a, self.b, self.r)

    def __eq__(self, other):
        return isinstance(other, State) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def __repr__(self):
        return (f"State(c={self.c}, p={self.p}, n={self.n}, a={self.a}, b={self.b}, "
                f"r={self.r})")
