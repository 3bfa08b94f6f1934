"""Shadow-execution audit: measured floating-point error against the derived bounds.

Every predicate of :data:`predicates.ALL` is run — the *same* source, through
:class:`fperr.shadow.ShadowContext` — on random and adversarial inputs in binary64,
binary32 and mpmath at 17 bits (ε = 2^-17, the paper's worst case). Each run follows the
working-precision decisions (the real floating-point path, early returns included) and
carries the exact value of every quantity beside it (fractions; 300-bit rigorous intervals
where a square root is irrational).

Soundness of quantities
    For every named quantity x (the names of the instrumented run), the largest observed
    |F[x] − x| / E[x], with E[x] the bound rules A–K derive, evaluated at the format's ε
    and the configuration's L (coordinates lie in [−L/2, L/2], as rule K assumes). It must
    never exceed 1; how close it gets to 1 is the bound's tightness. Quantities with a
    relative bound (r) are also checked against R[x]·|x|.
Decisions
    For a check "x ≤ T" (the section 3 tolerance model): exact x ≤ T− must imply that the
    working check says ≤, and the working check saying ≤ must imply exact x ≤ T+ (mirrored
    for ">"). Sign tests must agree with the exact sign wherever the paper's premise holds:
    a sign test guarded by a magnitude check on the same quantity counts when the guard
    passed; an unguarded one (edge-vertex's â < 0, ā < 0, protected by a degeneracy-excluded
    geometric bound) counts only when no lower sub-pair registers — the lower predicates
    are run, in the same format, to decide. "stress" is the share of the bracket gap
    (T − T−, T+ − T) the rounding actually consumed; it must stay below 1 for a violation
    to be possible.
Search
    Besides uniform and adversarial sampling (near-degenerate configurations at 0.1–10
    tolerances, long and short elements, slivers, flat and grid-aligned configurations,
    coordinates at the bounding-box extremes), a hill-climbing search starts from the worst
    samples of every quantity and check and perturbs their coordinates (by ulps, by random
    steps at every scale, by snapping to the box extremes) to maximise the error ratio or
    the stress.

The exact reference
    Exact values are fractions while rational and rigorous 300-bit rational intervals
    after an irrational square root (edge-vertex's m, the ε^(1/2), ε^(1/4) factors of the
    tolerances, the √3 of some T+): see :mod:`fperr.shadow`. A measured error is the far
    end of |F[x] − x| (an upper bound), so a ratio ≤ 1 is a proof for that input; a
    comparison the interval cannot decide is counted as "undecided", never as agreement.

Runs
    CI size (the default, about 25 s of CPU): ``fperr audit``. A larger run (about
    200 s of CPU, 130,000 shadow runs):
    ``fperr audit --samples 1500 --search-steps 150 --seed 7 --format json -o audit.json``;
    its figures are in benchmarks/README.md. ``--dtype``, ``--dim`` and
    ``--predicates`` restrict the audit; ``proofs.audit.replay(record)`` re-runs a
    violation or worst case from the JSON report.

Exit status 1 when any violation was found.
"""
from __future__ import annotations

import json
import math
import random
import sys
import time
import zlib
from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache

import numpy as np
import sympy

import fperr
import predicates
from fperr import FloatContext, MpContext, NumpyContext
from fperr.shadow import _sub  # exact subtraction (Fraction / interval)
from fperr.shadow import (BINARY32, BINARY64, Shadow, ShadowContext, compare,
                          interval_from_float, lower_fraction, mp_format, to_fraction,
                          upper_fraction)
from predicates.catalogue import pair_predicate
from predicates.tolerance_table import TABLES
from predicates.tolerances import Tolerances, tolerance_values, tracked_tolerances

# --------------------------------------------------------------------------------------
# formats, primitive kinds, scales
# --------------------------------------------------------------------------------------
MP17 = mp_format(17)

#: name -> (WorkingFormat, dtype argument of predicates.tolerances)
FORMATS = {"binary64": (BINARY64, float), "binary32": (BINARY32, np.float32),
           "mp17": (MP17, "mp17")}

#: (L_a, L_b): bounding-box edge lengths of the two primitives (long and short elements).
SCALES = [(0.5, 0.5), (0.9, 0.1), (0.1, 0.9), (0.999, 0.001), (0.001, 0.999),
          (1.5, 0.25), (0.75, 0.75), (0.3, 1.7)]

#: Distance tolerance of a near-incidence between faces of i and j vertices: the bracket
#: of the 3D predicate deciding such a pair (the catalogue's), used in 2D too as a scale.
NEAR_TOL = {(i, j): pair_predicate(3, i, j)[0].bracket
            for i in range(1, 4) for j in range(1, 4)
            if pair_predicate(3, i, j) and pair_predicate(3, i, j)[0].bracket}

DEFAULT_SAMPLES = 100
DEFAULT_SEARCH = 10


# --------------------------------------------------------------------------------------
# static part: bounds and check classification from the instrumented run
# --------------------------------------------------------------------------------------
def _lower_fraction_of(expr) -> Fraction:
    """A Fraction ≤ the (positive, constant) sympy expression."""
    expr = sympy.nsimplify(expr) if isinstance(expr, sympy.Float) else expr
    if expr.is_Rational:
        return Fraction(int(expr.p), int(expr.q))
    v = Fraction(str(sympy.N(expr, 80)))
    return v * (1 - Fraction(1, 10**60))


def _real(expr):
    """Exact value of a constant sympy expression: a Fraction, or a rigorous interval."""
    expr = sympy.nsimplify(expr) if isinstance(expr, sympy.Float) else sympy.sympify(expr)
    if expr.is_Rational:
        return Fraction(int(expr.p), int(expr.q))
    return interval_from_float(sympy.N(expr, 130))


@dataclass
class QuantitySpec:
    name: str
    power: int
    text: str
    E: object          # sympy expression in eps, L
    R: object          # sympy expression in eps, or None
    E1: dict = field(default_factory=dict)   # format -> Fraction lower bound of E at L=1
    R1: dict = field(default_factory=dict)   # format -> Fraction lower bound of R


@dataclass
class CheckSpec:
    index: int
    line: int
    rel: str
    kind: str          # "bracket" | "sign-guarded" | "sign-geometric"
    quantity: str      # the quantity the check tests
    label: str
    guard: int | None = None


