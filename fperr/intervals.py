"""Exact values of shadow execution: a Fraction, or a rigorous rational interval.

Every input coordinate, constant and working value is a dyadic rational, so sums,
differences, products and quotients of exact values stay exact Fractions. A square root
that is not rational (edge-vertex's m = ‖û‖, the ε^(1/2) and ε^(1/4) factors of the
tolerances of sections 4.1/5.1, the √3 in some T+) becomes an :class:`RInterval`: a
*rigorous* enclosure with endpoints of :data:`REFERENCE_PREC` = 300 significant bits,
rounded outward, and everything computed from it stays an interval. Its width, about
2^-290 relative to the magnitudes involved, is negligible against the ε² terms of every
bound (ε² ≥ 2^-106). Measured errors use the interval's far end (an upper bound of the
true error), and comparisons decide only when the enclosure does: :func:`compare` returns
``None`` (undecided) otherwise. ``None`` as an exact value means undefined (0/0 in a lane
the working path had already rejected); the ``exact_*`` operations propagate it.
"""
from __future__ import annotations

import math
from fractions import Fraction

from .exact import floor_log2, rational_sqrt, round_fraction

__all__ = ["REFERENCE_PREC", "RInterval", "compare", "exact_abs", "exact_add", "exact_div",
           "exact_mul", "exact_neg", "exact_sqrt", "exact_sub", "interval_from_float",
           "lower_fraction", "upper_fraction"]

#: Significand bits of the endpoints of the reference intervals (irrational exact values).
REFERENCE_PREC = 300



def _round_dir(q: Fraction, up: bool) -> Fraction:
    """q rounded to REFERENCE_PREC significant bits toward +inf (up) or -inf (down)."""
    n, d = q.numerator, q.denominator
    if n == 0 or (d & (d - 1) == 0 and abs(n).bit_length() <= REFERENCE_PREC):
        return q  # fast path: already short (most endpoints)
    return round_fraction(q, REFERENCE_PREC, "up" if up else "down")


class RInterval:
    """A closed interval [lo, hi] with dyadic rational endpoints of at most
    :data:`REFERENCE_PREC` significant bits, rounded outward after every operation: a
    rigorous enclosure of an irrational exact value."""

    __slots__ = ("lo", "hi")

    def __init__(self, lo: Fraction, hi: Fraction):
        self.lo = _round_dir(lo, False)
        self.hi = _round_dir(hi, True)

    @staticmethod
    def of(q):
        return q if type(q) is RInterval else RInterval(q, q)

    def __add__(self, o):
        o = RInterval.of(o)
        return RInterval(self.lo + o.lo, self.hi + o.hi)

    __radd__ = __add__

    def __sub__(self, o):
        o = RInterval.of(o)
        return RInterval(self.lo - o.hi, self.hi - o.lo)

    def __rsub__(self, o):
        return RInterval.of(o) - self

    def __mul__(self, o):
        o = RInterval.of(o)
        p = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi)
        return RInterval(min(p), max(p))

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = RInterval.of(o)
        if o.lo <= 0 <= o.hi:
            raise ZeroDivisionError("interval divisor contains zero")
        return self * RInterval(_round_dir(1 / o.hi, False), _round_dir(1 / o.lo, True))

    def __rtruediv__(self, o):
        return RInterval.of(o) / self

    def __neg__(self):
        return RInterval(-self.hi, -self.lo)

    def __abs__(self):
        if self.lo >= 0:
            return self
        if self.hi <= 0:
            return -self
        return RInterval(Fraction(0), max(-self.lo, self.hi))

    def sqrt(self):
        lo = self.lo if self.lo > 0 else Fraction(0)  # an enclosure of x >= 0 may dip below 0
        if self.hi < 0:
            raise ValueError("square root of a negative exact value")
        return RInterval(_sqrt_bound(lo, False), _sqrt_bound(self.hi, True))

    def mid(self) -> Fraction:
        return (self.lo + self.hi) / 2

    def __float__(self):
        return float(self.mid())

    def __repr__(self):
        return f"RInterval({float(self.lo)!r}, width 2^{_log2w(self)})"


def _log2w(iv):
    w = iv.hi - iv.lo
    return "-inf" if w == 0 else floor_log2(w)


def _sqrt_bound(q: Fraction, up: bool) -> Fraction:
    """A dyadic bound of √q (q ≥ 0) with about REFERENCE_PREC + 8 significant bits."""
    n, d = q.numerator, q.denominator
    if n == 0:
        return Fraction(0)
    # √(n/d) = √(n·d)/d; scale by 4^k so the integer root has enough bits
    nd = n * d
    k = max(0, (REFERENCE_PREC + 8) - nd.bit_length() // 2)
    r = math.isqrt(nd << (2 * k))
    if up and r * r != (nd << (2 * k)):
        r += 1
    return Fraction(r, d << k)


def exact_add(a, b):
    if a is None or b is None:
        return None
    return a + b if type(a) is Fraction else RInterval.of(a) + b


def exact_sub(a, b):
    if a is None or b is None:
        return None
    return a - b if type(a) is Fraction else RInterval.of(a) - b


def exact_mul(a, b):
    if a is None or b is None:
        return None
    return a * b if type(a) is Fraction else RInterval.of(a) * b


def exact_div(a, b):
    if a is None or b is None:
        return None
    try:
        return a / b if type(a) is Fraction else RInterval.of(a) / b
    except ZeroDivisionError:
        return None


def exact_neg(a):
    return None if a is None else -a


def exact_abs(a):
    return None if a is None else abs(a)


def exact_sqrt(q):
    """√q: a Fraction when q is the square of a rational, else a rigorous interval."""
    if q is None:
        return None
    if type(q) is Fraction:
        root = rational_sqrt(q)
        if root is not None:
            return root
        return RInterval(_sqrt_bound(q, False), _sqrt_bound(q, True))
    return q.sqrt()


def compare(a, b):
    """Exact comparison: -1, 0 or 1, or ``None`` when an interval cannot decide."""
    if type(a) is Fraction and type(b) is Fraction:
        return (a > b) - (a < b)
    if a is None or b is None:
        return None
    d = RInterval.of(a) - b
    if d.lo > 0:
        return 1
    if d.hi < 0:
        return -1
    if d.lo == 0 and d.hi == 0:
        return 0
    return None


def upper_fraction(a) -> Fraction | None:
    """|a| as a Fraction, or an upper bound of it for an interval (its far end)."""
    if a is None:
        return None
    if type(a) is Fraction:
        return abs(a)
    return abs(a).hi


def lower_fraction(a) -> Fraction | None:
    """|a| as a Fraction, or a lower bound of it for an interval (its near end)."""
    if a is None:
        return None
    if type(a) is Fraction:
        return abs(a)
    return abs(a).lo


def interval_from_float(v, rel=Fraction(1, 2**280)) -> RInterval:
    """A rigorous interval around a high-precision decimal approximation ``v`` of a real
    number (e.g. ``sympy.N(expr, 130)``) known to be accurate to better than ``rel``."""
    q = Fraction(str(v)) if not isinstance(v, Fraction) else v
    delta = abs(q) * rel
    return RInterval(q - delta, q + delta)
