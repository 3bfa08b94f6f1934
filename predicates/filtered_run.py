"""The native run of a filtered predicate: lanes of numbers and a three-valued context.

:class:`Lanes` wraps a numpy array so that a comparison keeps its operands (a numpy
comparison would keep only the booleans); :class:`FilterContext` decides each recorded
comparison per lane as *surely true*, *surely false* or *undecided* against the derived
bound of that comparison (the i-th comparison the context sees is the i-th check of the
instrumented run: both run the same source straight through, in the same order). The
proof that a sure decision is the exact one is in :mod:`predicates.filtered`.
"""
from __future__ import annotations

import numpy as np

import fperr


def _value(x):
    return x.v if isinstance(x, Lanes) else x


class Lanes:
    """A numpy array of lane values inside a filtered run; arithmetic is numpy's, in
    the order written (nothing reordered or fused). In a careful run every product and
    quotient flags the lanes where it underflowed, and every result the lanes where it
    is not finite (:meth:`FilterContext.flag`)."""

    __slots__ = ("v", "ctx")
    __array_ufunc__ = None  # numpy scalars defer to our reflected operators

    def __init__(self, v, ctx):
        self.v, self.ctx = v, ctx

    def _new(self, r, a=None, b=None, product=False):
        if self.ctx.careful:
            self.ctx.flag(r, a, b, product)
        return Lanes(r, self.ctx)

    def __add__(self, o):
        return self._new(self.v + _value(o))

    def __radd__(self, o):
        return self._new(_value(o) + self.v)

    def __sub__(self, o):
        return self._new(self.v - _value(o))

    def __rsub__(self, o):
        return self._new(_value(o) - self.v)

    def __mul__(self, o):
        b = _value(o)
        return self._new(self.v * b, self.v, b, True)

    def __rmul__(self, o):
        a = _value(o)
        return self._new(a * self.v, a, self.v, True)

    def __truediv__(self, o):
        b = _value(o)
        return self._new(self.v / b, self.v, None, True)

    def __rtruediv__(self, o):
        a = _value(o)
        return self._new(a / self.v, a, None, True)

    def __pow__(self, k):
        if k != 2:
            raise TypeError("a filtered predicate writes x*x, not x**k (k ≠ 2)")
        return self * self

    def __neg__(self):
        return Lanes(-self.v, self.ctx)

    def __abs__(self):
        return Lanes(np.abs(self.v), self.ctx)

    def __pos__(self):
        return self

    def _cmp(self, o, rel):
        if isinstance(o, RunningLanes):
            return o._cmp(self, _reflect(rel))
        return Compare(self.v, _value(o), rel)

    def __le__(self, o): return self._cmp(o, "<=")
    def __lt__(self, o): return self._cmp(o, "<")
    def __ge__(self, o): return self._cmp(o, ">=")
    def __gt__(self, o): return self._cmp(o, ">")

    def __bool__(self):
        raise TypeError("a predicate may not branch on a number: use the context")


def _as_lanes(x, ctx):
    return x if isinstance(x, Lanes) else Lanes(x, ctx)


def _error(x):
    """The running-error bound of an operand (0: an exact input or constant)."""
    return getattr(x, "e", 0.0) if isinstance(x, Lanes) else 0.0


def _up(x):
    """One ulp up: ≥ the exact value of the operation just rounded to nearest (binary64,
    subnormals included)."""
    return np.nextafter(x, np.inf)