class PredicateSpec:
    """A predicate with what the audit needs: bounds, check kinds, its two primitives."""

    def __init__(self, pred, bound_fn=None, split=None):
        self.pred = pred
        self.dim = pred.dim
        self.name = pred.name
        self.key = f"{pred.dim}D {pred.name}"
        self.split = split or ("".join(pred.sim), "".join(pred.cut))
        if "".join(self.split) != "".join(pred.points):
            raise ValueError(f"{self.key}: split {self.split} does not match points {pred.points}")
        ins = pred.instrumented()
        bound_fn = bound_fn or fperr.bounds
        self.quantities: dict[str, QuantitySpec] = {}
        for qname, q in ins.quantities.items():
            b = bound_fn(q)
            if not b.valid:
                self.quantities[qname] = QuantitySpec(qname, 0, "invalid", None, None)
                continue
            self.quantities[qname] = QuantitySpec(qname, int(b.power), b.text(), b.E, b.R)
        self.checks = self._classify(ins)
        self.n_weights = len(pred.weight_names)

    @staticmethod
    def _qname(t):
        if t.name:
            return t.name
        if t.rule == "I" and t.args and t.args[0].name:
            return t.args[0].name
        return t.s

    def _classify(self, ins):
        out = []
        for k, c in enumerate(ins.checks):
            qn = self._qname(c.lhs)
            lhs_label = c.lhs.name or (f"|{c.lhs.args[0].name}|" if c.lhs.rule == "I"
                                       and c.lhs.args and c.lhs.args[0].name else c.lhs.s)
            if not c.is_sign_test:
                out.append(CheckSpec(k, c.line, c.rel, "bracket", qn,
                                     f"{lhs_label} {c.rel} {_rhs_label(c.rhs)}"))
                continue
            guard = None
            for j, g in enumerate(ins.checks):
                if g.is_sign_test or g.line is None or g.line > c.line:
                    continue
                if g.lhs is c.lhs or (g.lhs.rule == "I" and g.lhs.args and g.lhs.args[0] is c.lhs):
                    guard = j
                    break
            out.append(CheckSpec(k, c.line, c.rel, "sign-guarded" if guard is not None
                                 else "sign-geometric", qn, f"{lhs_label} {c.rel} 0", guard))
        return out

    def bound_coefficients(self, fmt_name):
        fmt = FORMATS[fmt_name][0]
        e = sympy.Rational(fmt.eps.numerator, fmt.eps.denominator)
        for q in self.quantities.values():
            if q.E is None or fmt_name in q.E1:
                continue
            q.E1[fmt_name] = _lower_fraction_of(q.E.subs({fperr.eps: e, fperr.L: 1}))
            q.R1[fmt_name] = (None if q.R is None else
                              _lower_fraction_of(q.R.subs(fperr.eps, e)))


@lru_cache(maxsize=None)
def spec_for(pred) -> PredicateSpec:
    """The (cached) audit spec of a predicate with the derived bounds."""
    return PredicateSpec(pred)


def _rhs_label(t):
    if t.name:
        return t.name
    if t.args and len(t.args) == 2 and t.rule == "F":
        return f"{_rhs_label(t.args[0])}*{_rhs_label(t.args[1])}"
    return t.s


# --------------------------------------------------------------------------------------
# tolerances: working values, exact values with brackets
# --------------------------------------------------------------------------------------
@dataclass
class ToleranceInfo:
    dim: int
    fmt_name: str
    L_ab: tuple
    real: Tolerances          # predicates.tolerances(...) in the working format
    shadow: Tolerances        # the same values as bracketed Shadow numbers
    L: Fraction
    floats: dict              # float values for geometry generation


@lru_cache(maxsize=None)
def tolerance_info(dim: int, fmt_name: str, L_a: float, L_b: float,
                   brackets: tuple = ()) -> ToleranceInfo:
    """Tolerances of a configuration. ``brackets``: ((name, lo, hi), ...) replaces the
    coefficients of T−, T+ of Figure 1/5 (tests use it to plant a wrong bracket)."""
    fmt, dtype = FORMATS[fmt_name]
    real = predicates.tolerances(dim, L_a, L_b, dtype=dtype)
    L = to_fraction(real.L)
    Ls = sympy.Rational(L.numerator, L.denominator)
    override = {name: (lo, hi) for name, lo, hi in brackets}
    vals = {}
    for name, spec in TABLES[dim].items():
        f = sympy.Integer(2) ** (-fmt.bits * spec.q) * Ls ** spec.p
        lo, hi = override.get(name, (spec.lo, spec.hi))
        vals[name] = Shadow.bracketed(real.values[name], _real(spec.mid * f),
                                      _real(sympy.sympify(lo) * f),
                                      _real(sympy.sympify(hi) * f), fmt, label=name)
    shadow = Tolerances(dim, real.L, real.eps, ShadowContext(fmt), vals)
    floats = {k: float(v) for k, v in real.values.items()}
    return ToleranceInfo(dim, fmt_name, (L_a, L_b), real, shadow, L, floats)


@lru_cache(maxsize=None)
def _tolerance_bounds(dim):
    """name -> (R[T] as a sympy expression in eps, its text), from the instrumented run."""
    out = {}
    for name, t in tracked_tolerances(dim).values.items():
        b = fperr.bounds(t)
        out[name] = (b.R, b.text())
    return out


# --------------------------------------------------------------------------------------
# one run
# --------------------------------------------------------------------------------------
@dataclass
class Config:
    """An input: exact coordinates (representable in the format) and the scale."""

    dim: int
    fmt_name: str
    L_ab: tuple
    points: tuple            # tuple of tuples of Fraction
    scenario: str = ""
    brackets: tuple = ()     # bracket overrides (tests only), see tolerance_info

    @property
    def info(self) -> ToleranceInfo:
        return tolerance_info(self.dim, self.fmt_name, *self.L_ab, self.brackets)

    def with_points(self, pts, scenario=None) -> "Config":
        return Config(self.dim, self.fmt_name, self.L_ab, tuple(pts),
                      self.scenario if scenario is None else scenario, self.brackets)

    def to_json(self):
        d = {"format": self.fmt_name, "L_a": self.L_ab[0], "L_b": self.L_ab[1],
             "points": [[float(c).hex() for c in p] for p in self.points],
             "scenario": self.scenario}
        if self.brackets:
            d["brackets"] = [[n, str(lo), str(hi)] for n, lo, hi in self.brackets]
        return d

    @staticmethod
    def from_json(dim, d):
        pts = tuple(tuple(Fraction(float.fromhex(c)) for c in p) for p in d["points"])
        br = tuple((n, sympy.Rational(lo), sympy.Rational(hi)) for n, lo, hi in d.get("brackets", ()))
        return Config(dim, d["format"], (d["L_a"], d["L_b"]), pts, d.get("scenario", ""), br)


def run_shadow(spec: PredicateSpec, cfg: Config, pred=None, points=None) -> ShadowContext:
    """Run ``spec``'s predicate (or ``pred``) on ``cfg`` with shadow numbers."""
    fmt = FORMATS[cfg.fmt_name][0]
    info = cfg.info
    pred = pred or spec.pred
    pts = cfg.points if points is None else points
    ctx = ShadowContext(fmt).fresh(len(pred.weight_names))
    with ctx.session():
        coords = [tuple(Shadow(fmt.from_fraction(c), c, fmt) for c in p) for p in pts]
        pred.fn(ctx, *coords, info.shadow)
    return ctx


