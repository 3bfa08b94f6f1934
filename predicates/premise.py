"""Rule K's premise at run time: the coordinates a call feeds the derived bounds.

Section 2 derives every bound for coordinates of magnitude L/2 (rule K: c = 1/2, p = 1,
the points translated so that their bounding box of edge L is centred at the origin).
A native run does not translate anything, so what the bounds actually need depends on
how the predicate uses its coordinates (docs/custom-predicates.md, "The premise"):

* **differences only** — every coordinate enters as a same-axis difference of two input
  coordinates (``sub(B, A)``). Such a difference is rounded once (rule E: relative error
  ε) and its magnitude is |B.x − A.x|, which rule K bounds by L; every later step sees
  only those differences. The bounds therefore hold for untranslated points as soon as
  every difference the predicate computes has |B.x − A.x| ≤ L (translation changes no
  computed value). This is the paper's own case: L is the box edge of each pair.
* **absolute** — some coordinate enters raw (the shoelace ``A.x·B.y − …``): its magnitude
  is |A.x| itself and rule K needs |coordinate| ≤ L/2 literally.

:func:`coordinate_use` finds out which by one run of the predicate on probe values (no
sympy: the float and numpy paths never load it), recording the differences computed.
:func:`check_scalar` and :func:`check_batch` verify the premise per call / per batch
(one reduction) and raise :class:`PremiseError` naming it and what to do.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fperr import to_fraction

from .tolerance_table import TABLES
from .tolerances import Tolerances


class PremiseError(ValueError):
    """The inputs break rule K's premise, so the derived bounds do not cover them."""


@dataclass(frozen=True)
class CoordinateUse:
    """``absolute``: some coordinate is used raw (premise |x| ≤ L/2); else ``pairs``
    holds every same-axis difference computed, as (point i, point j, axis) for P_i − P_j
    (premise |P_i − P_j| ≤ L on that axis)."""

    absolute: bool
    pairs: tuple[tuple[int, int, int], ...]


class _Probe:
    """A value of the probe run: a raw coordinate (point, axis), a same-axis difference
    of two, or anything else (kind "x"). Operators record into the owning context."""

    __slots__ = ("ctx", "kind", "point", "axis")

    def __init__(self, ctx, kind="x", point=None, axis=None):
        self.ctx, self.kind, self.point, self.axis = ctx, kind, point, axis

    def _other(self, *operands):
        for v in operands:
            if isinstance(v, _Probe) and v.kind == "coord":
                self.ctx.absolute = True
        return _Probe(self.ctx)

    def __sub__(self, o):
        if (self.kind == "coord" and isinstance(o, _Probe) and o.kind == "coord"
                and o.axis == self.axis):
            self.ctx.pairs.add((self.point, o.point, self.axis))
            return _Probe(self.ctx, "diff")
        return self._other(self, o)

    def __rsub__(self, o):
        return self._other(self, o)

    def _binary(self, o):
        return self._other(self, o)

    __add__ = __radd__ = __mul__ = __rmul__ = __truediv__ = __rtruediv__ = _binary
    __pow__ = __le__ = __lt__ = __ge__ = __gt__ = _binary

    def __neg__(self):
        return self._other(self)

    __abs__ = __pos__ = __neg__

    def __bool__(self):
        raise TypeError("a predicate may not branch on a number (use the context)")


class _ProbeValues(dict):
    """Tolerance values of the probe run: any name is a probe value."""

    def __init__(self, ctx, names):
        super().__init__((n, _Probe(ctx)) for n in names)
        self._ctx = ctx

    def __missing__(self, name):
        return _Probe(self._ctx)


def _probe_tolerances(ctx, dim: int) -> Tolerances:
    """Stands for ``tol``: every tolerance (Figure 1/5's and any other name, also after
    ``tol.scaled(f)``) is a probe value; their magnitudes do not matter here."""
    return Tolerances(dim, _Probe(ctx), 0, ctx, _ProbeValues(ctx, TABLES.get(dim, {})))


class _ProbeContext:
    """The context of the probe run: never returns early, records coordinate use."""

    format, bits, vectorised, dtype = "probe", None, False, None
    eps = 0

    def __init__(self, n_weights):
        self.n_weights, self.absolute, self.pairs = n_weights, False, set()

    def _value(self, *args):
        return _Probe(self)._other(*args)

    def name(self, label, x):
        return x

    def const(self, x):
        return _Probe(self)

    def sqrt(self, x):
        return self._value(x)

    def eps_multiple(self, q, power=1):
        return _Probe(self)

    def convert(self, x):
        return _Probe(self)

    def reject(self, cond, line=None):
        return False

    def any(self, *conds):
        return list(conds)

    def same_sign(self, x, y):
        return self._value(x, y)

    differ_sign = same_sign

    def hit(self, weights):
        return None, tuple(weights)

    def miss(self):  # pragma: no cover - reject never returns True
        return None, ()


@functools.lru_cache(maxsize=256)
def coordinate_use(pred) -> CoordinateUse:
    """How ``pred`` (a :class:`predicates.core.Predicate`) uses its coordinates (see the
    module docstring); one probe run, cached per predicate."""
    ctx = _ProbeContext(len(pred.weight_names))
    pts = [tuple(_Probe(ctx, "coord", i, k) for k in range(pred.dim))
           for i in range(len(pred.points))]
    try:
        pred.fn(ctx, *pts, _probe_tolerances(ctx, pred.dim))
    except Exception:  # a construct the probe does not model: assume the strict premise
        return CoordinateUse(True, ())
    return CoordinateUse(ctx.absolute, tuple(sorted(ctx.pairs)))


