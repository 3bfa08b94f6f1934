"""Number systems a predicate runs in, behind one small explicit interface.

A predicate is written once against a context ``ctx`` (the mpmath ``ctx`` idiom; see
docs/design.md). Decisions go through the context, never through ``if`` on a number:

* ``ctx.reject(cond, line)`` — True when the caller must return ``ctx.miss()`` now;
* ``ctx.any(*conds)``, ``ctx.same_sign(x, y)``, ``ctx.differ_sign(x, y)`` (against 0);
* ``ctx.hit(weights)`` / ``ctx.miss()``; ``ctx.sqrt``, ``ctx.const``, ``ctx.name(label, x)``.

The context also owns every number-type decision its callers would otherwise make with
``isinstance`` (section 2's standard model needs only ε and the format's range):

* ``format`` (a name :func:`context` accepts), ``bits`` (significand bits; None: no
  rounding), ``eps`` (unit roundoff 2^-bits as a number of the context), ``dtype``
  (numpy dtype of its arrays, or None), ``min_normal`` / ``max_finite`` (exact
  Fractions; None: unbounded exponent), ``vectorised`` (values are arrays of lanes);
* ``convert(x)`` — ``x`` as a number of the context, exactly (ValueError otherwise);
* ``to_fraction(x)`` — the exact value of a number of the context (TypeError for a
  number of another type: a silent promotion would make a result meaningless);
* ``from_fraction(q, rounding)`` — ``q`` correctly rounded to the format
  (``"nearest"`` ties-to-even, ``"up"``, ``"down"``, ``"zero"``), gradual underflow
  and overflow included;
* ``eps_multiple(q, power)`` — the constant q·ε^power (exact for a short q).

Contexts: :class:`FloatContext`, :class:`NumpyContext` (lanes), :class:`MpContext`,
:class:`ExactContext` (Fractions), :class:`fperr.tracked_context.TrackedContext`
(instrumented, never returns early) and :class:`fperr.shadow.ShadowContext` (working and
exact values at once); :func:`context` makes one from a name, a dtype or a precision.
An instance holds the state of one predicate call (``ctx.fresh()`` per call).
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from fractions import Fraction

import mpmath
import numpy as np

from .exact import floor_log2, rational_sqrt, round_fraction, to_fraction


class Context:
    """Interface shared by every number system (see module docstring)."""

    #: The context's name (accepted by :func:`context`).
    format: str = "?"
    #: Unit roundoff of the working format, a number of this context.
    eps: object = 0
    #: Significand bits (None: no rounding).
    bits: int | None = None
    #: numpy dtype of the context's arrays (None: not a numpy format).
    dtype = None
    #: Smallest normal and largest finite magnitude (None: unbounded exponent).
    min_normal: Fraction | None = None
    max_finite: Fraction | None = None
    #: Values are arrays of lanes (early returns become masks).
    vectorised: bool = False
    n_weights: int = 0

    def __repr__(self):
        return f"<{type(self).__name__} {self.format}>"

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

    # -- number-type decisions -----------------------------------------------------------
    def from_fraction(self, q, rounding: str = "nearest"):
        """``q`` correctly rounded to this format (see module docstring)."""
        raise NotImplementedError

    def to_fraction(self, x) -> Fraction:
        """The exact value of ``x``, a number of this context."""
        raise NotImplementedError

    def convert(self, x):
        """``x`` (any finite real number) as a number of this context, exactly;
        ValueError when the format cannot hold it."""
        try:
            q = to_fraction(x)
        except TypeError:
            raise TypeError(f"{self.format} cannot hold {x!r}: instrumented (Tracked) values "
                            "run only in the tracked context") from None
        w = self.from_fraction(q)
        try:
            same = self.to_fraction(w) == q
        except ValueError:  # overflow to infinity
            same = False
        if not same:
            raise ValueError(f"{x!r} is not representable in {self.format}; round the "
                             "inputs first (the analysis assumes exact coordinates)")
        return w

    def eps_multiple(self, q, power: int = 1):
        """The constant q·ε^power of this context (rounded once, to nearest; exact
        when q fits the significand, since ε is a power of two)."""
        e = Fraction(1, 2 ** self.bits) if self.bits is not None else Fraction(0)
        return self.from_fraction(Fraction(q) * e ** power)


class _BinaryFormat:
    """Correct rounding into a binary format with ``bits``, ``min_normal``, ``max_finite``."""

    def from_fraction(self, q, rounding: str = "nearest"):
        q = to_fraction(q)
        min_exp = None if self.min_normal is None else floor_log2(self.min_normal)
        r = round_fraction(q, self.bits, rounding, min_exp)
        if self.max_finite is not None and abs(r) > self.max_finite:
            neg = r < 0
            toward_zero = rounding == "zero" or (rounding == "up") == neg
            if rounding != "nearest" and toward_zero:
                return self._make(-self.max_finite if neg else self.max_finite)
            return self._make_float(-math.inf if neg else math.inf)
        return self._make(r)

    def _make(self, r: Fraction):  # exact: r is representable
        return self._make_float(float(r))


_F64 = np.finfo(np.float64)


class FloatContext(_BinaryFormat, Context):
    """Scalar Python floats (binary64, round to nearest): ε = 2^-53."""

    format = "binary64"
    eps = 2.0**-53
    bits = 53
    dtype = np.dtype(np.float64)
    min_normal = Fraction(float(_F64.tiny))
    max_finite = Fraction(float(_F64.max))

    def fresh(self, n_weights, lanes=None):
        c = type(self)()
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

    _make_float = staticmethod(float)

    def to_fraction(self, x) -> Fraction:
        if not isinstance(x, float):
            raise TypeError(f"binary64 value expected, got {type(x).__name__} {x!r}")
        return to_fraction(x)  # ValueError for inf / nan

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
    (prec=300). The exponent is unbounded (no underflow, no overflow)."""

    dtype = min_normal = max_finite = None

    def __init__(self, prec: int = 53):
        if isinstance(prec, bool) or int(prec) != prec or prec < 2:
            raise ValueError(f"precision must be an integer of at least 2 bits, not {prec!r}")
        self.prec = self.bits = int(prec)
        self.format = f"mp{self.prec}"
        self.eps = mpmath.mpf(2) ** (-self.prec)

    def fresh(self, n_weights, lanes=None):
        c = MpContext(self.prec)
        c.n_weights = n_weights
        return c

    @contextmanager
    def session(self):
        with mpmath.workprec(self.prec):
            yield self

    def const(self, x):  # a Fraction is rounded once (correctly), not via float
        return self.from_fraction(x) if type(x) is Fraction else mpmath.mpf(x)

    def sqrt(self, x):
        return mpmath.sqrt(x)

    def coords(self, point, label):
        out = []
        for v in point:
            try:
                q = to_fraction(v)
            except ValueError:
                raise ValueError(f"point {label} has a non-finite coordinate") from None
            m = self.from_fraction(q)
            if self.to_fraction(m) != q:
                raise ValueError(f"coordinate {v!r} of {label} is not representable with "
                                 f"{self.prec} bits; round the inputs first (the analysis "
                                 "assumes exact coordinates)")
            out.append(m)
        return tuple(out)

    def _make(self, r: Fraction):
        raw = mpmath.libmp.from_rational(r.numerator, r.denominator, self.prec, "n")
        return mpmath.mp.make_mpf(raw)  # exact: r has at most prec bits

    def to_fraction(self, x) -> Fraction:
        if getattr(x, "_mpf_", None) is None:
            raise TypeError(f"mpmath value expected, got {type(x).__name__} {x!r}")
        return to_fraction(x)  # ValueError for inf / nan

    def miss(self):
        return False, (mpmath.mpf(0),) * self.n_weights