def _working_points(fmt_name, pts):
    fmt = FORMATS[fmt_name][0]
    if fmt.kind == "numpy":
        return [np.array([[float(c) for c in p]], dtype=fmt.dtype) for p in pts]
    if fmt.kind == "mp":
        return [tuple(fmt.from_fraction(c) for c in p) for p in pts]
    return [tuple(float(c) for c in p) for p in pts]


def _real_context(fmt_name):
    fmt = FORMATS[fmt_name][0]
    if fmt.kind == "numpy":
        return NumpyContext(fmt.dtype)
    if fmt.kind == "mp":
        return MpContext(fmt.bits)
    return FloatContext()


def lower_pairs(dim, split):
    """Every pair (face of the first primitive, face of the second) except the pair itself,
    with the predicate that registers it and the argument order."""
    s1, s2 = split
    out = []
    from itertools import combinations
    for i in range(1, len(s1) + 1):
        for j in range(1, len(s2) + 1):
            if (i, j) == (len(s1), len(s2)):
                continue
            for f1 in combinations(s1, i):
                for f2 in combinations(s2, j):
                    pair = pair_predicate(dim, i, j)
                    if pair is None:
                        continue
                    pred, swap = pair
                    out.append((pred, (f2 + f1) if swap else (f1 + f2), f1 + f2))
    return out


def registered_sub_pairs(spec: PredicateSpec, cfg: Config) -> list:
    """The lower sub-pairs whose predicate says TRUE in the working format (the real
    predicate code, in the real context of that format). Empty: no degeneracy."""
    info = cfg.info
    names = "".join(spec.split)
    by_name = dict(zip(names, cfg.points))
    out = []
    for pred, args, faces in lower_pairs(cfg.dim, spec.split):
        pts = _working_points(cfg.fmt_name, [by_name[a] for a in args])
        hit, _ = pred(*pts, info.real, ctx=_real_context(cfg.fmt_name))
        if bool(np.all(hit)):
            out.append(f"{pred.name}({''.join(args)})")
    return out


@dataclass
class Outcome:
    """What one run measured."""

    ratios: dict = field(default_factory=dict)      # quantity -> E ratio (float)
    rratios: dict = field(default_factory=dict)     # quantity -> R ratio (float)
    stress: dict = field(default_factory=dict)      # check index -> stress (float)
    flip: dict = field(default_factory=dict)        # bracket check -> closeness to a flip
    mid: dict = field(default_factory=dict)         # bracket check -> exact decision at T
    zone: set = field(default_factory=set)          # check indices with exact x in [T-, T+]
    checks: set = field(default_factory=set)        # check indices evaluated
    violations: list = field(default_factory=list)
    undecided: set = field(default_factory=set)
    premise_failed: set = field(default_factory=set)  # sign tests whose premise fails
    result: object = None


#: A sign test without a guard needs its premise (no registered lower sub-pair) checked
#: when its stress reaches this share (or it disagrees, or is undecided).
PREMISE_STRESS = 0.05


def evaluate(spec: PredicateSpec, cfg: Config, pred=None) -> Outcome:
    fmt = FORMATS[cfg.fmt_name][0]
    info = cfg.info
    ctx = run_shadow(spec, cfg, pred)
    out = Outcome(result=ctx.result)
    L = info.L
    r_floor = (None if fmt.min_normal is None else fmt.min_normal * 2 ** (fmt.bits + 8))
    for name, s in ctx.quantities.items():
        q = spec.quantities.get(name)
        if q is None or q.E is None:
            continue
        err = s.error()
        if err is None:
            continue
        bound = q.E1[cfg.fmt_name] * L ** q.power
        ratio = float(err / bound) if bound else math.inf
        out.ratios[name] = ratio
        if err > bound:
            out.violations.append({"type": "quantity", "quantity": name, "bound": q.text,
                                   "ratio": ratio, "F": float(s.working_fraction),
                                   "exact": _approx(s.x)})
        R1 = q.R1.get(cfg.fmt_name)
        if R1 is not None:
            mag = lower_fraction(s.x)
            if mag and (r_floor is None or mag >= r_floor):
                rb = R1 * mag
                out.rratios[name] = float(err / rb)
                if err > rb:
                    out.violations.append({"type": "relative", "quantity": name,
                                           "bound": q.text, "ratio": float(err / rb),
                                           "F": float(s.working_fraction)})
    cks = spec.checks
    if len(ctx.checks) > len(cks):
        raise AssertionError(f"{spec.key}: the shadow run recorded more checks than the "
                             "instrumented run")
    sub_pairs = None
    for c in ctx.checks:
        cs = cks[c.index]
        if cs.rel != c.rel:
            raise AssertionError(f"{spec.key}: check {c.index} is {c.rel} in the shadow run "
                                 f"but {cs.rel} in the instrumented run")
        out.checks.add(c.index)
        d = bool(c.decision)
        if cs.kind == "bracket":
            _bracket(c, cs, d, out)
            continue
        # sign tests: T- = T+ = 0, the working sign must be the exact sign (premise)
        e = compare(c.lhs.x, Fraction(0))
        exact = None if e is None else e in _SIGN_OK[c.rel]
        stress = _sign_stress(c.lhs)
        if cs.kind == "sign-guarded":
            premise = not bool(ctx.checks[cs.guard].decision)
        elif exact is None or exact != d or stress >= PREMISE_STRESS:
            if sub_pairs is None:
                sub_pairs = registered_sub_pairs(spec, cfg)
            premise = not sub_pairs
        else:
            premise = True  # agrees with a small error: nothing to decide
        if not premise:
            if exact is None or exact != d:
                out.premise_failed.add(c.index)
            continue
        out.stress[c.index] = stress
        if exact is None:
            out.undecided.add(c.index)
        elif exact != d:
            out.violations.append({"type": "sign", "check": c.index, "line": cs.line,
                                   "label": cs.label, "working": d, "exact": exact,
                                   "F": float(c.lhs.working_fraction),
                                   "x": _approx(c.lhs.x),
                                   "registered_sub_pairs": sub_pairs or []})
    return out


_SIGN_OK = {">": (1,), "<": (-1,), ">=": (1, 0), "<=": (-1, 0)}


def _sgn(x):
    c = compare(x, Fraction(0))
    return -1 if c == -1 else 1


def _approx(x):
    if x is None:
        return None
    if type(x) is Fraction:
        return float(x)
    return float(lower_fraction(x)) * _sgn(x)


def _sign_stress(s):
    err = s.error()
    mag = lower_fraction(s.x)
    if err is None or mag is None:
        return 0.0
    if mag == 0:
        return math.inf if err else 0.0
    return float(err / mag)


