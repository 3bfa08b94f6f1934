"""Filtered sign predicates: decided in floating point where the derived bound allows,
exactly elsewhere, never wrong (docs/custom-predicates.md, "A filtered predicate").

A sign predicate is one function of its points that computes a quantity with ``+ − ×``
(the usual determinant expansions, differences first). The same source runs three ways:

1. **instrumented** (``fperr.Tracked``, rules A–K, section 2 of the paper): its sign
   bound E_sign = E without the final rounding (docs/proofs.md, "Sign tests"), a
   polynomial in ε times L^p for inputs with |coordinate| ≤ L/2 (rule K). The threshold
   is θ(L) = K·L^p with K ≥ (1 + ε)·E_sign(ε, 1) rounded up in the working format;
2. **natively on numpy** (float64 or float32, any batch shape, numpy's gufunc convention
   for the points (..., dim)): a lane is decided by the sign of the computed value q̂
   when |q̂| > θ(L_lane), which implies sign(q̂) = sign(q);
3. **exactly** (``fractions.Fraction``) on the lanes left: the exact sign.

The premise of the bound, |coordinate| ≤ L/2, is *established* per lane rather than
assumed: ``L_lane`` is 2·max |coordinate| of the lane, or, for a source that uses its
coordinates only through differences of one axis (found by a probe run:
:attr:`SignPredicate.through_differences`), the largest extent of the lane's box —
fl(a − b) errs by at most ε·|a − b|, so such a source's errors depend only on the
differences (CGAL's semi-static filters rest on the same fact). Semi-static: a lane far
from the origin, or a large one, gets the threshold its magnitudes need; with
``per_lane=False`` one L for the whole batch (static, one reduction). A lane
whose L is outside the range where underflow cannot matter
(:func:`predicates.tolerances.safe_scale_range`) is decided exactly. So a shoelace
orient2d of a unit triangle at offset 2^20 is either decided with the threshold of its
magnitude 2^21 or exactly; never by a threshold derived for L = 1.

Exact fallback in Python fractions: exactness first; the fallback share is small on
non-degenerate inputs (``benchmarks/filtered_bench.py`` measures it).
"""
from __future__ import annotations

import functools
import math
from fractions import Fraction

import numpy as np

__all__ = ["SignPredicate", "sign_predicate"]


class SignPredicate:
    """A sign predicate from one source (see the module docstring). Call it with the
    points, each (dim,) or (..., dim): returns the exact signs (int8: −1, 0, 1) of the
    quantity, shape (...). ``decide(...)`` also returns the fraction of lanes decided
    exactly; ``threshold(L, dtype)`` is θ(L) in that format."""

    def __init__(self, fn, dim: int, points: str):
        self.fn, self.dim, self.points = fn, dim, tuple(points)
        self.name = fn.__name__
        functools.update_wrapper(self, fn)

    def __repr__(self) -> str:
        return f"<sign predicate {self.dim}D {self.name}({', '.join(self.points)})>"

    # -- the analysis -------------------------------------------------------------------
    @functools.cached_property
    def bound(self):
        """The sign bound of the quantity (``fperr.Bounds``, ``sign=True``)."""
        import fperr

        pts = [tuple(fperr.coord(f"{p}.{'xyz'[a]}") for a in range(self.dim))
               for p in self.points]
        b = fperr.bounds(self.fn(*pts), sign=True)
        if not b.valid or b.E is None:
            raise ValueError(f"{self.name}: no error bound for its quantity ({b.text()})")
        return b

    @functools.lru_cache(maxsize=8)
    def _coefficient(self, dtype: np.dtype) -> tuple[float, int]:
        """(K, p): θ(L) = K·L^p, K ≥ (1 + ε)·E_sign(ε, L = 1) rounded up in ``dtype``."""
        import sympy

        from fperr.symbols import L, eps

        ft = np.finfo(dtype)
        e = Fraction(1, 2 ** (ft.nmant + 1))
        exact = sympy.Rational(1) + sympy.Rational(e.numerator, e.denominator)
        value = sympy.nsimplify(self.bound.E.subs({eps: sympy.Rational(e.numerator,
                                                                       e.denominator),
                                                   L: 1}) * exact)
        K = Fraction(int(sympy.numer(value)), int(sympy.denom(value)))
        k = dtype.type(float(K))
        while Fraction(float(k)) < K:  # round up: a threshold too small is a bug
            k = np.nextafter(k, dtype.type(np.inf))
        return float(k), int(self.bound.power)

    def threshold(self, L: float, dtype=np.float64) -> float:
        """θ(L) = K·L^p, rounded up (float64)."""
        K, p = self._coefficient(np.dtype(dtype))
        return float(_times_power_up(np.array([K]), np.array([float(L)]), p)[0])

    @functools.cached_property
    def through_differences(self) -> bool:
        """True when the source uses its coordinates only as differences of one axis
        (x_P − x_Q): its errors then depend only on the differences' magnitudes (the
        error of fl(a − b) is at most ε·|a − b|), so L may bound 2·|x − c| for any
        centre c instead of 2·|x| (translation-invariant: the premise is established
        per lane by its own extent). Found by running the source on probes."""
        pts = [tuple(_Probe(a) for a in range(self.dim)) for _ in self.points]
        try:
            self.fn(*pts)
        except _NotADifference:
            return False
        return True

    # -- running it -----------------------------------------------------------------------
    def __call__(self, *points) -> np.ndarray:
        return self.decide(*points)[0]

    def decide(self, *points, dtype=None, per_lane: bool = True) -> tuple[np.ndarray, float]:
        """(exact signs (...) int8, fraction of lanes decided exactly)."""
        if len(points) != len(self.points):
            raise TypeError(f"{self.name} takes the points {', '.join(self.points)}")
        arrs = [np.asarray(p) for p in points]
        dt = np.dtype(dtype) if dtype is not None else np.result_type(*arrs, np.float32)
        if dt not in (np.float32, np.float64):
            raise TypeError(f"{self.name}: float64 or float32 points, got {dt}")
        for p, a in zip(self.points, arrs):
            if a.shape[-1:] != (self.dim,):
                raise ValueError(f"{self.name}: point {p} must have shape (..., {self.dim}), "
                                 f"got {a.shape}")
        shape = np.broadcast_shapes(*[a.shape[:-1] for a in arrs])
        X = [np.broadcast_to(a.astype(dt, copy=False), shape + (self.dim,)).reshape(-1, self.dim)
             for a in arrs]
        signs, exact = self._lanes(X, dt, per_lane)
        return signs.reshape(shape), (float(exact.mean()) if exact.size else 0.0)

    def _lanes(self, X, dt, per_lane: bool):
        n = len(X[0])
        L = _lane_L(X, self.through_differences)
        if not per_lane:
            L = np.full(n, L.max(initial=0.0))
        _, Lexp = np.frexp(L)
        with np.errstate(all="ignore"):
            q = self.fn(*[tuple(a[:, j] for j in range(self.dim)) for a in X])
            q = np.broadcast_to(np.asarray(q, dtype=dt), (n,))
            K, p = self._coefficient(dt)
            theta = _times_power_up(np.full(n, K), L, p)
        # underflow: below 2^lo_exp a product may lose bits the bound does not count
        # (the argument of predicates.tolerances.safe_scale_range, for degree p);
        # overflow makes q or θ infinite or NaN (inf − inf), caught by isfinite
        ft = np.finfo(dt)
        lo_exp = math.ceil((20 + math.log2(float(ft.smallest_subnormal)) + ft.nmant + 1) / p)
        safe = (Lexp - 1 >= lo_exp) & np.isfinite(q) & np.isfinite(theta)
        decided = safe & (np.abs(q.astype(np.float64)) > theta)
        signs = np.where(decided, np.sign(q), 0).astype(np.int8)
        rest = np.flatnonzero(~decided)
        for i in rest.tolist():  # the exact sign of the quantity from the same source
            pts = [tuple(Fraction(float(a[i, j])) for j in range(self.dim)) for a in X]
            v = self.fn(*pts)
            signs[i] = (v > 0) - (v < 0)
        return signs, ~decided


