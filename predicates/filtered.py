"""Filtered predicates: decide natively when the derived bound allows, else exactly.

From one ``@predicate`` source (:mod:`predicates.core`), :class:`FilteredPredicate`
gives a batched predicate (numpy's gufunc convention: points of shape (..., dim)
broadcast) whose answer equals the exact answer — the same source run on exact
rationals with the same inputs and tolerance values — on every lane, and reports the
share of lanes that needed the exact path (docs/custom-predicates.md, "A filtered
predicate").

**Why a native decision is exact.** The instrumented run (section 2, rules A–K) bounds
the error of every comparison ``x rel y`` the predicate makes: E = E[x] + E[y]
(docs/design.md, "Error of a check"); for a comparison with zero the bound without the
final rounding (``fperr.bounds(x, sign=True)``) when fperr provides it — a rounding to
nearest never changes a sign — else the ordinary bound, also sound. E = K(ε)·L^p holds
when rule K's premise holds and no operation underflows or overflows. If the computed
operands satisfy |fl(x) − fl(y)| > E·(1 + u) then the computed difference of the
operands (rounded once, |d| ≥ |fl(d)|/(1 + u)) exceeds E, so the exact X − Y has the
sign of the computed comparison: the native decision is the exact one. A lane is
decided natively when each comparison it reaches is so decided (or, inside
``ctx.any``, one operand is surely true); otherwise it *falls back* and is decided
exactly. Every threshold is rounded upward (K up to binary64, each product of L^p·K one
ulp up), so it stays an upper bound of E.

**The premise, per lane.** The derived bounds hold for coordinates |x| ≤ L/2 (rule K).
For a predicate that uses coordinates only through same-axis differences they hold for
untranslated points whenever every difference it computes is at most L
(:mod:`predicates.premise`). So each lane gets its own L: the largest difference it
computes, one ulp up (``semi-static``, the per-call magnitude of CGAL's semi-static
filters, the difference set being the one the predicate actually forms), or one L for
the batch (``static``: ``L`` given, or the batch's largest); a predicate that uses raw
coordinates gets L = 2·max|coordinate| of the lane (exact). With a tolerance table, L is
at least ``tol.L``, the scale the tolerances were computed for. A lane whose L exceeds a
given static ``L`` falls back: never a silent wrong answer.

**Underflow and overflow** (section 2 assumes neither) are detected, not assumed away:
each block runs with numpy's underflow and overflow traps; a block that raises is rerun
with per-lane flags (a nonzero product or quotient below the smallest normal, a zero
one from nonzero operands, a non-finite value), and flagged lanes fall back.

**The exact path** evaluates the same source exactly on the lanes that fell back: all
at once in dyadic integers (:mod:`predicates.exact_lanes`: every float is m·2^s and
+, −, × keep that form, so Python integers and one exponent per value suffice, with no
gcd) when the source needs no quotient or root, else lane by lane with
:class:`fperr.ExactContext` (``fractions.Fraction``, ε = 0, square roots refused unless
rational). Exactness comes first: neither rounds, with no expansion arithmetic to get
wrong; the dyadic path costs 3–8 µs a lane for the classic determinants, Fractions
30–240 µs (benchmarks/README.md, "Filtered predicates").
"""
from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

import fperr
from fperr import round_fraction

from . import premise
from .exact_lanes import ExactLanesContext, NotDyadic, lanes_of
from .filtered_run import FilterContext, Lanes, RunningLanes
from .tolerances import Tolerances

MODES = ("semi-static", "static")


@dataclass(frozen=True)
class FilteredResult:
    """``hit``: the exact answer per lane (batch shape); ``fell_back``: the lanes the
    exact path decided; ``share``: their fraction (0 for an empty batch)."""

    hit: np.ndarray
    fell_back: np.ndarray
    first_stage: np.ndarray | None = None  #: lanes the derived-bound filter left


    @property
    def share(self) -> float:
        return float(self.fell_back.mean()) if self.fell_back.size else 0.0