def _bracket(c, cs, d, out):
    lo, hi = c.exact_decision("lo"), c.exact_decision("hi")
    out.mid[c.index] = c.exact_decision("mid")
    if lo is None or hi is None:
        out.undecided.add(c.index)
        return
    if lo != hi:
        out.zone.add(c.index)
    # stress: share of the gap consumed by rounding, in the direction that could flip
    Fl, Fr = c.lhs.working_fraction, c.rhs.working_fraction
    dx = _sub_exact(c.lhs.x, c.rhs.x)                  # x − T, exact
    delta = _sub_exact(_sub_exact(Fl, Fr), dx)         # what rounding added to it
    g_lo = lower_fraction(_sub_exact(c.rhs.x, c.rhs.lo))
    g_hi = lower_fraction(_sub_exact(c.rhs.hi, c.rhs.x))
    sd = _sgn(delta) if compare(delta, Fraction(0)) else 0
    dpos = upper_fraction(delta) if sd > 0 else Fraction(0)
    dneg = upper_fraction(delta) if sd < 0 else Fraction(0)
    # stress is measured near the threshold only (T − 2·gap_lo ≤ x ≤ T + 2·gap_hi): far
    # from it a large absolute error is harmless (and typically the relative bound is
    # what protects the check near T, e.g. d² vs σ²)
    if compare(dx, -2 * g_lo) != -1 and compare(dx, 2 * g_hi) != 1:
        out.stress[c.index] = max(float(dpos / g_lo) if g_lo else math.inf * bool(dpos),
                                  float(dneg / g_hi) if g_hi else math.inf * bool(dneg))
    # closeness to a flip: rounding pushing x − T toward the other side, relative to the
    # distance it would have to cover (at least the gap: flips inside [T−, T+] are allowed).
    sx = compare(dx, Fraction(0))
    if sd and sx is not None and sd != sx:
        need = max(lower_fraction(dx), g_lo if sd > 0 else g_hi)
        out.flip[c.index] = float(upper_fraction(delta) / need) if need else math.inf
    else:
        out.flip[c.index] = 0.0
    # the forbidden disagreements (section 3, (1))
    if c.rel in ("<=", "<"):
        bad = (lo and not d) or (d and not hi)
    else:
        bad = (hi and not d) or (d and not lo)
    if bad:
        out.violations.append({"type": "decision", "check": c.index, "line": cs.line,
                               "label": cs.label, "working": d, "exact_at_T-": lo,
                               "exact_at_T+": hi, "F_lhs": float(Fl), "F_rhs": float(Fr),
                               "lhs": _approx(c.lhs.x), "T-": _approx(c.rhs.lo),
                               "T+": _approx(c.rhs.hi)})


def _sub_exact(a, b):
    """a − b on exact values (Fractions or intervals)."""
    return _sub(a, b)


# --------------------------------------------------------------------------------------
# input generation
# --------------------------------------------------------------------------------------
SCENARIOS = (("uniform", 1), ("boxes", 2), ("near", 5), ("flat", 2), ("short", 2),
             ("grid", 1), ("extreme", 1))