class RunningLanes(Lanes):
    """Lanes with a per-lane running error bound ``e`` ≥ |exact − computed| (the
    permanent-style second stage, :mod:`predicates.filtered`): with ẑ = fl(x̂ ∘ ŷ) and
    |fl(s) − s| ≤ u·|fl(s)| (round to nearest, no underflow: checked),
    e(x ± y) = e_x + e_y + u|ẑ| and e(x·y) = |x̂|e_y + |ŷ|e_x + e_x·e_y + u|ẑ|, each
    evaluated in binary64 with every operation rounded one ulp up (docs/proofs.md,
    "Filtered predicates"). Division and square
    roots have no such bound here: e = ∞ (the lane goes to the exact path)."""

    __slots__ = ("e",)

    def __init__(self, v, ctx, e=0.0):
        super().__init__(v, ctx)
        self.e = e

    def _round(self, r):
        # u·|r| is exact unless it falls below the normal range (|r| near the smallest
        # normal of binary64), where rounding to nearest could drop it: one ulp up
        return _up(self.ctx.u * np.abs(np.asarray(r, dtype=np.float64)))

    def _sum(self, r, o):
        e = _up(_up(self.e + _error(o)) + self._round(r))
        return e

    def _new(self, r, a=None, b=None, product=False):
        self.ctx.flag(r, a, b, product)
        return r

    def __add__(self, o):
        r = self._new(self.v + _value(o))
        return RunningLanes(r, self.ctx, self._sum(r, o))

    __radd__ = __add__

    def __sub__(self, o):
        r = self._new(self.v - _value(o))
        return RunningLanes(r, self.ctx, self._sum(r, o))

    def __rsub__(self, o):
        r = self._new(_value(o) - self.v)
        return RunningLanes(r, self.ctx, self._sum(r, o))

    def __mul__(self, o):
        b, eb = _value(o), _error(o)
        r = self._new(self.v * b, self.v, b, True)
        xa = np.abs(np.asarray(self.v, dtype=np.float64))
        xb = np.abs(np.asarray(b, dtype=np.float64))
        e = _up(_up(_up(xa * eb) + _up(xb * self.e)) + _up(self.e * eb))
        return RunningLanes(r, self.ctx, _up(e + self._round(r)))

    __rmul__ = __mul__

    def _no_bound(self, r):
        return RunningLanes(r, self.ctx, np.inf)

    def __truediv__(self, o):
        return self._no_bound(self._new(self.v / _value(o), self.v, None, True))

    def __rtruediv__(self, o):
        return self._no_bound(self._new(_value(o) / self.v, _value(o), None, True))

    def __neg__(self):
        return RunningLanes(-self.v, self.ctx, self.e)

    def __abs__(self):
        return RunningLanes(np.abs(self.v), self.ctx, self.e)

    def _cmp(self, o, rel):
        return Compare(self.v, _value(o), rel, _up(self.e + _error(o)))


def _reflect(rel):
    return {"<=": ">=", "<": ">", ">=": "<=", ">": "<"}[rel]


class Compare:
    """A recorded comparison ``lhs rel rhs`` of lane values; ``err``: the per-lane bound
    of |error of lhs| + |error of rhs| in a running-error run (None otherwise)."""

    __slots__ = ("lhs", "rhs", "rel", "err")

    def __init__(self, lhs, rhs, rel, err=None):
        self.lhs, self.rhs, self.rel, self.err = lhs, rhs, rel, err

    def native(self):
        op = {"<=": np.less_equal, "<": np.less, ">=": np.greater_equal, ">": np.greater}
        return op[self.rel](self.lhs, self.rhs)

    def __bool__(self):
        raise TypeError("a comparison decides nothing by itself: use ctx.reject / ctx.any")


class _SameSign:
    """``ctx.same_sign(x, y)`` / ``differ_sign``: two sign tests, x > 0 and y > 0."""

    __slots__ = ("x", "y", "differ")

    def __init__(self, x, y, differ):
        self.x, self.y, self.differ = x, y, differ