SQRT_BITS = 320  #: bits of ExactContext's square root when it is irrational (default)


class ExactContext(FloatContext):
    """Scalar exact rationals (``fractions.Fraction``): no rounding, ε = 0.

    Decisions are exact. ``sqrt`` (edge-vertex's m = ‖û‖) is exact for the square of a
    rational, else truncated to a ``sqrt_bits``-bit dyadic (None: refuse).
    """

    format = "exact"
    eps = Fraction(0)
    bits = dtype = min_normal = max_finite = None

    def __init__(self, sqrt_bits: int | None = SQRT_BITS):
        self.sqrt_bits = sqrt_bits

    def fresh(self, n_weights, lanes=None):
        c = ExactContext(self.sqrt_bits)
        c.n_weights = n_weights
        return c

    def const(self, x):
        return to_fraction(x)

    def sqrt(self, x):
        x = to_fraction(x)
        root = rational_sqrt(x)
        if root is not None:
            return root
        if self.sqrt_bits is None:
            raise ValueError(f"sqrt({x}) is irrational: no exact rational value")
        n, d = x.numerator, x.denominator
        nd = n * d  # √(n/d) = √(n·d)/d, truncated to sqrt_bits bits
        k = max(0, self.sqrt_bits - nd.bit_length() // 2)
        return Fraction(math.isqrt(nd << (2 * k)), d << k)

    def coords(self, point, label):
        return tuple(to_fraction(v) for v in point)

    def from_fraction(self, q, rounding: str = "nearest"):
        return to_fraction(q)

    def to_fraction(self, x) -> Fraction:
        if isinstance(x, bool) or not isinstance(x, (int, Fraction)):
            raise TypeError(f"exact (Fraction) value expected, got {type(x).__name__} {x!r}")
        return Fraction(x)

    def miss(self):
        return False, (Fraction(0),) * self.n_weights


class NumpyContext(_BinaryFormat, Context):
    """Arrays of n lanes in float64 or float32. Early returns become a lane mask; a run
    stops as soon as every lane is rejected. Rejected lanes keep computing harmless
    garbage (division by zero included), silenced by ``session()`` and zeroed in the
    result."""

    vectorised = True

    def __init__(self, dtype=np.float64):
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
            raise TypeError(f"batch mode supports float64 and float32, not {self.dtype}")
        fi = np.finfo(self.dtype)
        self.format = f"numpy.{self.dtype.name}"
        self.bits = fi.nmant + 1
        self.eps = float(fi.eps) / 2
        self.min_normal = Fraction(float(fi.tiny))
        self.max_finite = Fraction(float(fi.max))
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

    def const(self, x):  # a Fraction is rounded once (correctly), not via float
        return self.from_fraction(x) if type(x) is Fraction else self.dtype.type(x)

    def sqrt(self, x):
        return np.sqrt(x)

    def coords(self, point, label):
        arr = np.asarray(point)
        if arr.dtype != self.dtype:
            raise TypeError(f"point {label} has dtype {arr.dtype}, expected {self.dtype}")
        if not np.isfinite(arr).all():
            raise ValueError(f"point {label} has non-finite coordinates")
        return tuple(arr[:, k] for k in range(arr.shape[1]))

    def _make_float(self, f: float):
        return self.dtype.type(f)

    def to_fraction(self, x) -> Fraction:
        if isinstance(x, np.ndarray) or np.result_type(x) != self.dtype:
            raise TypeError(f"{self.dtype} scalar expected, got {type(x).__name__} {x!r}")
        return to_fraction(x)  # ValueError for inf / nan

    def convert(self, x):
        """Scalars as in :meth:`Context.convert`; an array is converted elementwise."""
        if not isinstance(x, np.ndarray):
            return super().convert(x)
        w = x.astype(self.dtype)
        if not (np.isfinite(w).all() and np.array_equal(w.astype(x.dtype), x)):
            raise ValueError(f"array is not representable in {self.format}; round the "
                             "inputs first (the analysis assumes exact coordinates)")
        return w

    def reject(self, cond, line=None) -> bool:
        self.active &= ~np.asarray(cond, dtype=bool)
        return not self.active.any()

    def any(self, *conds):
        # an in-place OR chain (np.logical_or.reduce would first copy into a (k, n) array)
        out = np.logical_or(conds[0], conds[1]) if len(conds) > 1 else np.array(conds[0], dtype=bool)
        for c in conds[2:]:
            np.logical_or(out, c, out=out)
        return out

    same_sign, differ_sign = FloatContext.same_sign, FloatContext.differ_sign

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