class Generator:
    """Random and adversarial configurations for one predicate in one format."""

    def __init__(self, spec: PredicateSpec, fmt_name: str, rng: random.Random,
                 brackets: tuple = ()):
        self.spec, self.fmt_name, self.rng = spec, fmt_name, rng
        self.brackets = brackets
        self.fmt = FORMATS[fmt_name][0]
        self.d = spec.dim
        self.n1, self.n2 = len(spec.split[0]), len(spec.split[1])
        self.np_rng = np.random.default_rng(rng.getrandbits(64))

    # helpers ------------------------------------------------------------------------
    def _unit(self):
        v = self.np_rng.normal(size=self.d)
        return v / np.linalg.norm(v)

    def _k(self):
        return 10 ** self.rng.uniform(-1, 1)

    def _tol(self, info, name):
        """A length: the tolerance ``name`` (power 1), or T/L^(p-1) for an area (p = 2),
        volume (p = 3) or L^4 tolerance, i.e. the height that gives that area/volume
        against elements of length ~L. ``"any"`` picks one at random."""
        if name == "any":
            name = self.rng.choice(sorted(info.floats))
        if name not in info.floats:
            name = "tau"
        p = TABLES[self.d][name].p
        return info.floats[name] / float(info.L) ** (p - 1)

    def finish(self, pts, info, scenario) -> Config:
        """Round to the format (toward zero), clamp to [−L/2, L/2]."""
        h = info.L / 2
        tiny = info.L / 2**100
        out = []
        for p in pts:
            q = []
            for v in p:
                f = Fraction(float(v)) if math.isfinite(v) else Fraction(0)
                f = self.fmt.round(f, "z")
                if f > h:
                    f = h
                elif f < -h:
                    f = -h
                if abs(f) < tiny:
                    f = Fraction(0)
                q.append(f)
            out.append(tuple(q))
        return Config(self.d, self.fmt_name, info.L_ab, tuple(out), scenario, self.brackets)

    # scenarios ----------------------------------------------------------------------
    def sample(self) -> Config:
        L_ab = self.rng.choice(SCALES)
        info = tolerance_info(self.d, self.fmt_name, *L_ab, self.brackets)
        names, weights = zip(*SCENARIOS)
        scen = self.rng.choices(names, weights)[0]
        pts = getattr(self, "_" + scen)(info)
        if self.rng.random() < 0.15:
            pts = self._snap_extremes(pts, info)
            scen += "+extreme"
        return self.finish(pts, info, scen)

    def _uniform(self, info):
        h = float(info.L) / 2
        return [self.np_rng.uniform(-h, h, self.d) for _ in range(self.n1 + self.n2)]

    def _boxes(self, info):
        h = float(info.L) / 2
        La, Lb = info.L_ab
        s1 = La * self.rng.uniform(0.3, 1.0)
        s2 = Lb * self.rng.uniform(0.3, 1.0)
        c1 = self.np_rng.uniform(-h + s1 / 2, h - s1 / 2, self.d) if s1 < 2 * h else np.zeros(self.d)
        c2 = c1 + self.np_rng.uniform(-1, 1, self.d) * (s1 + s2) / 2
        p1 = [c1 + self.np_rng.uniform(-s1 / 2, s1 / 2, self.d) for _ in range(self.n1)]
        p2 = [c2 + self.np_rng.uniform(-s2 / 2, s2 / 2, self.d) for _ in range(self.n2)]
        return p1 + p2

    def _point_on(self, face):
        w = self.np_rng.dirichlet(np.ones(len(face)))
        r = self.rng.random()
        if len(face) > 1 and r < 0.3:  # on a sub-face, or just outside it
            k = self.rng.randrange(len(face))
            w[k] = 0 if r < 0.15 else -abs(self.np_rng.normal()) * 0.05
            w = w / w.sum()
        return sum(wi * p for wi, p in zip(w, face))

    def _normal_to(self, face):
        v = self._unit()
        if len(face) >= 2:
            basis = []
            for p in face[1:]:
                e = np.array(p - face[0], dtype=float)
                for b in basis:
                    e = e - (e @ b) * b
                n = np.linalg.norm(e)
                if n > 0:
                    basis.append(e / n)
            for b in basis:
                v = v - (v @ b) * b
            n = np.linalg.norm(v)
            v = v / n if n > 0 else self._unit()
        return v

    def _near(self, info):
        pts = self._boxes(info) if self.rng.random() < 0.6 else self._uniform(info)
        for _ in range(self.rng.choice((1, 1, 2, 3))):
            opts = [(i, j) for i in range(1, self.n1 + 1) for j in range(1, self.n2 + 1)
                    if i + j <= self.d + 1 and (i, j) in NEAR_TOL]
            if not opts:
                opts = [(1, 1)]
            i, j = self.rng.choice(opts)
            f1 = self.rng.sample(range(self.n1), i)
            f2 = self.rng.sample(range(self.n1, self.n1 + self.n2), j)
            X = self._point_on([pts[k] for k in f1])
            Y = self._point_on([pts[k] for k in f2])
            T = self._tol(info, self.rng.choice([NEAR_TOL[(i, j)], NEAR_TOL[(i, j)], "sigma_hat",
                                                 "any", "any"]))
            off = (self._normal_to([pts[k] for k in f1]) if self.rng.random() < 0.6
                   else self._unit()) * self._k() * T
            if self.rng.random() < 0.05:
                off = off * 0
            shift = X + off - Y
            move = range(self.n1, self.n1 + self.n2)
            if self.rng.random() < 0.5:  # move only the face, or the whole primitive
                move = f2
            for k in move:
                pts[k] = pts[k] + shift
        return pts

    def _flat(self, info):
        pts = self._boxes(info) if self.rng.random() < 0.5 else self._uniform(info)
        n = self._unit()
        o = pts[0]
        names = ["sigma", "tau", "delta", "gamma", "sigma_hat", "any", "any", "any"]
        out = []
        line = self.d == 3 and self.rng.random() < 0.3
        m = self._unit()
        T = self._tol(info, self.rng.choice(names))  # one scale for the whole sample
        for p in pts:
            q = p - ((p - o) @ n) * n
            if line:
                q = q - ((q - o) @ m) * m
            q = q + n * self.rng.choice((-1, 1)) * self._k() * T * (self.rng.random() < 0.9)
            out.append(q)
        return out

    def _short(self, info):
        pts = self._boxes(info)
        which = range(self.n1) if (self.rng.random() < 0.5 and self.n1 > 1) or self.n2 == 1 \
            else range(self.n1, self.n1 + self.n2)
        which = list(which)
        if len(which) < 2:
            return pts
        c = sum(pts[k] for k in which) / len(which)
        if self.rng.random() < 0.5:  # tiny element, size ~ a tolerance
            T = self._tol(info, self.rng.choice(["sigma_hat", "sigma", "tau", "delta"]))
            size = max(np.linalg.norm(pts[k] - c) for k in which) or 1.0
            s = self._k() * T / size
            for k in which:
                pts[k] = c + (pts[k] - c) * s
        else:  # sliver: squash along one direction
            n = self._unit()
            f = 10 ** -self.rng.uniform(0, 9)
            for k in which:
                v = pts[k] - c
                pts[k] = c + v - (1 - f) * (v @ n) * n
        return pts

    def _grid(self, info):
        h = float(info.L) / 2
        g = 2 ** self.rng.randint(1, 4)
        pts = [np.array([self.rng.randint(-g, g) * h / g for _ in range(self.d)])
               for _ in range(self.n1 + self.n2)]
        if self.rng.random() < 0.5:
            k = self.rng.randrange(len(pts))
            T = self._tol(info, self.rng.choice(["sigma", "tau", "delta", "gamma", "any"]))
            pts[k] = pts[k] + self._unit() * self._k() * T
        return pts

    def _extreme(self, info):
        h = float(info.L) / 2
        pts = [np.array([self.rng.choice((-h, h)) for _ in range(self.d)])
               for _ in range(self.n1 + self.n2)]
        for p in pts:
            for a in range(self.d):
                if self.rng.random() < 0.5:
                    p[a] -= np.sign(p[a]) * float(info.L) * 2.0 ** -self.rng.randint(1, 60)
        return pts

    def _snap_extremes(self, pts, info):
        h = float(info.L) / 2
        pts = [np.array(p, dtype=float) for p in pts]
        for p in pts:
            for a in range(self.d):
                if self.rng.random() < 0.3:
                    p[a] = h if p[a] >= 0 else -h
        return pts

    # local moves for the search -------------------------------------------------------
    def perturb(self, cfg: Config) -> Config:
        info = cfg.info
        h = info.L / 2
        pts = [list(p) for p in cfg.points]
        r = self.rng.random()
        i = self.rng.randrange(len(pts))
        if r < 0.5:  # a few ulps .. many ulps on one coordinate
            a = self.rng.randrange(self.d)
            c = pts[i][a]
            ulp = self.fmt.ulp(c) if c else self.fmt.ulp(info.L) * 2 ** -self.rng.randint(0, 40)
            pts[i][a] = c + self.rng.choice((-1, 1)) * ulp * 2 ** int(self.rng.expovariate(0.25))
        elif r < 0.85:  # a random step of a random scale on one point
            s = float(info.L) * 2.0 ** -self.rng.uniform(2, 45)
            for a in range(self.d):
                pts[i][a] = pts[i][a] + Fraction(float(self.np_rng.normal() * s))
        elif r < 0.93:  # snap one coordinate to the box extremes
            a = self.rng.randrange(self.d)
            pts[i][a] = h if pts[i][a] >= 0 else -h
        else:  # copy a coordinate of another point (exact alignment)
            a = self.rng.randrange(self.d)
            pts[i][a] = pts[self.rng.randrange(len(pts))][a]
        return cfg.with_points(self._fit(pts, h), cfg.scenario.split("+search")[0] + "+search")

    def _fit(self, pts, h):
        out = []
        for p in pts:
            q = []
            for v in p:
                v = self.fmt.round(v, "z")
                q.append(min(max(v, -h), h))
            out.append(tuple(q))
        return out

    def between(self, c0: Config, c1: Config, t: Fraction) -> Config:
        """The configuration (1 − t)·c0 + t·c1, rounded to the format (same scale)."""
        pts = [[a + t * (b - a) for a, b in zip(p, q)] for p, q in zip(c0.points, c1.points)]
        return c0.with_points(self._fit(pts, c0.info.L / 2), "zone-bisection")


