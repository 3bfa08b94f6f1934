"""First-order attainable error of every named quantity, on many inputs at once
(:mod:`proofs.audit`, the worst-case search of :mod:`proofs.audit.worst_case`).

Section 2's standard model writes each rounded operation as F[y_k] = y_k + e_k with
|e_k| ≤ ½ulp(y_k). To first order in the e_k a quantity x computed from them is
x + Σ_k (∂x/∂y_k)·e_k, so the largest error rounding could produce on a given input is
the *first-order attainable error*

    A(x) = Σ_k |∂x/∂y_k| · ½ulp(y_k),

reached when every e_k is at its largest with the sign of ∂x/∂y_k. :class:`Lin` carries,
for each lane (one input per lane), the value of an expression (float64, close to the
exact value) and the vector (∂x/∂y_k · ½ulp(y_k))_k in forward mode; every rounded
operation of the predicate adds one component. :class:`FirstOrderContext` runs the
*same* predicate source on Lin numbers with numpy lanes (as :class:`fperr.NumpyContext`:
a rejected lane leaves the path), so a quantity has a value only on the lanes that reach
it. ulp is the working format's (``bits`` significant bits), subnormals ignored.

The values are the working values (binary64: numpy's float64 operations are the real
ones; binary32, mp17: the float64 result of the working operands, rounded to the
format), so an operation whose result is representable is seen to be exact and adds 0
(error-free transformations TwoSum / TwoProduct in binary64; a division or a square
root always counts): a configuration made of short significands, where most operations
are exact, does not look worse than it can be. A is an estimate of what rounding *can*
do near an input, not a bound: it ignores second-order terms.
The derived bounds (rules A–K) bound the same first-order sum with magnitude bounds, so
max A over inputs ≤ E to first order: A separates the slack of the rules (E/max A) from
that of the search (max A / worst measured error).
"""
from __future__ import annotations

from itertools import count

import numpy as np

from fperr.contexts import NumpyContext

from .worst_inputs import round_bits

__all__ = ["FirstOrderContext", "LaneContext", "Lin", "attainable"]

_ids = count()


def half_ulp(y: np.ndarray, bits: int) -> np.ndarray:
    """½ulp(y) in a binary format with ``bits`` significant bits (normal range)."""
    _, e = np.frexp(y)              # |y| = m·2^e, m in [0.5, 1)
    return np.where(y == 0, 0.0, np.ldexp(1.0, e - 1 - bits))


class Lin:
    """Value and first-order rounding sensitivities of an expression (see module doc)."""

    __slots__ = ("v", "d", "bits")
    __array_priority__ = 1000

    def __init__(self, v, d: dict, bits: int):
        self.v, self.d, self.bits = v, d, bits

    def _lift(self, o):
        if isinstance(o, Lin):
            return o
        return Lin(np.asarray(o, dtype=np.float64), {}, self.bits)

    def _round(self, v, d: dict, err=None) -> "Lin":
        """The result of a rounded operation: one more error term ½ulp(y), 0 on the
        lanes where the operation is exact. ``v``: the float64 result of the working
        operands; ``err``: its rounding error when v is binary64 (None: unknown)."""
        if self.bits < 53:          # v is exact or nearly: the working value rounds it
            w = round_bits(v, self.bits)
            exact = w == v
        else:
            w, exact = v, (err == 0) if err is not None else False
        d[next(_ids)] = np.where(exact, 0.0, half_ulp(w, self.bits))
        return Lin(w, d, self.bits)

    @staticmethod
    def _comb(a: dict, ca, b: dict, cb) -> dict:
        out = {k: ca * x for k, x in a.items()} if ca is not None else dict(a)
        for k, x in b.items():
            t = x if cb is None else cb * x
            out[k] = out[k] + t if k in out else t
        return out

    def __add__(self, o):
        o = self._lift(o)
        v = self.v + o.v
        return self._round(v, self._comb(self.d, None, o.d, None), _two_sum_err(self.v, o.v, v))

    def __radd__(self, o):
        return self._lift(o) + self

    def __sub__(self, o):
        o = self._lift(o)
        v = self.v - o.v
        return self._round(v, self._comb(self.d, None, o.d, -1.0),
                           _two_sum_err(self.v, -o.v, v))

    def __rsub__(self, o):
        return self._lift(o) - self

    def __mul__(self, o):
        o = self._lift(o)
        v = self.v * o.v
        return self._round(v, self._comb(self.d, o.v, o.d, self.v),
                           _two_prod_err(self.v, o.v, v))

    def __rmul__(self, o):
        return self._lift(o) * self

    def __truediv__(self, o):
        o = self._lift(o)
        q = self.v / o.v
        return self._round(q, self._comb(self.d, 1.0 / o.v, o.d, -q / o.v))

    def __rtruediv__(self, o):
        return self._lift(o) / self

    def __neg__(self):
        return Lin(-self.v, {k: -x for k, x in self.d.items()}, self.bits)

    def __abs__(self):
        s = np.where(self.v < 0, -1.0, 1.0)
        return Lin(np.abs(self.v), {k: s * x for k, x in self.d.items()}, self.bits)

    def sqrt(self) -> "Lin":
        r = np.sqrt(self.v)
        c = np.where(r > 0, 0.5 / np.where(r > 0, r, 1.0), 0.0)
        return self._round(r, {k: c * x for k, x in self.d.items()})

    def __le__(self, o): return self.v <= self._lift(o).v
    def __lt__(self, o): return self.v < self._lift(o).v
    def __ge__(self, o): return self.v >= self._lift(o).v
    def __gt__(self, o): return self.v > self._lift(o).v

    def attainable(self) -> np.ndarray:
        """A = Σ_k |∂x/∂y_k|·½ulp(y_k), per lane."""
        out = np.zeros(np.shape(self.v))
        for x in self.d.values():
            out += np.abs(x)
        return out


