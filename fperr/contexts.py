"""Number systems a predicate runs in, behind one small explicit interface.

A predicate is written once against a context ``ctx`` (the mpmath ``ctx`` idiom; see
docs/design.md). Decisions go through the context, never through ``if`` on a number:

* ``ctx.reject(cond, line)`` — True when the caller must return ``ctx.miss()`` now;
* ``ctx.any(*conds)``, ``ctx.same_sign(x, y)``, ``ctx.differ_sign(x, y)`` — combine
  conditions (sign tests compare against zero);
* ``ctx.hit(weights)`` / ``ctx.miss()`` — the predicate's result;
* ``ctx.sqrt``, ``ctx.const``, ``ctx.name(label, x)`` — arithmetic and labelling.

Contexts: :class:`FloatContext` (Python floats: early returns), :class:`NumpyContext`
(arrays of n lanes: early returns become masks, the run stops when every lane is
rejected), :class:`MpContext` (mpmath at any precision), :class:`TrackedContext`
(instrumented: records every named quantity and every check, never returns early, so
one run covers every line of the algorithm).

A context instance holds the state of one predicate call; make a fresh one per call
(``ctx.fresh()``).
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from fractions import Fraction

import mpmath
import numpy as np

from . import tracked as _t
from .checks import Check


class Context:
    """Interface shared by every number system (see module docstring)."""

    #: Unit roundoff of the working format.
    eps: float
    n_weights: int = 0

    def fresh(self, n_weights: int, lanes: int | None = None) -> "Context":
        raise NotImplementedError

    @contextmanager
    def session(self):
        yield self

    def name(self, label: str, x):
        return x

    def const(self, x):
        raise NotImplementedError

    def sqrt(self, x):
        raise NotImplementedError

    def coords(self, point, label: str):
        """A point as a tuple of working-precision coordinates."""
        raise NotImplementedError


class FloatContext(Context):
    """Scalar Python floats (binary64, round to nearest): ε = 2^-53."""

    eps = 2.0**-53

    def fresh(self, n_weights, lanes=None):
        c = FloatContext()
        c.n_weights = n_weights
        return c

    def const(self, x):
        return float(x)

    def sqrt(self, x):
        return math.sqrt(x)

    def coords(self, point, label):
        out = tuple(float(v) for v in point)
        if not all(math.isfinite(v) for v in out):
            raise ValueError(f"point {label} has a non-finite coordinate: {out}")
        return out

    def reject(self, cond, line=None) -> bool:
        return bool(cond)

    def any(self, *conds):
        return any(conds)

    def same_sign(self, x, y):
        return (x > 0) == (y > 0)

    def differ_sign(self, x, y):
        return (x > 0) != (y > 0)

    def hit(self, weights):
        return True, tuple(weights)

    def miss(self):
        return False, (0.0,) * self.n_weights


class MpContext(FloatContext):
    """mpmath at ``prec`` bits (round to nearest): ε = 2^-prec. Simulates low precision
    (prec=17 is the paper's worst case, ε = 2^-17 < 1e-5) and serves as a reference
    (prec=300)."""

    def __init__(self, prec: int = 53):
        if prec < 2:
            raise ValueError("precision must be at least 2 bits")
        self.prec = int(prec)
        self.eps = mpmath.mpf(2) ** (-self.prec)

    def fresh(self, n_weights, lanes=None):
        c = MpContext(self.prec)
        c.n_weights = n_weights
        return c

    @contextmanager
    def session(self):
        with mpmath.workprec(self.prec):
            yield self

    def const(self, x):
        return mpmath.mpf(x)

    def sqrt(self, x):
        return mpmath.sqrt(x)

    def coords(self, point, label):
        out = []
        for v in point:
            m = mpmath.mpf(v)
            if not mpmath.isfinite(m):
                raise ValueError(f"point {label} has a non-finite coordinate")
            if mp_to_fraction(m) != to_fraction(v):
                raise ValueError(f"coordinate {v!r} of {label} is not representable with "
                                 f"{self.prec} bits; round the inputs first (the analysis "
                                 "assumes exact coordinates)")
            out.append(m)
        return tuple(out)

    def miss(self):
        return False, (mpmath.mpf(0),) * self.n_weights


def mp_to_fraction(m) -> Fraction:
    """The exact value of an mpmath mpf (``man_exp`` drops the sign)."""
    m = mpmath.mpf(m)
    man, exp = m.man_exp
    q = Fraction(man) * (Fraction(2) ** exp)
    return -q if m < 0 else q


def to_fraction(v) -> Fraction:
    """The exact value of a float, numpy scalar, mpmath mpf, int or Fraction."""
    if isinstance(v, mpmath.mpf):
        return mp_to_fraction(v)
    if isinstance(v, (np.floating, np.integer)):
        return Fraction(v.item())
    return Fraction(v)


class NumpyContext(Context):
    """Arrays of n lanes in float64 or float32. Early returns become a lane mask; a run
    stops as soon as every lane is rejected. Rejected lanes keep computing harmless
    garbage (division by zero included), silenced by ``session()`` and zeroed in the
    result."""

    def __init__(self, dtype=np.float64):
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
            raise TypeError(f"batch mode supports float64 and float32, not {self.dtype}")
        self.eps = float(np.finfo(self.dtype).eps) / 2
        self.active = None

    def fresh(self, n_weights, lanes=None):
        c = NumpyContext(self.dtype)
        c.n_weights = n_weights
        c.active = np.ones(lanes, dtype=bool)
        return c

    @contextmanager
    def session(self):
        with np.errstate(all="ignore"):
            yield self

    def const(self, x):
        return self.dtype.type(x)

    def sqrt(self, x):
        return np.sqrt(x)

    def coords(self, point, label):
        arr = np.asarray(point)
        if arr.dtype != self.dtype:
            raise TypeError(f"point {label} has dtype {arr.dtype}, expected {self.dtype}")
        if not np.isfinite(arr).all():
            raise ValueError(f"point {label} has non-finite coordinates")
        return tuple(arr[:, k] for k in range(arr.shape[1]))

    def reject(self, cond, line=None) -> bool:
        self.active &= ~np.asarray(cond, dtype=bool)
        return not self.active.any()

    def any(self, *conds):
        # an in-place OR chain: np.logical_or.reduce(conds) first copies the conditions
        # into one (k, n) array
        out = np.logical_or(conds[0], conds[1]) if len(conds) > 1 else np.array(conds[0], dtype=bool)
        for c in conds[2:]:
            np.logical_or(out, c, out=out)
        return out

    def same_sign(self, x, y):
        return (x > 0) == (y > 0)

    def differ_sign(self, x, y):
        return (x > 0) != (y > 0)

    #: Optional (lanes, n_weights) output the caller provides (zero-filled): ``hit``
    #: writes the weights of the active lanes into it instead of allocating.
    out = None

    def hit(self, weights):
        n = self.active.shape[0]
        out = self.out if self.out is not None else np.zeros((n, len(weights)), dtype=self.dtype)
        for j, x in enumerate(weights):
            np.copyto(out[:, j], x, where=self.active)
        return self.active, out

    def miss(self):
        n = self.active.shape[0]
        out = self.out if self.out is not None else np.zeros((n, self.n_weights), dtype=self.dtype)
        return np.zeros(n, dtype=bool), out


class TrackedContext(Context):
    """The instrumented run: inputs are :class:`fperr.Tracked`; every named quantity and
    every check is recorded; ``reject`` never returns early so every line is analysed.

    After a run: ``quantities`` (label → Tracked, in order of computation), ``checks``
    (list of :class:`fperr.checks.Check` with ``line``), ``weights`` (returned Tracked).
    """

    from .symbols import eps as eps  # symbolic unit roundoff

    def __init__(self):
        self.quantities: dict[str, _t.Tracked] = {}
        self.checks: list[Check] = []
        self.weights: tuple = ()

    def fresh(self, n_weights, lanes=None):
        c = TrackedContext()
        c.n_weights = n_weights
        return c

    def name(self, label, x):
        if isinstance(x, _t.Tracked):
            x.name = label
            self.quantities[label] = x
        return x

    def const(self, x):
        return _t.const(x)

    def sqrt(self, x):
        return _t.sqrt(x)

    def coords(self, point, label):
        if isinstance(point, str) or point is None:
            raise TypeError("instrumented points are tuples of Tracked coordinates")
        return tuple(point)

    def _flatten(self, cond):
        if isinstance(cond, Check):
            return [cond]
        if isinstance(cond, (list, tuple)):
            return [c for x in cond for c in self._flatten(x)]
        raise TypeError(f"instrumented condition must be a Tracked comparison, got {cond!r}")

    def reject(self, cond, line=None) -> bool:
        for c in self._flatten(cond):
            c.line = line
            self.checks.append(c)
        return False

    def any(self, *conds):
        return list(conds)

    def same_sign(self, x, y):
        zero = _t.const(0)
        return [Check(x, zero, ">", label="sign"), Check(y, zero, ">", label="sign")]

    differ_sign = same_sign  # the same two sign tests are recorded

    def hit(self, weights):
        self.weights = tuple(weights)
        return None, self.weights

    def miss(self):  # pragma: no cover - reject never asks for it
        raise AssertionError("the instrumented run never returns early")


def context_for(*values) -> Context:
    """The context matching the inputs' number type (Tracked, numpy, mpmath, float)."""
    flat = [v for p in values for v in (p if isinstance(p, (tuple, list)) else (p,))]
    if any(isinstance(v, _t.Tracked) for v in flat):
        return TrackedContext()
    if any(isinstance(v, np.ndarray) for v in values):
        dt = np.result_type(*[np.asarray(v).dtype for v in values])
        return NumpyContext(dt)
    if any(isinstance(v, mpmath.mpf) for v in flat):
        return MpContext(mpmath.mp.prec)
    return FloatContext()