# --------------------------------------------------------------------------------------
# the audit
# --------------------------------------------------------------------------------------
@dataclass
class Stat:
    """Running statistics of one quantity or check in one format."""

    count: int = 0
    worst: float = 0.0
    worst_cfg: Config | None = None
    evaluated: int = 0
    zone: int = 0
    undecided: int = 0
    premise_failed: int = 0
    violations: int = 0
    seeds: list = field(default_factory=list)   # (value, Config), best first
    flip: float = 0.0
    flip_seeds: list = field(default_factory=list)

    def add_flip(self, value, cfg, keep=3):
        self.flip = max(self.flip, value)
        if value > 0 and (len(self.flip_seeds) < keep or value > self.flip_seeds[-1][0]):
            self.flip_seeds.append((value, cfg))
            self.flip_seeds.sort(key=lambda t: -t[0])
            del self.flip_seeds[keep:]

    def add(self, value, cfg, keep=3):
        self.count += 1
        if value > self.worst or self.worst_cfg is None:
            self.worst, self.worst_cfg = value, cfg
        if value > 0 and (len(self.seeds) < keep or value > self.seeds[-1][0]):
            self.seeds.append((value, cfg))
            self.seeds.sort(key=lambda t: -t[0])
            del self.seeds[keep:]


class Audit:
    """The audit of a set of predicates in a set of formats (see module docstring).

    ``brackets``: bracket overrides ((name, T− coefficient, T+ coefficient), ...) — a
    way for tests to plant a wrong tolerance bracket; ``bound_fn`` replaces
    :func:`fperr.bounds` (tests plant a wrong bound with it).
    """

    def __init__(self, preds=None, formats=("binary64", "binary32", "mp17"),
                 samples=DEFAULT_SAMPLES, search_steps=DEFAULT_SEARCH, seed=0, bound_fn=None,
                 progress=None, brackets: tuple = (), zone_pairs: int = 2, zone_steps: int = 72,
                 audit_tolerances: bool = True):
        preds = preds if preds is not None else [p for d in (2, 3) for p in predicates.ALL[d]]
        self.specs = [p if isinstance(p, PredicateSpec) else
                      (spec_for(p) if bound_fn is None else PredicateSpec(p, bound_fn))
                      for p in preds]
        self.formats = tuple(formats)
        self.samples = samples
        self.search_steps = search_steps
        self.seed = seed
        self.progress = progress
        self.brackets = tuple(brackets)
        self.zone_pairs = zone_pairs
        self.zone_steps = zone_steps
        self.do_tolerances = audit_tolerances
        self.q: dict = {}       # (key, fmt, quantity) -> Stat
        self.r: dict = {}       # (key, fmt, quantity) -> Stat (relative)
        self.c: dict = {}       # (key, fmt, check index) -> Stat
        self.sides: dict = {}   # (key, fmt, check, L_ab, exact decision at T) -> [Config]
        self.violations: list = []
        self.n_violations = 0
        self.runs = 0
        self.tolerance_rows: list = []
        self.elapsed = 0.0

    # bookkeeping ----------------------------------------------------------------------
    def _record(self, spec, fmt, cfg, out: Outcome):
        self.runs += 1
        for name, v in out.ratios.items():
            self.q.setdefault((spec.key, fmt, name), Stat()).add(v, cfg)
        for name, v in out.rratios.items():
            self.r.setdefault((spec.key, fmt, name), Stat()).add(v, cfg)
        for k in out.checks:
            st = self.c.setdefault((spec.key, fmt, k), Stat())
            if k in out.stress:
                st.add(out.stress[k], cfg)
            if k in out.flip:
                st.add_flip(out.flip[k], cfg)
            st.evaluated += 1
            st.zone += k in out.zone
            st.undecided += k in out.undecided
            st.premise_failed += k in out.premise_failed
        for k, m in out.mid.items():
            if m is None:
                continue
            lst = self.sides.setdefault((spec.key, fmt, k, cfg.L_ab, m), [])
            if len(lst) < 4:
                lst.append(cfg)
        for v in out.violations:
            self.n_violations += 1
            if "check" in v:
                self.c[(spec.key, fmt, v["check"])].violations += 1
            rec = dict(v, predicate=spec.key, format=fmt, config=cfg.to_json())
            if sum(x["predicate"] == spec.key for x in self.violations) < 20:
                self.violations.append(rec)

    def _eval(self, spec, fmt, cfg):
        out = evaluate(spec, cfg)
        self._record(spec, fmt, cfg, out)
        return out

    # phases -----------------------------------------------------------------------------
    def run(self):
        t0 = time.perf_counter()
        if self.do_tolerances:
            self.audit_tolerances()
        for spec in self.specs:
            for fmt in self.formats:
                spec.bound_coefficients(fmt)
                rng = random.Random(zlib.crc32(f"{self.seed}/{spec.key}/{fmt}".encode()))
                gen = Generator(spec, fmt, rng, self.brackets)
                for _ in range(self.samples):
                    self._eval(spec, fmt, gen.sample())
                if self.zone_pairs:
                    self.zone(spec, fmt, gen)
                if self.search_steps:
                    self.search(spec, fmt, gen)
                if self.progress:
                    self.progress(spec, fmt)
        self.elapsed = time.perf_counter() - t0
        return self

    def zone(self, spec, fmt, gen: Generator):
        """Land inputs on each bracket check's threshold: bisect between two samples of the
        same scale whose exact decisions at T differ, where the check is most fragile."""
        for cs in spec.checks:
            if cs.kind != "bracket":
                continue
            pairs = []
            for (key, f, k, L_ab, m), lst in self.sides.items():
                if key == spec.key and f == fmt and k == cs.index and m:
                    other = self.sides.get((key, f, k, L_ab, False), [])
                    pairs += [(a, b) for a in lst for b in other]
            gen.rng.shuffle(pairs)
            for c_true, c_false in pairs[: self.zone_pairs]:
                t0, t1 = Fraction(0), Fraction(1)
                prev, after = None, None
                for _ in range(self.zone_steps):
                    t = (t0 + t1) / 2
                    cand = gen.between(c_true, c_false, t)
                    if cand.points == prev:
                        break
                    prev = cand.points
                    out = self._eval(spec, fmt, cand)
                    m = out.mid.get(cs.index)
                    if m is None:
                        break
                    if cs.index in out.zone and after is None:
                        after = 4  # landed between T- and T+: a few more steps toward T
                    if after is not None:
                        after -= 1
                        if after < 0:
                            break
                    if m:
                        t0 = t
                    else:
                        t1 = t

    def search(self, spec, fmt, gen: Generator):
        """Hill climbing from the worst samples of every quantity (error ratio), every
        sign test (stress) and every bracket check (closeness to a forbidden flip)."""
        targets = []
        for (key, f, name), st in list(self.q.items()):
            if key == spec.key and f == fmt:
                targets.append(("q", name, st.seeds))
        seen_labels = set()
        for (key, f, k), st in list(self.c.items()):
            if key != spec.key or f != fmt:
                continue
            lab = (spec.checks[k].line, spec.checks[k].label)
            if lab in seen_labels:  # duplicate sign leaves share a search
                continue
            seen_labels.add(lab)
            if spec.checks[k].kind == "bracket":
                targets.append(("flip", k, st.flip_seeds))
            else:
                targets.append(("stress", k, st.seeds))
        for kind, name, seeds in targets:
            for value, cfg in list(seeds[:2]):
                cur, cur_v = cfg, value
                for _ in range(self.search_steps):
                    cand = gen.perturb(cur)
                    out = self._eval(spec, fmt, cand)
                    v = {"q": out.ratios, "stress": out.stress, "flip": out.flip}[kind].get(name)
                    if v is None:
                        continue
                    if v >= cur_v:
                        cur, cur_v = cand, v

    def audit_tolerances(self):
        """R[T] of every tolerance: the shared tolerance code run with shadow numbers."""
        for dim in sorted({s.dim for s in self.specs}):
            rb = _tolerance_bounds(dim)
            for fmt_name in self.formats:
                fmt = FORMATS[fmt_name][0]
                e = sympy.Rational(fmt.eps.numerator, fmt.eps.denominator)
                for L_ab in SCALES:
                    info = tolerance_info(dim, fmt_name, *L_ab)
                    ctx = ShadowContext(fmt)
                    L = info.L
                    with ctx.session():
                        vals = tolerance_values(
                            dim, lambda p: Shadow(fmt.from_fraction(L ** p), L ** p, fmt), ctx)
                    for name, s in vals.items():
                        same = fmt.to_fraction(s.w) == fmt.to_fraction(info.real.values[name])
                        R, text = rb[name]
                        R1 = _lower_fraction_of(R.subs(fperr.eps, e))
                        ratio = float(s.error() / (R1 * lower_fraction(s.x)))
                        self.tolerance_rows.append((dim, fmt_name, L_ab, name, ratio, same,
                                                    text))
                        if ratio > 1 or not same:
                            self.n_violations += 1
                            self.violations.append({
                                "type": "tolerance", "predicate": f"{dim}D tolerances",
                                "format": fmt_name, "tolerance": name, "ratio": ratio,
                                "same_as_predicates.tolerances": same, "L_ab": L_ab})

    # report ---------------------------------------------------------------------------
    def summary(self) -> dict:
        rows_q = []
        for spec in self.specs:
            for name, qs in spec.quantities.items():
                row = {"predicate": spec.key, "quantity": name, "bound": qs.text, "formats": {}}
                for fmt in self.formats:
                    st = self.q.get((spec.key, fmt, name))
                    rs = self.r.get((spec.key, fmt, name))
                    row["formats"][fmt] = {
                        "samples": st.count if st else 0,
                        "max_ratio": st.worst if st else None,
                        "max_relative_ratio": rs.worst if rs else None,
                        "worst": st.worst_cfg.to_json() if st and st.worst_cfg else None}
                rows_q.append(row)
        rows_c = []
        for spec in self.specs:
            merged = {}
            for cs in spec.checks:
                merged.setdefault((cs.line, cs.label), []).append(cs)
            for (line, label), group in merged.items():
                row = {"predicate": spec.key, "line": line, "check": label,
                       "kind": group[0].kind, "formats": {}}
                for fmt in self.formats:
                    sts = [self.c[(spec.key, fmt, cs.index)] for cs in group
                           if (spec.key, fmt, cs.index) in self.c]
                    if not sts:
                        row["formats"][fmt] = {"evaluated": 0}
                        continue
                    best = max(sts, key=lambda s: s.worst)
                    row["formats"][fmt] = {
                        "evaluated": max(s.evaluated for s in sts),
                        "in_zone": sum(s.zone for s in sts),
                        "max_stress": best.worst,
                        "max_flip": max(s.flip for s in sts),
                        "violations": sum(s.violations for s in sts),
                        "undecided": sum(s.undecided for s in sts),
                        "premise_failed": sum(s.premise_failed for s in sts),
                        "worst": best.worst_cfg.to_json() if best.worst_cfg else None}
                rows_c.append(row)
        tol = {}
        for dim, fmt, L_ab, name, ratio, same, text in self.tolerance_rows:
            k = (dim, name)
            t = tol.setdefault(k, {"dim": dim, "tolerance": name, "bound": text, "formats": {}})
            f = t["formats"].setdefault(fmt, {"max_ratio": 0.0, "same": True})
            f["max_ratio"] = max(f["max_ratio"], ratio)
            f["same"] = f["same"] and same
        return {"samples_per_predicate_and_format": self.samples,
                "search_steps": self.search_steps, "seed": self.seed,
                "formats": list(self.formats), "runs": self.runs,
                "elapsed_s": round(self.elapsed, 2), "violation_count": self.n_violations,
                "violations": self.violations, "quantities": rows_q, "checks": rows_c,
                "tolerances": list(tol.values())}