def _two_sum_err(a, b, s):
    """a + b − s exactly, s = fl(a + b) in binary64 (Knuth's TwoSum)."""
    bb = s - a
    return (a - (s - bb)) + (b - bb)


def _split(a):
    c = 134217729.0 * a           # 2^27 + 1: Veltkamp's splitting
    hi = c - (c - a)
    return hi, a - hi


def _two_prod_err(a, b, p):
    """a·b − p exactly, p = fl(a·b) in binary64 (Dekker's TwoProduct; no overflow)."""
    ah, al = _split(a)
    bh, bl = _split(b)
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl


class LaneContext(NumpyContext):
    """A predicate run on lanes of number-like objects with ``sqrt()`` (as
    :class:`fperr.NumpyContext`: a rejected lane leaves the path); subclasses record the
    named quantities in ``quantities``."""

    def __init__(self, lanes: int):
        super().__init__(np.float64)
        self.active = np.ones(lanes, dtype=bool)
        self.quantities: dict = {}

    def sqrt(self, x):
        return x.sqrt()

    def const(self, x):
        return float(x)

    def hit(self, weights):
        return self.active.copy(), ()

    def miss(self):
        return np.zeros_like(self.active), ()


class FirstOrderContext(LaneContext):
    """Runs a predicate on :class:`Lin` numbers in lanes; records each named quantity's
    attainable error, the lanes that reached it and its value (``quantities``: name ->
    (A, mask, value))."""

    def __init__(self, bits: int, lanes: int):
        super().__init__(lanes)
        self.bits = bits

    def name(self, label, x):
        if isinstance(x, Lin):
            self.quantities[label] = (x.attainable(), self.active.copy(), x.v)
        return x


class _Tol:
    """Tolerances as per-lane float arrays (attribute access as predicates expect)."""

    def __init__(self, values: dict):
        self.__dict__.update(values)


def attainable(pred, X: np.ndarray, bits: int, tol_values: dict) -> dict:
    """Run ``pred`` on the inputs ``X`` (lanes × points × dim, float64, representable in
    the format) with per-lane tolerances ``tol_values`` (name -> array); returns
    name -> (A, reached mask, value) for every named quantity reached by some lane."""
    n, k, d = X.shape
    ctx = FirstOrderContext(bits, n)
    pts = [tuple(Lin(X[:, i, a].copy(), {}, bits) for a in range(d)) for i in range(k)]
    with np.errstate(all="ignore"):
        pred.fn(ctx, *pts, _Tol(tol_values))
    return ctx.quantities
