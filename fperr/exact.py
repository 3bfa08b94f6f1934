"""Exact values and exact rounding: the one place numbers become Fractions and back.

* :func:`to_fraction` — the exact rational value of any finite real number the library
  handles (int, Fraction, float, numpy scalar, mpmath mpf of any context, decimal
  string, sympy Rational);
* :func:`round_fraction` — a rational rounded to a ``bits``-bit significand in one of four
  rounding modes (unbounded exponent; the contexts add their formats' exponent ranges);
* :func:`ulp` — the spacing of ``bits``-bit numbers at a value;
* exactness of constants (rule J): which numbers every format the analysis covers holds.

The analysis is format-agnostic: it holds for every binary format with unit roundoff
ε ≤ 1e-5, i.e. a significand of at least 17 bits (2^-17 ≈ 7.6e-6 ≤ 1e-5 < 2^-16).
A constant is therefore *exact* when it is a dyadic rational whose odd part fits in
17 bits; anything else (0.1, 1/3, π, a 53-bit binary64 value) is rounded once when
it enters the computation, and rule J then carries a relative error of one ε.
"""
from __future__ import annotations

import math
from fractions import Fraction
from numbers import Rational

#: Smallest significand (bits) of a format with unit roundoff ≤ 1e-5.
MIN_SIGNIFICAND_BITS = 17

#: Rounding modes of :func:`round_fraction` (IEEE 754 names: roundTiesToEven,
#: roundTowardPositive, roundTowardNegative, roundTowardZero).
ROUNDING = ("nearest", "up", "down", "zero")


def to_fraction(x) -> Fraction:
    """The exact value of a finite real number.

    Accepts int, Fraction (and other :class:`numbers.Rational`), float, numpy scalars,
    mpmath ``mpf`` (of any mpmath context), decimal strings ("0.1" is 1/10) and sympy
    Rationals. Raises TypeError for booleans and anything else (a sympy irrational, a
    Tracked quantity), ValueError for inf/nan.
    """
    if type(x) is Fraction:
        return x
    if isinstance(x, bool):
        raise TypeError("a boolean is not a number")
    if isinstance(x, int):
        return Fraction(x)
    mpf = getattr(x, "_mpf_", None)
    if mpf is not None:
        return _mpf_fraction(mpf)
    if isinstance(x, Rational):
        return Fraction(int(x.numerator), int(x.denominator))
    if isinstance(x, str):
        return Fraction(x)
    if hasattr(x, "is_Rational") and not isinstance(x, float):  # sympy numbers
        if x.is_Rational:
            return Fraction(int(x.p), int(x.q))
        raise TypeError(f"{x} is not rational: no exact Fraction value")
    try:
        f = float(x) if not isinstance(x, float) else x
    except (TypeError, ValueError):
        raise TypeError(f"no exact value for {x!r}") from None
    if not math.isfinite(f):
        raise ValueError(f"{x!r} is not finite")
    if hasattr(x, "item"):  # numpy scalar: its value is float(x) (float16/32/64)
        return Fraction(f)
    if isinstance(x, float):
        return Fraction(x)
    raise TypeError(f"no exact value for {x!r}")


def _mpf_fraction(m) -> Fraction:
    """The exact value of a raw mpmath number (sign, man, exp, bc)."""
    sign, man, exp, _ = m
    if not man:
        if exp:  # inf / nan are (0, 0, special, -1)
            raise ValueError("mpmath value is not finite")
        return Fraction(0)
    q = Fraction(int(man) << exp) if exp >= 0 else Fraction(int(man), 1 << -exp)
    return -q if sign else q


def floor_log2(q: Fraction) -> int:
    """⌊log2 |q|⌋ exactly (q ≠ 0)."""
    n, d = abs(q.numerator), q.denominator
    e = n.bit_length() - d.bit_length()
    if (n << max(-e, 0)) < (d << max(e, 0)):
        e -= 1
    return e


def round_fraction(q, bits: int, rounding: str = "nearest", min_exp: int | None = None
                   ) -> Fraction:
    """``q`` rounded to a number with a ``bits``-bit significand.

    ``rounding``: ``"nearest"`` (ties to even), ``"up"`` (toward +∞), ``"down"``
    (toward −∞), ``"zero"`` (toward zero). ``min_exp``: the exponent of the smallest
    normal number (binary64: −1022); below it the spacing stays 2^(min_exp − bits + 1)
    (gradual underflow). None: unbounded exponent. Overflow is the caller's business.
    """
    if rounding not in ROUNDING:
        raise ValueError(f"rounding must be one of {', '.join(ROUNDING)}, not {rounding!r}")
    q = Fraction(q)
    n, d = q.numerator, q.denominator
    if n == 0:
        return q
    neg = n < 0
    n = -n if neg else n
    e = floor_log2(q)
    if min_exp is not None and e < min_exp:
        e = min_exp
    shift = e - bits + 1  # the spacing is 2^shift
    if shift >= 0:
        den = d << shift
        k, r = divmod(n, den)
    else:
        den = d
        k, r = divmod(n << -shift, d)
    if r:
        if rounding == "nearest":
            k += 2 * r > den or (2 * r == den and k & 1)
        elif rounding == "zero":
            pass
        elif (rounding == "up") != neg:  # the magnitude is rounded up
            k += 1
    v = Fraction(k << shift) if shift >= 0 else Fraction(k, 1 << -shift)
    return -v if neg else v


def rational_sqrt(q: Fraction) -> Fraction | None:
    """√q exactly when it is rational (numerator and denominator perfect squares), else
    None. Raises ValueError for q < 0."""
    if q < 0:
        raise ValueError(f"square root of a negative value {q}")
    rn, rd = math.isqrt(q.numerator), math.isqrt(q.denominator)
    return Fraction(rn, rd) if rn * rn == q.numerator and rd * rd == q.denominator else None


def ulp(q, bits: int) -> Fraction:
    """The spacing of ``bits``-bit numbers at ``q`` (q ≠ 0; unbounded exponent)."""
    k = floor_log2(Fraction(q)) - bits + 1
    return Fraction(1 << k) if k >= 0 else Fraction(1, 1 << -k)


def significand_bits(q: Fraction) -> int | None:
    """Bits of the odd part of a dyadic rational ``q``; None when ``q`` is not dyadic."""
    den = q.denominator
    if den & (den - 1):
        return None
    num = abs(q.numerator)
    if num == 0:
        return 0
    while num % 2 == 0:
        num //= 2
    return num.bit_length()


def is_exact(q: Fraction, bits: int = MIN_SIGNIFICAND_BITS) -> bool:
    """True when ``q`` is representable with a ``bits``-bit significand (no exponent limit)."""
    nb = significand_bits(q)
    return nb is not None and nb <= bits