def _fmt_ratio(v):
    if v is None:
        return "—"
    if v == math.inf:
        return "inf"
    return f"{v:.3f}"


def render_markdown(s: dict) -> str:
    fm = s["formats"]
    out = ["# fperr audit: shadow execution against derived bounds", "",
           f"{s['runs']} shadow runs ({s['samples_per_predicate_and_format']} samples per "
           f"predicate and format, {s['search_steps']} hill-climbing steps per seed, seed "
           f"{s['seed']}) in {s['elapsed_s']} s. Formats: {', '.join(fm)}.", ""]
    nv = s["violation_count"]
    out.append(f"**Violations: {nv}**" + ("" if nv else " (every measured error within its "
                                            "bound, every decision within its brackets)"))
    out.append("")
    out += ["## Quantities: max |F[x] − x| / E[x] (soundness ≤ 1; tightness: close to 1)", "",
            "| predicate | quantity | derived bound | " + " | ".join(
                f"{f} E-ratio (R-ratio) | n" for f in fm) + " |",
            "|---|---|---|" + "---|---|" * len(fm)]
    for r in s["quantities"]:
        cells = []
        for f in fm:
            d = r["formats"][f]
            rr = f" ({_fmt_ratio(d['max_relative_ratio'])})" if d["max_relative_ratio"] is not None else ""
            cells.append(f"{_fmt_ratio(d['max_ratio'])}{rr} | {d['samples']}")
        out.append(f"| {r['predicate']} | {r['quantity']} | {r['bound']} | " + " | ".join(cells) + " |")
    out += ["", "## Checks", "",
            "stress: the largest share of the bracket gap (T − T−, T+ − T) that rounding "
            "consumed in the direction that could flip the decision, over samples near the "
            "threshold (T − 2·(T − T−) ≤ x ≤ T + 2·(T+ − T)); for a sign test, |F[x] − x|/|x| "
            "where its premise holds; "
            "flip: the closest approach to a forbidden flip (rounding error over the distance "
            "x would have to cross, at least the gap; ≥ 1 outside [T−, T+] is a violation); "
            "zone: samples whose exact value lay between T− and T+; n: evaluations; "
            "viol.: forbidden disagreements (premise holding).", "",
            "| predicate | line | check | kind | " + " | ".join(
                f"{f} stress / flip / zone / n / viol." for f in fm) + " |",
            "|---|---|---|---|" + "---|" * len(fm)]
    for r in s["checks"]:
        cells = []
        for f in fm:
            d = r["formats"][f]
            if not d.get("evaluated"):
                cells.append("not reached")
                continue
            extra = ""
            if d["premise_failed"]:
                extra += f" ({d['premise_failed']} w/o premise)"
            if d["undecided"]:
                extra += f" ({d['undecided']} undecided)"
            flip = _fmt_ratio(d["max_flip"]) if r["kind"] == "bracket" else "—"
            cells.append(f"{_fmt_ratio(d['max_stress'])} / {flip} / {d['in_zone']} / "
                         f"{d['evaluated']} / **{d['violations']}**{extra}")
        out.append(f"| {r['predicate']} | {r['line']} | `{r['check']}` | {r['kind']} | "
                   + " | ".join(cells) + " |")
    out += ["", "## Tolerances: max |F[T] − T| / (R[T]·T)", "",
            "| dim | tolerance | derived | " + " | ".join(fm) + " |",
            "|---|---|---|" + "---|" * len(fm)]
    for t in s["tolerances"]:
        cells = [(_fmt_ratio(t["formats"][f]["max_ratio"]) +
                  ("" if t["formats"][f]["same"] else " MISMATCH")) if f in t["formats"] else "—"
                 for f in fm]
        out.append(f"| {t['dim']}D | {t['tolerance']} | {t['bound']} | " + " | ".join(cells) + " |")
    if s["violations"]:
        out += ["", "## Violations (reproduce with proofs.audit.replay)", ""]
        for v in s["violations"][:50]:
            out.append("- " + json.dumps(v))
    return "\n".join(out) + "\n"


