"""Exactness of constants (rule J): which numbers every format the analysis covers can hold.

The analysis is format-agnostic: it holds for every binary format with unit roundoff
ε ≤ 1e-5, i.e. a significand of at least 17 bits (2^-17 ≈ 7.6e-6 ≤ 1e-5 < 2^-16).
A constant is therefore *exact* when it is a dyadic rational whose odd part fits in
17 bits; anything else (0.1, 1/3, π, a 53-bit binary64 value) is rounded once when
it enters the computation, and rule J then carries a relative error of one ε.
"""
from __future__ import annotations

from fractions import Fraction
from numbers import Rational

import sympy

#: Smallest significand (bits) of a format with unit roundoff ≤ 1e-5.
MIN_SIGNIFICAND_BITS = 17


def to_fraction(x) -> Fraction | None:
    """The exact rational value of ``x``, or None when it is not rational."""
    if isinstance(x, bool):
        raise TypeError("a boolean is not a number")
    if isinstance(x, (int, Fraction)):
        return Fraction(x)
    if isinstance(x, float):
        if x != x or x in (float("inf"), float("-inf")):
            raise ValueError(f"constant {x!r} is not finite")
        return Fraction(x)
    if isinstance(x, Rational):
        return Fraction(x.numerator, x.denominator)
    if isinstance(x, str):
        return Fraction(x)
    if isinstance(x, sympy.Basic):
        x = sympy.nsimplify(x) if x.is_Float else x
        if x.is_Rational:
            return Fraction(int(x.p), int(x.q))
        return None
    try:  # numpy scalars, mpmath mpf
        return Fraction(float(x)) if float(x) == x else None
    except (TypeError, ValueError):
        return None


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