def _fail(pred, use: CoordinateUse, L, worst, where: str):
    if use.absolute:
        raise PremiseError(
            f"{pred.name}: rule K's premise fails: this predicate uses raw coordinates (not "
            f"only differences), so its bounds assume |coordinate| ≤ L/2 = {float(L) / 2:.17g}"
            f", but {where} has |coordinate| = {float(worst):.17g}. Translate the points so "
            "that their bounding box is centred at the origin (subtract an exactly "
            "representable centre), or compute the tolerances for L ≥ 2·max|coordinate| "
            "(docs/custom-predicates.md, 'The premise').")
    raise PremiseError(
        f"{pred.name}: rule K's premise fails: the bounds assume every coordinate "
        f"difference the predicate computes is at most L = {float(L):.17g}, but {where} "
        f"has |difference| = {float(worst):.17g}. Compute the tolerances for L ≥ the "
        "largest bounding-box edge of the points of one call (predicates.tolerances, "
        "FPERR_TOLERANCES.tolerances(L)) (docs/custom-predicates.md, 'The premise').")


def check_scalar(pred, points, L) -> None:
    """Raise :class:`PremiseError` unless one call's ``points`` (tuples of numbers of any
    exact type: float, mpmath) satisfy the premise for ``L`` (compared exactly)."""
    use = coordinate_use(pred)
    if isinstance(L, float) and all(isinstance(v, float) for p in points for v in p):
        # binary64 fast path: |x| and 2|x| are exact; a rounded difference below L is
        # exactly below L (rounding is monotone and L is representable)
        if use.absolute:
            if all(2 * abs(v) <= L for p in points for v in p):
                return
        elif all(abs(points[i][k] - points[j][k]) < L for i, j, k in use.pairs):
            return
    Lq = to_fraction(L)
    try:
        [to_fraction(v) for p in points for v in p]
    except (ValueError, TypeError):  # non-finite or odd: the context's own check names it
        return
    if use.absolute:
        for lbl, p in zip(pred.points, points):
            worst = max(abs(to_fraction(v)) for v in p)
            if 2 * worst > Lq:
                _fail(pred, use, L, worst, f"point {lbl}")
        return
    for i, j, k in use.pairs:
        d = abs(to_fraction(points[i][k]) - to_fraction(points[j][k]))
        if d > Lq:
            _fail(pred, use, L, d, f"{pred.points[i]} − {pred.points[j]} on axis {'xyz'[k]}")


def lane_extent(arrs, use: CoordinateUse) -> np.ndarray:
    """Per lane, an upper bound (in float64) of every |P_i − P_j| of ``use.pairs`` on
    (n, dim) arrays ``arrs``: the largest computed difference, one ulp up (a difference
    rounded to nearest is within half an ulp of the exact one; a subnormal one is
    exact). Zero when the predicate computes no difference."""
    n = arrs[0].shape[0]
    out = np.zeros(n)
    for i, j, k in use.pairs:
        d = np.abs(arrs[i][:, k].astype(np.float64) - arrs[j][:, k].astype(np.float64))
        np.maximum(out, d, out=out)
    return np.nextafter(out, np.inf, where=out > 0, out=out)


def check_batch(pred, arrs, L) -> None:
    """Raise :class:`PremiseError` unless every lane of the (n, dim) point arrays
    ``arrs`` satisfies the premise for ``L``: one reduction per batch, exact."""
    use = coordinate_use(pred)
    Lf = float(L)
    if use.absolute:
        for lbl, a in zip(pred.points, arrs):
            worst = float(np.max(np.abs(a))) if a.size else 0.0
            if 2 * Fraction(worst) > to_fraction(L):  # |x| exact, 2·|x| compared exactly
                _fail(pred, use, L, worst, f"point {lbl}")
        return
    if not use.pairs or arrs[0].shape[0] == 0:
        return
    if float(_axis_extent_max(arrs, use)) < Lf:  # fast path: the extent bounds every pair
        return
    for i, j, k in use.pairs:
        a, b = arrs[i][:, k], arrs[j][:, k]
        # rounding is monotone and L is representable: fl(d) < L ⇒ d < L, fl(d) > L ⇒
        # d > L; only lanes with fl(d) == L need the exact difference
        d = np.abs(a.astype(np.float64) - b.astype(np.float64))
        if float(np.max(d)) < Lf:
            continue
        for lane in np.flatnonzero(d >= Lf):
            exact = abs(to_fraction(a[lane]) - to_fraction(b[lane]))
            if exact > to_fraction(L):
                _fail(pred, use, L, exact, f"lane {lane}: {pred.points[i]} − "
                      f"{pred.points[j]} on axis {'xyz'[k]}")


def _axis_extent_max(arrs, use: CoordinateUse) -> float:
    """The largest per-axis extent (max − min, rounded to nearest in float64) over the
    points that enter a difference: ≥ fl(every |P_i − P_j|), since rounding is monotone."""
    points = sorted({i for i, _, _ in use.pairs} | {j for _, j, _ in use.pairs})
    worst = 0.0
    for k in sorted({k for _, _, k in use.pairs}):
        cols = [arrs[i][:, k] for i in points]
        lo, hi = np.minimum(cols[0], cols[1]), np.maximum(cols[0], cols[1])
        for c in cols[2:]:
            np.minimum(lo, c, out=lo)
            np.maximum(hi, c, out=hi)
        np.subtract(hi, lo, out=hi, dtype=hi.dtype)
        worst = max(worst, float(hi.max()))
    return worst