@dataclass(frozen=True)
class CheckBound:
    """The bound of one recorded comparison: E ≤ ``K``·L^``power`` in the working
    format (``K`` rounded up to binary64; inf when no bound is valid)."""

    rel: str
    K: float
    power: int
    label: str


def _sign_bounds_supported() -> bool:
    try:
        return "sign" in inspect.signature(fperr.bounds).parameters
    except (TypeError, ValueError):  # pragma: no cover - a builtin without a signature
        return False


def _error_expr(check, sign_bounds: bool):
    """E of a recorded check (sympy in ε, L): the sign bound for a comparison with 0."""
    if check.is_sign_test and sign_bounds:
        E = fperr.bounds(check.lhs, strict=True, sign=True).E
        if E is None:
            raise fperr.InvalidBound(f"no sign bound for {check}")
        return E
    return check.error()


@functools.lru_cache(maxsize=64)
def check_bounds(pred, bits: int, table=None) -> tuple[CheckBound, ...]:
    """Every comparison of ``pred``'s instrumented run, in execution order, with its
    bound K·L^p at ε = 2^-bits (exact, then rounded up)."""
    import sympy
    ins = pred.instrumented(None if table is None else dict(table))
    sign_bounds = _sign_bounds_supported()
    out = []
    for c in ins.checks:
        try:
            E = _error_expr(c, sign_bounds)
            power = int(c.power)
            if power != c.power or power < 0:
                raise fperr.InvalidBound(f"power {c.power}")
            k = sympy.Rational(sympy.expand(E.subs(fperr.L, 1).subs(fperr.eps,
                                                                  sympy.Rational(1, 2**bits))))
            K = float(round_fraction(Fraction(int(k.p), int(k.q)), 53, "up"))
        except fperr.InvalidBound:
            K, power = float("inf"), 0
        out.append(CheckBound(c.rel, K, power, str(c)))
    return tuple(out)


