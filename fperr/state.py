"""The paper's per-quantity state (section 2), with exact rational arithmetic fast.

Most states are rational numbers (magnitudes c·L^p, relative errors 1 + aε + bε²):
those are held as :class:`fractions.Fraction`, whose arithmetic is exact and some 30×
faster than sympy's. A field that depends on ε (a tolerance inside arithmetic: c = 21ε,
√ε, ...) is an :class:`EpsFrac`, an exact rational function of u = ε^(1/4) over ℚ kept
reduced (sympy's sparse fraction field), so rule B's means stay small instead of
nesting; anything else (√2 from rule H, Max of symbolic values) is a sympy expression. Readers always see sympy
(``state.c`` is ``sympy.Rational(1, 2)``, as before); the rules read the raw values
(``state._c``) so that no sympy object is built on the hot path. docs/design.md.
"""
from __future__ import annotations

import operator
from fractions import Fraction

import sympy
from sympy import QQ
from sympy.polys.fields import field

from .symbols import eps


_U = sympy.Symbol("u", positive=True)
_FIELD, _ = field(_U, QQ)
_EPS_OF_U = {eps: _U**4}
_U_OF_EPS = {_U: eps ** sympy.Rational(1, 4)}


class EpsFrac:
    """An exact rational function of u = ε^(1/4) with rational coefficients (module
    docstring). Arithmetic with Fractions stays here (a constant result becomes a
    Fraction again); with sympy expressions it becomes sympy (``_sympy_``)."""

    __slots__ = ("f",)

    def __init__(self, f):
        self.f = f

    @staticmethod
    def make(f):
        if f.numer.is_ground and f.denom.is_ground:
            q = f.numer.LC / f.denom.LC if not f.numer.is_zero else 0
            return Fraction(int(q.numerator), int(q.denominator)) if q else Fraction(0)
        return EpsFrac(f)

    def _sympy_(self):
        return self.f.as_expr().subs(_U_OF_EPS)

    @staticmethod
    def _other(o):
        if isinstance(o, EpsFrac):
            return o.f
        if isinstance(o, (Fraction, int)):
            o = Fraction(o)
            return _FIELD(QQ(o.numerator, o.denominator))
        return None

    def _op(self, o, fn, reflected=False):
        g = self._other(o)
        if g is None:  # a sympy operand: leave the fast path
            a, b = sympy.sympify(self), sympy.sympify(o)
            return raw(fn(b, a) if reflected else fn(a, b))
        return EpsFrac.make(fn(g, self.f) if reflected else fn(self.f, g))

    __add__ = lambda s, o: s._op(o, operator.add)
    __radd__ = lambda s, o: s._op(o, operator.add, True)
    __sub__ = lambda s, o: s._op(o, operator.sub)
    __rsub__ = lambda s, o: s._op(o, operator.sub, True)
    __mul__ = lambda s, o: s._op(o, operator.mul)
    __rmul__ = lambda s, o: s._op(o, operator.mul, True)
    __truediv__ = lambda s, o: s._op(o, operator.truediv)
    __rtruediv__ = lambda s, o: s._op(o, operator.truediv, True)

    def __pow__(self, k: int):
        return EpsFrac.make(self.f ** k)

    def __neg__(self):
        return EpsFrac(-self.f)

    def __eq__(self, o):
        g = self._other(o)
        return self.f == g if g is not None else sympy.sympify(self) == o

    def __ne__(self, o):
        return not self == o

    __hash__ = None

    def __repr__(self):
        return str(sympy.sympify(self))


def raw(x):
    """x as held in a State: a Fraction when rational, an EpsFrac when a rational
    function of ε^(1/4), else a sympy expression."""
    if isinstance(x, (Fraction, EpsFrac)):
        return x
    if isinstance(x, (int, bool)):
        return Fraction(int(x))
    if isinstance(x, sympy.Basic):
        if x.is_Rational:
            return Fraction(int(x.p), int(x.q))
        if x.is_Float:
            x = sympy.nsimplify(x)
            return raw(x) if x.is_Rational else x
        if x.free_symbols == {eps}:
            try:
                return EpsFrac.make(_FIELD.from_expr(x.subs(_EPS_OF_U)))
            except (ValueError, TypeError):
                return x
        return x
    return raw(sympy.sympify(x))


def sym(x) -> sympy.Expr:
    """A raw value as sympy (what readers of a State see)."""
    if isinstance(x, Fraction):
        return sympy.Rational(x.numerator, x.denominator)
    if isinstance(x, EpsFrac):
        return sympy.sympify(x)
    return x


def rmax(u, v):
    """max of two raw values: Python's for rationals, sympy.Max otherwise."""
    if isinstance(u, Fraction) and isinstance(v, Fraction):
        return max(u, v)
    return raw(sympy.Max(sym(u), sym(v)))


def rabs(u):
    return abs(u) if isinstance(u, Fraction) else raw(sympy.Abs(sym(u)))


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
