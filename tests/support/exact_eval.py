"""Evaluate one expression in several number systems, and compare with fperr's bound.

An *expression* is a plain Python function ``fn(xs, K)``: ``xs`` are the input
coordinates in some number system, ``K`` the system itself — a library context
(:func:`fperr.context`) or a reference evaluator (``K.const(q)``, ``K.sqrt(x)``); the
operators are Python's (``+ - * / abs``), so the same function runs, in the same
operation order, on

* :data:`TRACKED`   — fperr's instrumented numbers (gives the state and the bound),
* :data:`BINARY64`  — Python floats, ε = 2^-53,
* :data:`BINARY32`  — ``numpy.float32`` scalars, ε = 2^-24,
* :data:`MP17`      — mpmath at 17 bits of precision, ε = 2^-17 (the paper's worst case),
* :data:`EXACT`     — :class:`fperr.ExactContext`, Fractions (no square roots),
* :data:`INTERVAL`  — mpmath interval arithmetic at 300 bits (a rigorous enclosure of
  the exact value when a square root is involved),
* :data:`SYMBOLIC`  — sympy, exact algebraic numbers (a slow fallback for ties).

:func:`check_bounds` does the comparison. Every comparison with a bound is exact:
the computed value and the exact value (or the endpoints of its enclosure) are
Fractions, the bound's coefficient is enclosed between two Fractions, and only a
comparison that lands inside that enclosure falls back to exact sympy arithmetic.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable

import mpmath
import numpy as np
import sympy
from mpmath.ctx_iv import MPIntervalContext

import fperr
from fperr import to_fraction
from fperr.exact import is_exact
from fperr.exact import significand_bits as _significand_bits

# ---------------------------------------------------------------------------------
# exact helpers: the library's (fperr.exact)


def significand_bits(q: Fraction) -> int:
    """Bits of the odd part of a dyadic rational (raises for a non-dyadic one)."""
    nb = _significand_bits(Fraction(q))
    if nb is None:
        raise ValueError(f"{q} is not dyadic")
    return nb


def representable(q: Fraction, bits: int) -> bool:
    return is_exact(Fraction(q), bits)


def eps_of(fmt) -> Fraction:
    """The unit roundoff 2^-bits of a binary context, exactly."""
    return Fraction(1, 2 ** fmt.bits)


# ---------------------------------------------------------------------------------
# number systems: the library's contexts, plus two reference evaluators


class _Interval:
    """mpmath intervals at 300 bits: outward rounded, so the result encloses the exact value
    (a reference evaluator, not a number format)."""

    format = "interval300"

    def __init__(self, prec: int = 300):
        self.ctx = MPIntervalContext()
        self.ctx.prec = prec

    def convert(self, q):
        q = Fraction(q)
        num, den = self.ctx.mpf(q.numerator), self.ctx.mpf(q.denominator)
        return num / den

    const = convert

    def sqrt(self, x):
        return self.ctx.sqrt(x)

    def enclosure(self, x) -> tuple[Fraction, Fraction]:
        lo, hi = x._mpi_
        return to_fraction(mpmath.mp.make_mpf(lo)), to_fraction(mpmath.mp.make_mpf(hi))


class _Symbolic:
    """Exact algebraic numbers (sympy): the slow reference for ties."""

    format = "sympy"

    def convert(self, q):
        q = Fraction(q)
        return sympy.Rational(q.numerator, q.denominator)

    const = convert

    def sqrt(self, x):
        return sympy.sqrt(x)


BINARY64 = fperr.context("binary64")
BINARY32 = fperr.context("binary32")
MP17 = fperr.context("mp17")
EXACT = fperr.ExactContext(sqrt_bits=None)   # no square roots: evaluate those in INTERVAL
INTERVAL = _Interval()
SYMBOLIC = _Symbolic()
TRACKED = fperr.context("tracked")

#: The three floating-point formats every bound is checked in.
FORMATS = (BINARY64, BINARY32, MP17)


def evaluate(expr, fmt, coords) -> Fraction:
    """The exact value of ``expr`` computed in ``fmt`` (inside its session: mpmath's
    precision), keeping the caller's numpy error policy (:func:`check` raises)."""
    policy = np.geterr()
    with fmt.session(), np.errstate(**policy):
        return fmt.to_fraction(expr(fmt, coords))


# ---------------------------------------------------------------------------------
# expressions


@dataclass(frozen=True)
class Expr:
    """An expression over ``len(names)`` coordinates, written once for every system.

    ``rule``: the rule fperr must apply at the top of the expression.
    ``pre``: a precondition on the exact (Fraction) coordinates, e.g. a non-zero
    denominator or a weight in [0, 1].
    """

    name: str
    names: tuple[str, ...]
    fn: Callable
    rule: str | None = None
    sqrt: bool = False
    pre: Callable | None = None
    notes: str = ""

    @property
    def arity(self) -> int:
        return len(self.names)

    def __call__(self, system, coords):
        if system is TRACKED:
            return self.fn([fperr.coord(n) for n in self.names], TRACKED)
        return self.fn([system.convert(q) for q in coords], system)

    def __repr__(self) -> str:
        return self.name


