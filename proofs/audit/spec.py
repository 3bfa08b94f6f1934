"""What the audit knows before running anything (:mod:`proofs.audit`): the working
formats, the scales, each predicate's derived bounds and classified checks, the
tolerances of a configuration with their exact brackets, and an input (Config)."""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache

import sympy

import fperr
import predicates
from fperr import to_fraction
from fperr.intervals import interval_from_float
from fperr.shadow import Shadow, ShadowContext
from predicates.catalogue import pair_predicate
from predicates.tolerances import Tolerances, tracked_tolerances

from ..tables import TABLES

#: name -> the working context (fperr.context(name))
FORMATS = {name: fperr.context(name) for name in ("binary64", "binary32", "mp17")}

#: (L_a, L_b): bounding-box edge lengths of the two primitives (long and short elements).
SCALES = [(0.5, 0.5), (0.9, 0.1), (0.1, 0.9), (0.999, 0.001), (0.001, 0.999),
          (1.5, 0.25), (0.75, 0.75), (0.3, 1.7)]

#: Distance tolerance of a near-incidence between faces of i and j vertices: the bracket
#: of the 3D predicate deciding such a pair (the catalogue's), used in 2D too as a scale.
NEAR_TOL = {(i, j): found[0].bracket
            for i in range(1, 4) for j in range(1, 4)
            if (found := pair_predicate(3, i, j)) and found[0].bracket}

DEFAULT_SAMPLES = 100
DEFAULT_SEARCH = 10


# --------------------------------------------------------------------------------------
# static part: bounds and check classification from the instrumented run
# --------------------------------------------------------------------------------------
def lower_fraction_of(expr) -> Fraction:
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
    kind: str          # "bracket" | "sign-guarded" | "sign-geometric"; user predicates:
    #                    "sign-filter", "sign-protected", "sign-unprotected" (proofs.audit.user)
    quantity: str      # the quantity the check tests
    label: str
    guard: int | None = None
    protect: object = None   # sign-filter: θ's label; sign-protected: the declared Bound


class PredicateSpec:
    """A predicate with what the audit needs: bounds, check kinds, its two primitives."""

    def __init__(self, pred, bound_fn=None, split=None, system=None):
        self.pred = pred
        self.system = system   # a user declaration (proofs.user_predicates), or None
        self.dim = pred.dim
        self.name = pred.name
        self.key = f"{pred.dim}D {pred.name}"
        self.split = split or ("".join(pred.sim), "".join(pred.cut))
        if "".join(self.split) != "".join(pred.points):
            raise ValueError(f"{self.key}: split {self.split} does not match points {pred.points}")
        ins = pred.instrumented(None if system is None else system.table())
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
        e = sympy.Rational(1, 2 ** FORMATS[fmt_name].bits)
        for q in self.quantities.values():
            if q.E is None or fmt_name in q.E1:
                continue
            q.E1[fmt_name] = lower_fraction_of(q.E.subs({fperr.eps: e, fperr.L: 1}))
            q.R1[fmt_name] = (None if q.R is None else
                              lower_fraction_of(q.R.subs(fperr.eps, e)))


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
    powers: dict = field(default_factory=dict)   # name -> p (T ∝ L^p)
    thetas: dict = field(default_factory=dict)   # predicate -> {quantity: working θ}


@lru_cache(maxsize=None)
def tolerance_info(dim: int, fmt_name: str, L_a: float, L_b: float,
                   brackets: tuple = (), system=None) -> ToleranceInfo:
    """Tolerances of a configuration. ``brackets``: ((name, lo, hi), ...) replaces the
    coefficients of T−, T+ of Figure 1/5 (tests use it to plant a wrong bracket).
    ``system``: a user declaration (:class:`proofs.user_predicates.PredicateTolerances`):
    its table, computed by its ``tolerances(L_a + L_b, dtype)`` (docs/custom-predicates.md),
    and the working thresholds θ of its sign filters."""
    fmt = FORMATS[fmt_name]
    if system is None:
        real, table, thetas = predicates.tolerances(dim, L_a, L_b, dtype=fmt), TABLES[dim], {}
    else:
        real, table = system.tolerances(L_a + L_b, dtype=fmt), system.table()
        thetas = system.sign_thresholds(L_a + L_b, fmt) if system.declared.filtered else {}
    L = to_fraction(real.L)
    Ls = sympy.Rational(L.numerator, L.denominator)
    override = {name: (lo, hi) for name, lo, hi in brackets}
    vals = {}
    for name, spec in table.items():
        f = sympy.Integer(2) ** (-fmt.bits * sympy.sympify(spec.q)) * Ls ** spec.p
        lo, hi = override.get(name, (spec.lo, spec.hi))
        vals[name] = Shadow.bracketed(real.values[name], _real(sympy.sympify(spec.mid) * f),
                                      _real(sympy.sympify(lo) * f),
                                      _real(sympy.sympify(hi) * f), fmt, label=name)
    shadow = Tolerances(dim, real.L, real.eps, ShadowContext(fmt), vals,
                        None if system is None else table)
    floats = {k: float(v) for k, v in real.values.items()}
    thetas = {p: {q: fmt.to_fraction(v) for q, v in qs.items()} for p, qs in thetas.items()}
    return ToleranceInfo(dim, fmt_name, (L_a, L_b), real, shadow, L, floats,
                         {k: int(v.p) for k, v in table.items()}, thetas)


@lru_cache(maxsize=None)
def tolerance_bounds(dim, system=None):
    """name -> (R[T] as a sympy expression in eps, its text), from the instrumented run
    (of ``system``'s table when given, a user declaration)."""
    out = {}
    table = None if system is None else system.table()
    for name, t in tracked_tolerances(dim, table).values.items():
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
    system: object = None    # a user declaration whose table applies (None: the paper's)

    @property
    def info(self) -> ToleranceInfo:
        return tolerance_info(self.dim, self.fmt_name, *self.L_ab, self.brackets,
                              self.system)

    def with_points(self, pts, scenario=None) -> "Config":
        return Config(self.dim, self.fmt_name, self.L_ab, tuple(pts),
                      self.scenario if scenario is None else scenario, self.brackets,
                      self.system)

    def to_json(self):
        d = {"format": self.fmt_name, "L_a": self.L_ab[0], "L_b": self.L_ab[1],
             "points": [[float(c).hex() for c in p] for p in self.points],
             "scenario": self.scenario}
        if self.brackets:
            d["brackets"] = [[n, str(lo), str(hi)] for n, lo, hi in self.brackets]
        if self.system is not None:
            d["module"] = self.system.name
        return d

    @staticmethod
    def from_json(dim, d):
        pts = tuple(tuple(Fraction(float.fromhex(c)) for c in p) for p in d["points"])
        br = tuple((n, sympy.Rational(lo), sympy.Rational(hi)) for n, lo, hi in d.get("brackets", ()))
        return Config(dim, d["format"], (d["L_a"], d["L_b"]), pts, d.get("scenario", ""), br)