class FilterContext(fperr.NumpyContext):
    """A block of lanes decided against the derived bounds ``bounds`` (a sequence of
    :class:`predicates.filtered.CheckBound`) at scale ``L`` (an array per lane or one
    number). ``undecided`` collects the lanes that must fall back."""

    def __init__(self, dtype, bounds, L, lanes: int, n_weights: int, careful: bool = False,
                 running: bool = False):
        super().__init__(dtype)
        self.bounds, self.L, self.careful, self.running = bounds, L, careful, running
        self.careful |= running  # the running stage always flags underflow per lane
        self.u = float(self.eps)
        self.n_weights = n_weights
        self.active = np.ones(lanes, dtype=bool)
        self.undecided = np.zeros(lanes, dtype=bool)
        self.flagged = np.zeros(lanes, dtype=bool)
        self.index = 0  # the next recorded check
        self._powers: dict[int, object] = {}
        self.tiny = float(np.finfo(self.dtype).tiny)

    def fresh(self, n_weights, lanes=None):  # pragma: no cover - one context per block
        raise TypeError("a filter context is made per block by FilteredPredicate")

    def coords(self, point, label):  # pragma: no cover - FilteredPredicate wraps points
        raise TypeError("a filter context takes Lanes from FilteredPredicate")

    def sqrt(self, x):
        r = np.sqrt(_value(x))
        if self.careful:
            self.flag(r)
        return RunningLanes(r, self, np.inf) if self.running else Lanes(r, self)

    def const(self, x):
        c = super().const(x)
        return RunningLanes(c, self, _up(self.u * abs(float(c)))) if self.running else c

    def eps_multiple(self, q, power: int = 1):
        c = super().eps_multiple(q, power)
        return RunningLanes(c, self, _up(self.u * abs(float(c)))) if self.running else c

    def flag(self, r, a=None, b=None, product=False):
        """Careful run: lanes where ``r`` is not finite, or (a product/quotient) where it
        underflowed — nonzero below the smallest normal, or zero from a nonzero ``a``
        (and ``b``) — lose the standard model and fall back."""
        bad = ~np.isfinite(r)
        if product:
            bad |= (r != 0) & (np.abs(r) < self.tiny)
            zero_from = (r == 0) & (np.asarray(a) != 0)
            if b is not None:
                zero_from &= np.asarray(b) != 0
            bad |= zero_from
        np.logical_or(self.flagged, bad, out=self.flagged)

    # -- thresholds ----------------------------------------------------------------------
    def _L_power(self, p: int):
        """L^p rounded up (each product one ulp up: ≥ the exact power)."""
        if p not in self._powers:
            with np.errstate(all="ignore"):
                if p == 0:
                    self._powers[p] = np.float64(1.0)
                else:
                    x = np.asarray(self.L, dtype=np.float64)
                    for _ in range(p - 1):
                        x = np.nextafter(x * self.L, np.inf)
                    self._powers[p] = x
        return self._powers[p]

    def _sure(self, cmp: Compare):
        """(native value, sure) of the next recorded check."""
        if self.index >= len(self.bounds):
            raise RuntimeError(f"internal error: the native run made more comparisons than "
                               f"the instrumented run's {len(self.bounds)}")
        b = self.bounds[self.index]
        self.index += 1
        if b.rel == _reflect(cmp.rel) and b.rel != cmp.rel:  # T >= x written, x <= T seen
            cmp = Compare(cmp.rhs, cmp.lhs, b.rel, cmp.err)
        if b.rel != cmp.rel:
            raise RuntimeError(f"internal error: comparison {self.index} is {cmp.rel} here "
                               f"but {b.rel} in the instrumented run ({b.label})")
        with np.errstate(all="ignore"):
            E = b.K * self._L_power(b.power) if cmp.err is None else cmp.err
            thr = np.nextafter(np.nextafter(E, np.inf), np.inf)
            gap = np.abs(np.asarray(cmp.lhs, dtype=np.float64)
                         - np.asarray(cmp.rhs, dtype=np.float64))
            return cmp.native(), gap > thr  # nan (overflowed operands): never sure

    def _tri(self, cond):
        """(value, sure) of a condition: a comparison, an any-list or a sign pair."""
        if isinstance(cond, Compare):
            return self._sure(cond)
        if isinstance(cond, _SameSign):
            vx, sx = self._sure(_as_lanes(cond.x, self) > 0)
            vy, sy = self._sure(_as_lanes(cond.y, self) > 0)
            value = (vx != vy) if cond.differ else (vx == vy)
            return value, sx & sy
        if isinstance(cond, (list, tuple)):
            parts = [self._tri(c) for c in cond]
            value = np.zeros(self.active.shape, dtype=bool)
            sure_true = np.zeros(self.active.shape, dtype=bool)
            sure_false = np.ones(self.active.shape, dtype=bool)
            for v, s in parts:
                value |= v
                sure_true |= v & s
                sure_false &= ~v & s
            return value, sure_true | sure_false
        raise TypeError(f"a filtered condition must be a comparison of lane values, got "
                        f"{cond!r}")

    # -- decisions -----------------------------------------------------------------------
    def reject(self, cond, line=None) -> bool:
        value, sure = self._tri(cond)
        unsure = self.active & ~sure
        self.undecided |= unsure
        self.active &= ~(unsure | value)
        return not self.active.any()

    def any(self, *conds):
        return list(conds)

    def same_sign(self, x, y):
        return _SameSign(x, y, False)

    def differ_sign(self, x, y):
        return _SameSign(x, y, True)

    def hit(self, weights):
        return self.active.copy(), None

    def miss(self):
        return np.zeros(self.active.shape, dtype=bool), None