class _NotADifference(Exception):
    pass


class _Probe:
    """A coordinate (its axis) in the probe run of :attr:`SignPredicate.through_differences`:
    only ``x_P − x_Q`` of one axis is allowed; its result takes any arithmetic."""

    def __init__(self, axis: int):
        self.axis = axis

    def __sub__(self, other):
        if isinstance(other, _Probe) and other.axis == self.axis:
            return _Free()
        raise _NotADifference

    def _refuse(self, *_):
        raise _NotADifference

    __add__ = __radd__ = __rsub__ = __mul__ = __rmul__ = __truediv__ = __neg__ = _refuse
    __rtruediv__ = __pow__ = __abs__ = __lt__ = __le__ = __gt__ = __ge__ = _refuse


class _Free:
    """A value derived from differences: any arithmetic, with anything but a probe."""

    def _op(self, other=None):
        if isinstance(other, _Probe):
            raise _NotADifference
        return _Free()

    __add__ = __radd__ = __sub__ = __rsub__ = __mul__ = __rmul__ = _op
    __truediv__ = __rtruediv__ = __pow__ = __neg__ = __abs__ = _op


def _lane_L(X, centred: bool) -> np.ndarray:
    """Per lane, an L with |coordinate − c| ≤ L/2 (rule K's premise): c = 0, or, for a
    source that only uses differences, the centre of the lane's box (then L is the box's
    largest extent). Rounded up (one ulp), in float64."""
    if centred:
        lo = np.minimum.reduce([a.astype(np.float64) for a in X])
        hi = np.maximum.reduce([a.astype(np.float64) for a in X])
        ext = (hi - lo).max(axis=1)  # fl(hi − lo) may round down by half an ulp
        return np.nextafter(ext, np.inf)
    mag = np.maximum.reduce([np.abs(a.astype(np.float64)) for a in X]).max(axis=1)
    return np.nextafter(2.0 * mag, np.inf)


def _times_power_up(K: np.ndarray, L: np.ndarray, p: int) -> np.ndarray:
    """K·L^p with every product rounded up (round-to-nearest, then one ulp up: an upper
    bound of the exact product of non-negative numbers)."""
    out = np.asarray(K, dtype=np.float64)
    for _ in range(p):
        out = np.nextafter(out * L, np.inf)
    return out


def sign_predicate(dim: int, points: str):
    """Decorator: ``@sign_predicate(dim=3, points="ABCD")`` on a function of the points
    (tuples of coordinates) returning the quantity whose sign is the answer."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")

    def wrap(fn):
        return SignPredicate(fn, dim, points)

    return wrap
