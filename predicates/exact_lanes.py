"""The exact path of a filtered predicate, many lanes at once: dyadic integers.

Every binary64 or binary32 number is m·2^s with integer m and s, and +, −, × of such
numbers are again such numbers, exactly. So a predicate whose source uses only +, −, ×,
comparisons and dyadic constants (the classic determinants, and most sign tests) is
evaluated exactly by integer arithmetic: one value of the run is an array of Python
integers M (numpy object array, one per lane) and one exponent s shared by the lanes;
a sum shifts the operand with the larger exponent left by the difference, a product
multiplies the integers and adds the exponents. No rounding, no gcd (what makes
``fractions.Fraction`` slow), and the source runs once for all the lanes (branches
become lane masks, as in :class:`fperr.NumpyContext`).

A quotient, a square root or a constant that is not dyadic (1/3) raises
:class:`NotDyadic`; :mod:`predicates.filtered` then decides those lanes with Fractions,
one lane at a time (exact for every +, −, ×, ÷). Both are the same source run on exact
numbers, so their answers are the exact answer (tests: ``tests/test_predicates/
test_filtered.py`` against independent determinants, and ``test_exact_lanes.py``).
"""
from __future__ import annotations

import operator
from fractions import Fraction

import numpy as np

import fperr

__all__ = ["DyadicLanes", "ExactLanesContext", "NotDyadic", "lanes_of"]


class NotDyadic(ArithmeticError):
    """The run needs a number that is not m·2^s (a quotient, an irrational root)."""


def _dyadic(q) -> tuple[int, int]:
    """(m, s) with q = m·2^s, for an int, a float or a Fraction with a power-of-two
    denominator."""
    q = fperr.to_fraction(q)
    d = q.denominator
    if d & (d - 1):
        raise NotDyadic(f"{q} is not a dyadic rational (m·2^s)")
    return q.numerator, -(d.bit_length() - 1)


class DyadicLanes:
    """Exact values M·2^s per lane: ``m`` an object array of Python ints (or one int for
    every lane), ``s`` one exponent for all lanes (module docstring)."""

    __slots__ = ("m", "s")

    def __init__(self, m, s: int):
        self.m, self.s = m, s

    @staticmethod
    def of(x) -> DyadicLanes:
        if isinstance(x, DyadicLanes):
            return x
        if isinstance(x, np.generic):
            x = x.item()
        return DyadicLanes(*_dyadic(x))

    def _aligned(self, o):
        o = DyadicLanes.of(o)
        if self.s == o.s:
            return self.m, o.m, self.s
        if self.s > o.s:
            return self.m << (self.s - o.s), o.m, o.s
        return self.m, o.m << (o.s - self.s), self.s

    def _sum(self, o, op, reflected=False):
        a, b, s = self._aligned(o)
        return DyadicLanes(op(b, a) if reflected else op(a, b), s)

    def __add__(self, o):
        return self._sum(o, operator.add)

    def __radd__(self, o):
        return self._sum(o, operator.add, True)

    def __sub__(self, o):
        return self._sum(o, operator.sub)

    def __rsub__(self, o):
        return self._sum(o, operator.sub, True)

    def __mul__(self, o):
        o = DyadicLanes.of(o)
        return DyadicLanes(self.m * o.m, self.s + o.s)

    __rmul__ = __mul__  # the product of integers commutes; nothing is rounded

    def __pow__(self, k: int):
        if not isinstance(k, int) or k < 0:
            raise NotDyadic(f"x**{k!r}")
        return DyadicLanes(self.m ** k, self.s * k)

    def __truediv__(self, o):
        raise NotDyadic("a quotient")

    __rtruediv__ = __truediv__

    def __neg__(self):
        return DyadicLanes(-self.m, self.s)

    def __pos__(self):
        return self

    def __abs__(self):
        return DyadicLanes(abs(self.m), self.s)

    def _cmp(self, o, op):
        a, b, _ = self._aligned(o)
        return np.asarray(op(a, b), dtype=bool)

    def __lt__(self, o): return self._cmp(o, operator.lt)
    def __le__(self, o): return self._cmp(o, operator.le)
    def __gt__(self, o): return self._cmp(o, operator.gt)
    def __ge__(self, o): return self._cmp(o, operator.ge)

    def __bool__(self):
        raise TypeError("a predicate may not branch on a number: use the context")

    def fraction(self, lane: int | None = None) -> Fraction:
        """The exact value (of one lane when ``m`` is an array)."""
        m = self.m if lane is None or not isinstance(self.m, np.ndarray) else self.m[lane]
        return Fraction(int(m)) * Fraction(2) ** self.s


def lanes_of(column: np.ndarray) -> DyadicLanes:
    """A float64/float32 column as exact dyadic lanes: x = mant·2^(e−53) with an integer
    53-bit mant (``frexp``, exact for subnormals too), all shifted to the column's
    smallest exponent."""
    x = np.asarray(column, dtype=np.float64)  # exact for float32
    f, e = np.frexp(x)
    mant = np.ldexp(f, 53).astype(np.int64)  # exact: |f·2^53| < 2^53
    e = e.astype(np.int64) - 53
    nz = mant != 0
    s = int(e[nz].min()) if nz.any() else 0
    shift = np.where(nz, e - s, 0)
    return DyadicLanes(mant.astype(object) << shift.astype(object), s)


class ExactLanesContext(fperr.Context):
    """Exact arithmetic on lanes of :class:`DyadicLanes` (ε = 0): branches become lane
    masks as in :class:`fperr.NumpyContext`; hit/miss return the answer per lane."""

    format = "exact-lanes"
    eps = Fraction(0)
    vectorised = True

    def __init__(self, lanes: int = 0):
        self.active = np.ones(lanes, dtype=bool)

    def fresh(self, n_weights, lanes=None):
        c = ExactLanesContext(lanes or 0)
        c.n_weights = n_weights
        return c

    def const(self, x):
        return DyadicLanes.of(x)

    def sqrt(self, x):
        raise NotDyadic("a square root")

    def from_fraction(self, q, rounding: str = "nearest"):
        return DyadicLanes.of(q)

    def to_fraction(self, x) -> Fraction:
        if not isinstance(x, DyadicLanes) or isinstance(x.m, np.ndarray):
            raise TypeError(f"one exact dyadic value expected, got {x!r}")
        return x.fraction()

    # lane masks exactly as the numpy batches keep them
    reject, any = fperr.NumpyContext.reject, fperr.NumpyContext.any
    same_sign, differ_sign = fperr.NumpyContext.same_sign, fperr.NumpyContext.differ_sign

    def hit(self, weights):
        return self.active.copy(), None

    def miss(self):
        return np.zeros(self.active.shape, dtype=bool), None
