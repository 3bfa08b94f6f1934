"""Approximate measured error on many inputs at once: the guide of the worst-case
search's climb (:mod:`proofs.audit.worst_case`); every figure the audit *reports* comes
from the exact shadow run instead (:func:`proofs.audit.shadow_run.run_shadow`).

:class:`Pair` holds per lane the working value ``w`` — computed exactly as the real code
computes it: binary64 and binary32 by numpy's IEEE operations, mp17 by float64
operations rounded to 17 bits (exact for products and for sums of nearby magnitudes; a
rare double rounding only blurs the guide) — and a reference ``r`` in a wider format
(x87 extended, 64 bits, for binary64; float64 otherwise). Its error on a quantity of
magnitude up to c·L^p is about c·2^-64·L^p, i.e. ~2^-11·c of the unit ε·L^p of
binary64: enough to rank candidates. :class:`FastContext` follows the *working*
decisions (as the real code and the shadow run do), lane by lane.
"""
from __future__ import annotations

import numpy as np

from .first_order import LaneContext, _Tol
from .worst_inputs import round_bits

__all__ = ["FastContext", "Pair", "fast_errors"]

_REF = {53: np.longdouble, 24: np.float64}


class Pair:
    """Working value and wide reference, per lane (see module docstring)."""

    __slots__ = ("w", "r", "bits")
    __array_priority__ = 1000

    def __init__(self, w, r, bits):
        self.w, self.r, self.bits = w, r, bits

    def _lift(self, o):
        if isinstance(o, Pair):
            return o
        return Pair(self._wt(o), np.asarray(o, dtype=_REF.get(self.bits, np.float64)),
                    self.bits)

    def _wt(self, v):
        return np.asarray(v, dtype=np.float32 if self.bits == 24 else np.float64)

    def _rnd(self, w):
        return w if self.bits in _REF else round_bits(w, self.bits)

    def _op(self, o, f, reflected=False):
        o = self._lift(o)
        a, b = (o, self) if reflected else (self, o)
        return Pair(self._rnd(f(a.w, b.w)), f(a.r, b.r), self.bits)

    def __add__(self, o): return self._op(o, np.add)
    def __radd__(self, o): return self._op(o, np.add, True)
    def __sub__(self, o): return self._op(o, np.subtract)
    def __rsub__(self, o): return self._op(o, np.subtract, True)
    def __mul__(self, o): return self._op(o, np.multiply)
    def __rmul__(self, o): return self._op(o, np.multiply, True)
    def __truediv__(self, o): return self._op(o, np.divide)
    def __rtruediv__(self, o): return self._op(o, np.divide, True)
    def __neg__(self): return Pair(-self.w, -self.r, self.bits)
    def __abs__(self): return Pair(np.abs(self.w), np.abs(self.r), self.bits)

    def sqrt(self) -> "Pair":
        return Pair(self._rnd(np.sqrt(self.w)), np.sqrt(self.r), self.bits)

    # the working decisions, as the real code takes them
    def __le__(self, o): return self.w <= self._lift(o).w
    def __lt__(self, o): return self.w < self._lift(o).w
    def __ge__(self, o): return self.w >= self._lift(o).w
    def __gt__(self, o): return self.w > self._lift(o).w


class FastContext(LaneContext):
    """Runs a predicate on :class:`Pair` lanes; ``quantities``: name -> (|w − r|, mask)."""

    def name(self, label, x):
        if isinstance(x, Pair):
            err = np.abs(x.w.astype(x.r.dtype) - x.r).astype(np.float64)
            self.quantities[label] = (err, self.active.copy())
        return x


def fast_errors(pred, X: np.ndarray, bits: int, tol_values: dict) -> dict:
    """|F[x] − x| (approximately) of every named quantity on the lanes X (lanes × points
    × dim), following the working path with the working tolerances ``tol_values`` (name
    -> per-lane array); returns name -> (error, reached mask)."""
    n, k, d = X.shape
    ctx = FastContext(n)
    ref = _REF.get(bits, np.float64)
    w = X.astype(np.float32) if bits == 24 else X
    pts = [tuple(Pair(w[:, i, a].copy(), X[:, i, a].astype(ref), bits) for a in range(d))
           for i in range(k)]
    tol = {name: Pair(np.asarray(v, dtype=w.dtype), np.asarray(v, dtype=ref), bits)
           for name, v in tol_values.items()}
    with np.errstate(all="ignore"):
        pred.fn(ctx, *pts, _Tol(tol))
    return ctx.quantities