def replay(violation_or_worst: dict, predicate_key: str | None = None):
    """Re-run a recorded configuration: returns (PredicateSpec, Config, ShadowContext,
    Outcome). Accepts a violation record, or a ``worst`` entry plus ``predicate_key``
    ("3D edge_edge")."""
    key = predicate_key or violation_or_worst["predicate"]
    cfgd = violation_or_worst.get("config", violation_or_worst)
    dim = int(key[0])
    pred = next(p for p in predicates.ALL[dim] if p.name == key.split()[1])
    spec = spec_for(pred)
    cfg = Config.from_json(dim, cfgd)
    spec.bound_coefficients(cfg.fmt_name)
    return spec, cfg, run_shadow(spec, cfg), evaluate(spec, cfg)


def run_audit(**kw) -> dict:
    return Audit(**kw).run().summary()


# --------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------
#: --dtype names (the same as intersect's and demo's) -> audit formats
DTYPES = {"float64": "binary64", "float32": "binary32", "mp17": "mp17"}


def _listed(choices, convert=str):
    """argparse type of the deprecated comma-separated options: every item checked."""
    def parse(text):
        out = []
        for item in (t.strip() for t in text.split(",")):
            if item and convert(item) not in choices:
                raise ValueError(item)
            if item:
                out.append(convert(item))
        return out
    parse.__name__ = "list of " + "/".join(map(str, choices))
    return parse


def add_arguments(parser):
    import argparse

    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                        help=f"random/adversarial samples per predicate and format "
                             f"(default {DEFAULT_SAMPLES}, the CI size)")
    parser.add_argument("--search-steps", type=int, default=DEFAULT_SEARCH,
                        help="hill-climbing steps per seed (2 seeds per quantity and check; "
                             f"default {DEFAULT_SEARCH}; 0 disables the search)")
    parser.add_argument("--format", choices=("md", "json"), default="md",
                        help="report format (default md)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--dtype", choices=tuple(DTYPES), action="append",
                        help="working precision to audit, repeatable (default all three: "
                             "float64, float32 and mp17, mpmath at 17 bits)")
    parser.add_argument("--dim", type=int, choices=(2, 3), action="append",
                        help="dimension to audit, repeatable (default both)")
    # the former names, kept working (same checks, not shown)
    parser.add_argument("--formats", type=_listed(tuple(FORMATS)), help=argparse.SUPPRESS)
    parser.add_argument("--dims", type=_listed((2, 3), int), help=argparse.SUPPRESS)
    parser.add_argument("--predicates", default="",
                        help="comma-separated predicate names to audit (default all)")
    parser.add_argument("-o", "--output", help="also write the report to this file")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")


def run(args) -> int:
    import os

    formats = [DTYPES[d] for d in args.dtype] if args.dtype else \
        (args.formats or ["binary64", "binary32", "mp17"])
    dims = sorted(set(args.dim or args.dims or [2, 3]))
    if args.output:  # checked before the run, not after it
        parent = os.path.dirname(os.path.abspath(args.output))
        if not os.path.isdir(parent) or os.path.isdir(args.output):
            print(f"fperr audit: error: cannot write {args.output} (no directory {parent})"
                  if not os.path.isdir(parent) else
                  f"fperr audit: error: {args.output} is a directory", file=sys.stderr)
            return 2
    wanted = {p.strip() for p in args.predicates.split(",") if p.strip()}
    known = {p.name for d in dims for p in predicates.ALL[d]}
    if wanted - known:
        print(f"fperr audit: error: unknown predicate(s) {', '.join(sorted(wanted - known))}"
              f" in {', '.join(f'{d}D' for d in dims)} (choose from "
              f"{', '.join(sorted(known))})", file=sys.stderr)
        return 2
    preds = [p for d in dims for p in predicates.ALL[d] if not wanted or p.name in wanted]

    def progress(spec, fmt):
        if not args.quiet:
            print(f"  audited {spec.key} in {fmt}", file=sys.stderr)

    audit = Audit(preds, formats, args.samples, args.search_steps, args.seed,
                  progress=progress).run()
    s = audit.summary()
    text = json.dumps(s, indent=1) if args.format == "json" else render_markdown(s)
    print(text)
    if args.output:
        with open(args.output, "w") as fh:
            fh.write(text)
    return 1 if s["violation_count"] else 0