@functools.lru_cache(maxsize=None)
def tracked(expr: Expr) -> fperr.Tracked:
    return expr(TRACKED, None)


# ---------------------------------------------------------------------------------
# exact comparison with bounds


def scale_for(coords) -> Fraction:
    """Rule K: coordinates satisfy |x| <= L/2; the tightest choice is L = 2·max|x|."""
    m = max((abs(Fraction(q)) for q in coords), default=Fraction(0))
    return 2 * m if m else Fraction(1)


@dataclass(frozen=True)
class Coef:
    """A non-negative real sympy number enclosed between two Fractions."""

    expr: sympy.Expr
    lo: Fraction
    hi: Fraction

    @staticmethod
    def of(e) -> "Coef":
        e = sympy.nsimplify(e) if isinstance(e, sympy.Float) else sympy.sympify(e)
        if e.is_Rational:
            q = Fraction(int(e.p), int(e.q))
            return Coef(e, q, q)
        approx = Fraction(str(sympy.N(e, 80)))
        slack = abs(approx) * Fraction(1, 10 ** 60) + Fraction(1, 10 ** 200)
        return Coef(e, approx - slack, approx + slack)


@functools.lru_cache(maxsize=None)
def coefficients(expr: Expr, bits: int):
    """(c, E coefficient c·(aε + bε²), R coefficient aε + bε² or None, p) at ε = 2^-bits."""
    x = tracked(expr)
    st = x.state
    assert st is not None, f"{expr.name} is invalid: {x.why}"
    e = sympy.Rational(1, 2 ** bits)
    at = {fperr.eps: e}  # a divisor bounded below (rules GL/HL) puts ε in c and a
    c = sympy.sympify(st.c).subs(at)
    rel = (st.a * fperr.eps + st.b * fperr.eps ** 2).subs(at)
    assert st.p.is_integer, f"{expr.name}: non-integer power {st.p}"
    return (Coef.of(c), Coef.of(c * rel), Coef.of(rel) if st.r else None, int(st.p))


class BoundViolation(AssertionError):
    pass


def _le(lo_side: Fraction, coef: Coef, factor: Fraction, tie: Callable[[], bool],
        what: Callable[[], str]):
    """Assert ``lo_side <= coef·factor`` exactly (``lo_side`` is already an upper bound
    of the quantity; ``tie`` decides exactly when the enclosures cannot)."""
    if lo_side <= coef.lo * factor:
        return
    if lo_side > coef.hi * factor or not tie():
        raise BoundViolation(what())


def check_bounds(expr: Expr, fmt: fperr.Context, coords) -> dict:
    """Evaluate ``expr`` in ``fmt`` and exactly, and assert fperr's bounds (magnitude
    |x| <= c·L^p, E, and R when r holds) at ``fmt``'s ε. Returns the numbers involved."""
    coords = [Fraction(q) for q in coords]
    x = tracked(expr)
    c, Ecoef, Rcoef, p = coefficients(expr, fmt.bits)
    L = scale_for(coords)
    Lp = L ** p

    computed = evaluate(expr, fmt, coords)
    if expr.sqrt:
        lo, hi = INTERVAL.enclosure(expr(INTERVAL, coords))
    else:
        lo = hi = expr(EXACT, coords)
    err_hi = max(abs(computed - lo), abs(computed - hi))
    mag_hi = max(abs(lo), abs(hi))
    mag_lo = Fraction(0) if lo <= 0 <= hi else min(abs(lo), abs(hi))

    @functools.lru_cache(maxsize=None)
    def symbolic():
        return sympy.sympify(expr(SYMBOLIC, coords))

    def decide(e: sympy.Expr) -> bool:           # is e >= 0, exactly
        e = sympy.radsimp(sympy.expand(e))
        if e == 0:
            return True
        v = sympy.N(e, 400)
        assert abs(v) > sympy.Float(10) ** -350, f"cannot decide the sign of {e}"
        return bool(v > 0)

    Ls = sympy.Rational(L.numerator, L.denominator)
    comp_s = sympy.Rational(computed.numerator, computed.denominator)

    def info():
        return dict(expr=expr.name, fmt=fmt.format, coords=[str(q) for q in coords], L=str(L),
                    computed=str(computed), exact=(float(lo), float(hi)), state=repr(x))

    # the magnitude claim c·L^p: for a bare quotient (rule G's c = 1*) it is a premise
    # (normalisation), not a claim, so E is only checked where the premise holds.
    premise = True
    if mag_hi > c.lo * Lp:
        ok = mag_lo <= c.hi * Lp and decide(c.expr * Ls ** p - sympy.Abs(symbolic()))
        if not ok:
            if x.inv:
                premise = False
            else:
                raise BoundViolation(f"|x| > c·L^p: {info()}")
    if premise:
        _le(err_hi, Ecoef, Lp,
            lambda: decide(Ecoef.expr * Ls ** p - sympy.Abs(comp_s - symbolic())),
            lambda: f"error exceeds E: err={float(err_hi):.3e} > "
                    f"E={float(Ecoef.hi * Lp):.3e}; {info()}")
    if Rcoef is not None:
        _le(err_hi, Rcoef, mag_lo,
            lambda: decide(Rcoef.expr * sympy.Abs(symbolic())
                           - sympy.Abs(comp_s - symbolic())),
            lambda: f"error exceeds R·|x|: err={float(err_hi):.3e} > "
                    f"R|x|={float(Rcoef.hi * mag_lo):.3e}; {info()}")
    return dict(computed=computed, exact=(lo, hi), L=L, err=err_hi, E=Ecoef.hi * Lp,
                premise=premise)