class FilteredPredicate:
    """A :class:`predicates.core.Predicate` decided natively where its derived bounds
    allow and exactly elsewhere (module docstring). Call it like the predicate, ``tol``
    optional for sign-only predicates: ``f(A, B, C)`` → :class:`FilteredResult`.

    ``mode``: ``"semi-static"`` (each lane's own L, default) or ``"static"`` (one L:
    ``L`` if given, else the batch's largest). ``table``: the tolerance table the
    predicate's tolerances come from (name → ToleranceSpec), None for Figure 1/5."""

    BLOCK = 1 << 15  #: lanes per block (temporaries stay in cache)

    def __init__(self, pred, mode: str = "semi-static", L=None, table: dict | None = None,
                 running: bool = True):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
        if L is not None and not (np.isfinite(float(L)) and float(L) > 0):
            raise ValueError(f"L must be a positive finite number, got {L!r}")
        if mode == "semi-static" and L is not None:
            raise ValueError("L is the static filter's scale: pass mode='static' with it")
        self.pred, self.mode, self.L = pred, mode, None if L is None else float(L)
        self.running = running
        self._dyadic = True  # until the source divides or takes a root (exact path)
        self.table = None if table is None else tuple(sorted(table.items()))
        self.name = pred.name
        functools.update_wrapper(self, pred.fn)

    def __repr__(self):
        return f"<filtered {self.mode} {self.pred!r}>"

    def __call__(self, *args, tol: Tolerances | None = None) -> FilteredResult:
        arrs, batch, dtype, tol = self._inputs(args, tol)
        n = arrs[0].shape[0]
        hit, fell = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        bounds = check_bounds(self.pred, np.finfo(dtype).nmant + 1, self.table)
        use = premise.coordinate_use(self.pred)
        lane_L = self._lane_L(arrs, use, tol)
        static_L = None
        if self.mode == "static":
            static_L = self.L if self.L is not None else (float(lane_L.max()) if n else 1.0)
        for start in range(0, n, self.BLOCK):
            stop = min(n, start + self.BLOCK)
            blocks = [a[start:stop] for a in arrs]
            Lb = lane_L[start:stop]
            if static_L is None:
                too_big, L_run = np.zeros(stop - start, dtype=bool), Lb
            else:
                too_big, L_run = Lb > static_L, static_L
            h, undecided = self._native(blocks, tol, dtype, bounds, L_run)
            undecided |= too_big
            hit[start:stop] = h & ~undecided
            fell[start:stop] = undecided
        first = fell.copy()
        lanes = np.flatnonzero(fell)
        if lanes.size and self.running:  # second stage: a per-lane running error bound
            sub = [a[lanes] for a in arrs]
            h, still = self._native(sub, tol, dtype, bounds, None, running=True)
            hit[lanes[~still]] = h[~still]
            fell[lanes[~still]] = False
            lanes = lanes[still]
        if lanes.size:
            hit[lanes] = self._exact_lanes(arrs, lanes, tol)
        return FilteredResult(hit.reshape(batch), fell.reshape(batch), first.reshape(batch))

    def exact(self, *args, tol: Tolerances | None = None,
              arithmetic: str = "auto") -> np.ndarray:
        """The all-exact path (every lane exact): the reference and baseline.
        ``arithmetic``: "auto" (dyadic integers when the source allows, else Fractions)
        or "fractions" (lane by lane)."""
        if arithmetic not in ("auto", "fractions"):
            raise ValueError(f"arithmetic must be 'auto' or 'fractions', not {arithmetic!r}")
        arrs, batch, _, tol = self._inputs(args, tol)
        lanes = np.arange(arrs[0].shape[0])
        if arithmetic == "fractions":
            return self._fraction_lanes(arrs, lanes, tol).reshape(batch)
        return self._exact_lanes(arrs, lanes, tol).reshape(batch)

    # -- pieces ---------------------------------------------------------------------------
    def _inputs(self, args, tol):
        pred = self.pred
        if len(args) != len(pred.points):
            raise TypeError(f"{self.name} takes points {', '.join(pred.points)} "
                            f"({len(pred.points)} arrays), got {len(args)}; tol= by keyword")
        dtypes = {np.asarray(a).dtype for a in args}
        if len(dtypes) != 1 or next(iter(dtypes)) not in (np.float64, np.float32):
            raise TypeError(f"{self.name}: the points must all be float64 or all float32 "
                            f"arrays (convert explicitly: rounding changes the geometry), got "
                            f"{', '.join(sorted(str(d) for d in dtypes))}")
        dtype = next(iter(dtypes))
        ctx = fperr.NumpyContext(dtype)
        arrs, batch = pred._batch_points(args, ctx)
        for a, lbl in zip(arrs, pred.points):
            if not np.isfinite(a).all():
                raise ValueError(f"{self.name}: point {lbl} has non-finite coordinates")
        if tol is not None and (not isinstance(tol, Tolerances) or tol.dim != pred.dim):
            raise TypeError(f"{self.name}: tol must be {pred.dim}D Tolerances")
        return arrs, batch, dtype, tol

    def _lane_L(self, arrs, use, tol) -> np.ndarray:
        """Each lane's L: an upper bound of the magnitudes rule K's premise needs."""
        if use.absolute:
            L = np.zeros(arrs[0].shape[0])
            for a in arrs:
                np.maximum(L, np.abs(a).max(axis=1).astype(np.float64), out=L)
            L *= 2  # exact: a power-of-two scaling of a float64 (overflow → inf → exact path)
        else:
            L = premise.lane_extent(arrs, use)
        if tol is not None:
            np.maximum(L, float(tol.L), out=L)
        return L

    def _native(self, blocks, tol, dtype, bounds, L, running=False):
        """(native answer, undecided lanes) of one block (``running``: of the lanes
        ``blocks`` hold, with the running error bound)."""
        k = len(self.pred.weight_names)
        if running:
            ctx = FilterContext(dtype, bounds, L, blocks[0].shape[0], k, running=True)
            with np.errstate(all="ignore"):
                hit, undecided = self._run(ctx, blocks, tol)
            return hit & ~ctx.flagged, undecided | ctx.flagged
        ctx = FilterContext(dtype, bounds, L, blocks[0].shape[0], k)
        try:
            with np.errstate(under="raise", over="raise", divide="ignore", invalid="ignore"):
                return self._run(ctx, blocks, tol)
        except FloatingPointError:  # rerun with per-lane underflow/overflow flags
            ctx = FilterContext(dtype, bounds, L, blocks[0].shape[0], k, careful=True)
            with np.errstate(all="ignore"):
                hit, undecided = self._run(ctx, blocks, tol)
            return hit, undecided | ctx.flagged

    def _run(self, ctx, blocks, tol):
        kind = RunningLanes if ctx.running else Lanes
        coords = [tuple(kind(b[:, j], ctx) for j in range(self.pred.dim)) for b in blocks]
        tol_values = _NoTolerances(self.pred) if tol is None else \
            self.pred._tolerances_for(tol, fperr.NumpyContext(ctx.dtype))
        hit, _ = self.pred.fn(ctx, *coords, tol_values)
        return np.asarray(hit, dtype=bool) & ~ctx.undecided, ctx.undecided

    def _exact_lanes(self, arrs, lanes, tol) -> np.ndarray:
        """The exact answer on ``lanes``: all at once in dyadic integers
        (:mod:`predicates.exact_lanes`) when the source needs no quotient or root, else
        lane by lane in Fractions (an irrational sqrt is refused)."""
        if lanes.size and self._dyadic:
            run = ExactLanesContext().fresh(len(self.pred.weight_names), lanes.size)
            try:
                tol_values = _NoTolerances(self.pred) if tol is None else \
                    self.pred._tolerances_for(tol, run)
                pts = [tuple(lanes_of(a[lanes, j]) for j in range(self.pred.dim))
                       for a in arrs]
                return np.asarray(self.pred.fn(run, *pts, tol_values)[0], dtype=bool)
            except NotDyadic:
                self._dyadic = False  # this source divides or takes roots: Fractions
        return self._fraction_lanes(arrs, lanes, tol)

    def _fraction_lanes(self, arrs, lanes, tol) -> np.ndarray:
        """The exact answer on ``lanes``, one lane at a time in Fractions."""
        exact = fperr.ExactContext(sqrt_bits=None)
        tol_values = _NoTolerances(self.pred) if tol is None else \
            self.pred._tolerances_for(tol, exact)
        cols = [a[lanes].tolist() for a in arrs]  # Python floats: exact for f32 and f64
        out = np.zeros(lanes.size, dtype=bool)
        k = len(self.pred.weight_names)
        for idx in range(lanes.size):
            run = exact.fresh(k)
            pts = [tuple(Fraction(v) for v in c[idx]) for c in cols]
            out[idx] = bool(self.pred.fn(run, *pts, tol_values)[0])
        return out


class _NoTolerances:
    """``tol`` of a call without tolerances: reading one is a clear error."""

    def __init__(self, pred):
        self._pred = pred

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise TypeError(f"{self._pred.name} reads the tolerance {name!r}: pass tol= "
                        "(predicates.tolerances(...) or FPERR_TOLERANCES.tolerances(L))")

    def scaled(self, factor):
        return self


def filtered(pred, mode: str = "semi-static", L=None, table: dict | None = None,
             running: bool = True) -> FilteredPredicate:
    """``pred`` as a :class:`FilteredPredicate` (see the module docstring)."""
    return FilteredPredicate(pred, mode=mode, L=L, table=table, running=running)