# ---------------------------------------------------------------------------------
# evaluation guard and input strategy


class OutOfRange(Exception):
    """The evaluation left the format's normal range (the paper assumes no underflow
    and no overflow, section 2); the caller discards such an input."""


def check(expr: Expr, fmt: fperr.Context, coords) -> dict:
    """:func:`check_bounds` with binary32 under- and overflow turned into
    :class:`OutOfRange` (numpy raises for an inexact underflow or an overflow)."""
    try:
        with np.errstate(over="raise", under="raise", divide="raise", invalid="raise"):
            return check_bounds(expr, fmt, coords)
    except FloatingPointError as e:
        if "underflow" in str(e) or "overflow" in str(e):
            raise OutOfRange(str(e)) from e
        raise


#: Per significand width: (lowest base exponent, highest base exponent, spread below it).
#: binary32 is kept well inside its exponent range; 17-bit mpmath has none.
RANGES = {53: (-60, 60, 30), 24: (-8, 8, 12), 17: (-60, 60, 30)}

KINDS = ("random", "max", "pow2", "tiny", "zero")
DERIVED = ("near", "near", "copy", "neg", "scaled")


def _ulp(q: Fraction, bits: int) -> Fraction:
    e = q.numerator.bit_length() - q.denominator.bit_length()
    if Fraction(2) ** e > abs(q):
        e -= 1
    return Fraction(2) ** (e - bits + 1)


@functools.lru_cache(maxsize=None)
def coordinates(fmt: fperr.Context, n: int):
    """``n`` coordinates exactly representable in ``fmt``: random ones, and adversarial
    ones — the largest significand, powers of two, tiny significands, zeros, and values
    derived from earlier ones (a few ulps apart, equal, negated, scaled by a power of two)
    so that differences cancel and magnitudes sit at the bound |x| = L/2."""
    from hypothesis import strategies as st

    bits = fmt.bits
    emin, emax, spread = RANGES[bits]
    top = 2 ** bits - 1
    # strategies built once (a fresh strategy per draw costs hypothesis a lot)
    first_kind, kind = st.sampled_from(KINDS), st.sampled_from(KINDS + DERIVED)
    base_s, off_s = st.integers(emin, emax), st.integers(0, spread)
    sign_s = st.sampled_from((1, -1))
    mant_s, tiny_s = st.integers(-top, top), st.integers(1, 7)
    pow_s, ulps_s, scale_s = st.integers(-spread, bits - 1), st.integers(1, 3), st.integers(-3, 3)
    index_s = [st.integers(0, i - 1) if i else None for i in range(n)]
    two = Fraction(2)

    @st.composite
    def strategy(draw):
        base = draw(base_s)
        out: list[Fraction] = []
        for i in range(n):
            k = draw(kind if out else first_kind)
            if k == "random":
                q = draw(mant_s) * two ** (base - draw(off_s))
            elif k == "max":
                q = draw(sign_s) * top * two ** base
            elif k == "pow2":
                q = draw(sign_s) * two ** (base + draw(pow_s))
            elif k == "tiny":
                q = draw(sign_s) * draw(tiny_s) * two ** (base - draw(off_s))
            elif k == "zero":
                q = Fraction(0)
            else:
                src = out[draw(index_s[i])]
                if k == "copy":
                    q = src
                elif k == "neg":
                    q = -src
                elif k == "scaled":
                    q = src * two ** draw(scale_s)
                else:  # near: a few ulps away
                    step = draw(sign_s) * draw(ulps_s)
                    q = src + step * (_ulp(src, bits) if src else two ** (base - draw(off_s)))
                    if not representable(q, bits):
                        q = src - step * _ulp(src, bits)
            assert representable(q, bits), (k, q)
            out.append(q)
        return out

    return strategy()
