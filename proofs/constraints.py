"""The constraints the paper's correctness rests on, per algorithm, in two kinds.

**Declared by hand** (geometric facts of the proofs, exact sympy relations between
T−, T, T+ of the tolerance table, each citing its section): :data:`GEOMETRIC`,
the lower bounds that protect sign tests (:data:`PROTECTED`) and divisions
(:data:`NONZERO`), and the geometric lower bounds on m used by the special argument
(:data:`M_LOWER`). Where the paper prints an *equality* that fixes a T+ (κ+ = 2τ−²,
λ+ = 16(τ−² − γ+²)², ...) soundness only needs T+ ≤ the proven lower bound of the
quantity (a rejection "|x| ≤ T" then only discards pairs with |x| ≤ T+, which cannot
intersect); that inequality is what is checked, and the report says whether the table
meets it with equality.

**Generated from an instrumented run** (:class:`predicates.core.Instrumented`) — no
error figure is typed in; every error comes from :func:`fperr.bounds`:

* each comparison of a quantity x against an expression g(T) of one tolerance T
  (a *window*): with E = E[x] + E[g(T)] (``Check.error()``),
      g(T+) − g(T) > E   and   g(T) − g(T−) > E,
  in the units of the check (the check d² ≤ σ² gives a window in σ² units:
  σ+² − σ², σ² − σ−²). When x carries a relative error (r: the paper's
  "R[d²] ≤ 5ε") the error near the threshold is R[x]·g(T±) instead of the
  worst case over all x: g(T+) − g(T) > R[x]·g(T+) + E[g(T)], and likewise below.
  Either is sound; the tighter one is used and the report shows both;
* each sign test (comparison with 0) of a quantity x: the lower bound B that the
  paper's argument gives for |x| when the test is reached must exceed E[x]. B is
  T− when the run rejects |x| ≤ T on the same or an earlier line (section 3, second
  case), else a declared geometric bound (:data:`PROTECTED`, e.g. â > √(σ−² − τ+²)
  in edge-vertex); a sign test with neither is reported as unprotected;
* the check x̂² ≤ T²·q where q has no relative error bound (section 5.4.4: d̂² ≤ γ²m²
  in 3D edge-edge, d̂² ≤ δ²m² in 3D triangle-vertex, line 14): the special argument,
  encoded step by step (:func:`special_argument`).

Homogeneity: every relation is homogeneous in L (checked), which lets the decision
procedure set L = 1 (:mod:`proofs.decide`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import sympy

import fperr
from fperr import InvalidBound, Tracked
from fperr import bounds as _fperr_bounds
from fperr.ops import BY_RULE
from fperr.symbols import L, eps
from predicates.tolerance_table import L_SIGMA_PLUS

from .tables import Values

R = sympy.Rational
SQRT3 = sympy.sqrt(3)

GREEK = {"sigma": "σ", "tau": "τ", "sigma_hat": "σ̂", "kappa": "κ", "delta": "δ",
         "gamma": "γ", "lam": "λ", "phi": "φ", "nu": "ν", "zeta": "ζ", "mu": "μ",
         "xi": "ξ", "rho": "ρ"}

#: length-type tolerances (compared against distances), per dimension
LENGTHS = {2: ("sigma", "tau", "sigma_hat"),
           3: ("sigma", "tau", "delta", "gamma", "sigma_hat")}


def g(name: str, which: str = "") -> str:
    return GREEK.get(name, name) + {"lo": "−", "hi": "+", "": ""}[which]


_BOUNDS_MEMO: dict[int, tuple] = {}


def bounds(t: Tracked, strict: bool = False):
    """:func:`fperr.bounds`, memoised per Tracked object (its state never changes;
    the memo keeps a reference so ids are not reused)."""
    hit = _BOUNDS_MEMO.get(id(t))
    if hit is None or hit[0] is not t:
        hit = _BOUNDS_MEMO[id(t)] = (t, _fperr_bounds(t))
    b = hit[1]
    if strict and not b.valid:
        return _fperr_bounds(t, strict=True)  # raises InvalidBound with the reason
    return b


# -- data model -----------------------------------------------------------------------

@dataclass
class Inequality:
    """lhs > rhs (``strict``) or lhs ≥ rhs, to hold for every ε ∈ (0, 1e-5]."""

    lhs: sympy.Expr
    rhs: sympy.Expr
    strict: bool = True
    label: str = ""


@dataclass
class Step:
    """One step of an argument: a statement and the inequalities that prove it."""

    title: str
    inequalities: list
    explanation: str = ""


@dataclass
class Argument:
    """A proof of a constraint as a sequence of steps (all must hold)."""

    name: str
    steps: list
    note: str = ""


@dataclass
class Constraint:
    """One constraint. It holds when all ``inequalities`` hold and, when ``arguments``
    is non-empty, at least one argument has every step holding. ``error`` marks a
    constraint that could not even be formed (invalid bound, unprotected sign test,
    unsupported comparison): it fails."""

    id: str
    dim: int
    algorithm: str
    section: str
    kind: str          # bracket | setup | geometric | window | sign | nonzero | special
    statement: str
    inequalities: list = field(default_factory=list)
    arguments: list = field(default_factory=list)
    detail: str = ""
    lines: tuple = ()
    printed: str = ""  # the relation as the paper prints it (geometric facts only)
    error: str | None = None
    info: dict = field(default_factory=dict)


# -- declared geometric facts ------------------------------------------------------------

@dataclass(frozen=True)
class Fact:
    """A geometric fact: ``relation(v)`` returns (lhs, rhs) for lhs > rhs (or ≥)."""

    key: str
    section: str
    statement: str
    relation: Callable
    strict: bool = True
    printed: str = ""      # the paper's wording when it differs (e.g. an equality)
    equality: bool = False  # the paper states it as an equality (report says if it is)


def _tm2(v, other):  # τ−² − other+²
    return v.lo("tau") ** 2 - v.hi(other) ** 2


GEOMETRIC: dict[tuple[int, str], list[Fact]] = {
    (2, "edge_vertex"): [
        Fact("tau+<sqrt3/2*sigma-", "4.3",
             "τ+ < (√3/2)·σ−  (Figure 2(a): m ≤ σ− and ‖P−A‖, ‖P−B‖ > σ− give d > τ+)",
             lambda v: (SQRT3 / 2 * v.lo("sigma"), v.hi("tau"))),
        Fact("sigma_hat+<=sigma-", "4.3",
             "σ̂+ ≤ σ−  (a rejected m ≤ σ̂ means m ≤ σ̂+ ≤ σ−: no valid hit is lost)",
             lambda v: (v.lo("sigma"), v.hi("sigma_hat")), strict=False,
             printed="σ− = σ̂+", equality=True),
    ],
    (2, "edge_edge"): [
        Fact("kappa+<=2tau-^2", "4.4",
             "κ+ ≤ 2τ−²  (an intersecting pair has |a_P| > 2τ−²)",
             lambda v: (2 * v.lo("tau") ** 2, v.hi("kappa")), strict=False,
             printed="κ+ = 2τ−²", equality=True),
    ],
    (2, "triangle_vertex"): [
        Fact("kappa+<=2tau-^2", "4.5",
             "κ+ ≤ 2τ−²  (an interior vertex has |a_A|, |a_B|, |a_C| > 2τ−²)",
             lambda v: (2 * v.lo("tau") ** 2, v.hi("kappa")), strict=False,
             printed="κ+ = 2τ−²", equality=True),
    ],
    (3, "edge_vertex"): [
        Fact("tau+<sqrt3/2*sigma-", "5.3", "τ+ < (√3/2)·σ−  (as in 2D, section 4.3)",
             lambda v: (SQRT3 / 2 * v.lo("sigma"), v.hi("tau"))),
        Fact("sigma_hat+<=sigma-", "5.3", "σ̂+ ≤ σ−  (as in 2D, section 4.3)",
             lambda v: (v.lo("sigma"), v.hi("sigma_hat")), strict=False,
             printed="σ− = σ̂+", equality=True),
    ],
    (3, "edge_edge"): [
        Fact("tau->gamma+", "5.4.1",
             "τ− > γ+  (α = √(ℓ(AM)² − ℓ(AA')²) > √(τ−² − γ+²) needs τ− > γ+)",
             lambda v: (v.lo("tau"), v.hi("gamma"))),
        Fact("lam+<=16(tau-^2-gamma+^2)^2", "5.4.1, 5.4.3",
             "λ+ ≤ 16(τ−² − γ+²)²  (an intersecting pair has m > 4(τ−² − γ+²))",
             lambda v: (16 * _tm2(v, "gamma") ** 2, v.hi("lam")), strict=False,
             printed="λ+ = 16(τ−² − γ+²)²", equality=True),
        Fact("phi+<=8(tau-^2-gamma+^2)^2", "5.4.2, 5.4.3",
             "φ+ ≤ 8(τ−² − γ+²)²  (|â|, |ā|, |b̂|, |b̄| > 8(τ−² − γ+²)²)",
             lambda v: (8 * _tm2(v, "gamma") ** 2, v.hi("phi")), strict=False,
             printed="φ+ = 8(τ−² − γ+²)²", equality=True),
    ],
    (3, "triangle_vertex"): [
        Fact("tau->delta+", "5.5.1",
             "τ− > δ+  (ℓ(P'R) > √(τ−² − δ+²) needs τ− > δ+)",
             lambda v: (v.lo("tau"), v.hi("delta"))),
        Fact("nu+<=108(tau-^2-delta+^2)^2", "5.5.1, 5.5.3",
             "ν+ ≤ 108(τ−² − δ+²)²  (m > 6√3(τ−² − δ+²) when P projects inside ABC)",
             lambda v: (108 * _tm2(v, "delta") ** 2, v.hi("nu")), strict=False,
             printed="ν+ = 108(τ−² − δ+²)²", equality=True),
        Fact("zeta+<=12sqrt3(tau-^2-delta+^2)^2", "5.5.2, 5.5.3",
             "ζ+ ≤ 12√3(τ−² − δ+²)²  (|â|, |b̂|, |ĉ| > 2m(τ−² − δ+²))",
             lambda v: (12 * SQRT3 * _tm2(v, "delta") ** 2, v.hi("zeta")), strict=False,
             printed="ζ+ = 12√3(τ−² − δ+²)²", equality=True),
    ],
    (3, "triangle_edge"): [
        Fact("mu+<=4gamma-^2min(gamma-,delta-)", "5.6",
             "μ+ ≤ 4γ−²·min(γ−, δ−)  (|v_A|, |v_B|, |v_C| > 4γ−²·min(γ−, δ−))",
             lambda v: (4 * v.lo("gamma") ** 2 * sympy.Min(v.lo("gamma"), v.lo("delta")),
                        v.hi("mu")), strict=False,
             printed="μ+ = 4γ−²·min(γ−, δ−)", equality=True),
        Fact("xi+<=6sqrt3gamma-^2min(gamma-,delta-)", "5.6",
             "ξ+ ≤ 6√3γ−²·min(γ−, δ−)  (|v_P|, |v_Q| > 6√3γ−²·min(γ−, δ−))",
             lambda v: (6 * SQRT3 * v.lo("gamma") ** 2
                        * sympy.Min(v.lo("gamma"), v.lo("delta")), v.hi("xi")),
             strict=False, printed="ξ+ = 6√3γ−²·min(γ−, δ−)", equality=True),
    ],
    (3, "tetrahedron_vertex"): [
        Fact("rho+<=6sqrt3delta-^3", "5.7",
             "ρ+ ≤ 6√3δ−³  (|v_A|, ..., |v_D| > 6√3δ−³ for an interior vertex)",
             lambda v: (6 * SQRT3 * v.lo("delta") ** 3, v.hi("rho")), strict=False,
             printed="ρ+ = 6√3δ−³", equality=True),
    ],
}


@dataclass(frozen=True)
class Bound:
    """A declared lower bound ``expr(v)`` of a quantity's magnitude, with its reason."""

    section: str
    text: str
    expr: Callable


def _ev_bound():
    return Bound("4.3, Figure 2(b)" , "√(σ−² − τ+²)  (‖P−A‖ > σ− and d ≤ τ+)",
                 lambda v: sympy.sqrt(v.lo("sigma") ** 2 - v.hi("tau") ** 2))


#: Sign tests protected by a declared geometric lower bound (not by a |x| ≤ T check).
PROTECTED: dict[tuple[int, str], dict[str, Bound]] = {
    (2, "edge_vertex"): {"a_hat": _ev_bound(), "a_bar": _ev_bound()},
    (3, "edge_vertex"): {"a_hat": Bound("5.3", _ev_bound().text, _ev_bound().expr),
                         "a_bar": Bound("5.3", _ev_bound().text, _ev_bound().expr)},
}

#: Divisors that must be non-zero: m > 0, enforced by rejecting m ≤ σ̂ (so m > σ̂−).
NONZERO: dict[tuple[int, str], dict[str, Bound]] = {
    (2, "edge_vertex"): {"m": Bound("4.3", "σ̂−  (m ≤ σ̂ is rejected first)",
                                    lambda v: v.lo("sigma_hat"))},
    (3, "edge_vertex"): {"m": Bound("5.3", "σ̂−  (m ≤ σ̂ is rejected first)",
                                    lambda v: v.lo("sigma_hat"))},
}

#: Geometric lower bounds on m (= ‖r‖) when an intersection should be registered;
#: used by the special argument for the rejecting side of line 14.
M_LOWER: dict[tuple[int, str], Bound] = {
    (3, "edge_edge"): Bound("5.4.1", "m > 4(τ−² − γ+²)",
                            lambda v: 4 * _tm2(v, "gamma")),
    (3, "triangle_vertex"): Bound("5.5.1", "m > 6√3(τ−² − δ+²)",
                                  lambda v: 6 * SQRT3 * _tm2(v, "delta")),
}


def table_constraints(dim: int, v: Values) -> list[Constraint]:
    """Section 3 (brackets) and section 4.1/5.1 (the scale L) facts of a table."""
    out = []
    for name in v.tab:
        lo, mid, hi = v.all(name)
        out.append(Constraint(
            f"{dim}D.tolerances.bracket.{name}", dim, "tolerances", "3", "bracket",
            f"0 < {g(name, 'lo')} < {g(name)} < {g(name, 'hi')}",
            [Inequality(lo, sympy.Integer(0), label=f"{g(name, 'lo')} > 0"),
             Inequality(mid, lo, label=f"{g(name)} > {g(name, 'lo')}"),
             Inequality(hi, mid, label=f"{g(name, 'hi')} > {g(name)}")]))
    sec = "4.1" if dim == 2 else "5.1"
    for name in LENGTHS[dim]:
        if name == "sigma":
            continue
        out.append(Constraint(
            f"{dim}D.tolerances.setup.{name}+<=sigma+", dim, "tolerances", sec, "setup",
            f"{g(name, 'hi')} ≤ σ+  (σ+ is the largest tolerance: pairs are processed "
            f"when their boxes are within σ+)",
            [Inequality(v.hi("sigma"), v.hi(name), strict=False)]))
    q = v.tab["sigma"].q
    out.append(Constraint(
        f"{dim}D.tolerances.setup.L", dim, "tolerances", sec, "setup",
        f"σ+ ≤ {L_SIGMA_PLUS}·ε^{q}·L  (L = (1+5ε)/(1−{L_SIGMA_PLUS}ε^{q})·(L_a+L_b) "
        f"bounds every coordinate difference only if σ+ does not exceed the factor "
        f"used in L)",
        [Inequality(L_SIGMA_PLUS * eps**q * L, v.hi("sigma"), strict=False)]))
    return out


def geometric_constraints(dim: int, algorithm: str, v: Values) -> list[Constraint]:
    out = []
    for f in GEOMETRIC.get((dim, algorithm), []):
        lhs, rhs = f.relation(v)
        c = Constraint(f"{dim}D.{algorithm}.geometric.{f.key}", dim, algorithm, f.section,
                       "geometric", f.statement, [Inequality(lhs, rhs, f.strict)],
                       printed=f.printed or f.statement.split("  (")[0])
        if f.equality:
            c.info["equality_holds"] = sympy.simplify(lhs - rhs) == 0
        out.append(c)
    return out


# -- reading checks -------------------------------------------------------------------------

class _Impure(Exception):
    """The expression depends on input coordinates."""


def label(t: Tracked) -> str:
    """Short display label of a Tracked quantity."""
    if t.name:
        return t.name
    if t.rule == "I" and t.args and t.args[0].name:
        return f"|{t.args[0].name}|"
    if t.rule == "A" and t.args and t.args[0].name:
        return f"-{t.args[0].name}"
    return t.s if len(t.s) <= 40 else t.s[:37] + "..."


def tolerance_nodes(t: Tracked, names) -> list[str]:
    """Tolerances (by name) an expression is built from, without descending into them."""
    out, stack, seen = [], [t], set()
    while stack:
        x = stack.pop()
        if id(x) in seen:
            continue
        seen.add(id(x))
        if x.s in names:
            if x.s not in out:
                out.append(x.s)
            continue
        stack.extend(x.args)
    return out


def exact_value(t: Tracked, env: dict) -> sympy.Expr:
    """The exact value of a Tracked expression whose leaves are tolerances (env:
    name → value) and constants; raises _Impure on an input coordinate."""
    if t.s in env:
        return env[t.s]
    if t.rule == "J":
        c = t.state.c
        return c if t.state.n else -c
    if t.rule == "K":
        raise _Impure(t.s)
    if t.rule not in BY_RULE:
        raise ValueError(f"unknown rule {t.rule} in {t.s}")
    return BY_RULE[t.rule].exact(*(exact_value(x, env) for x in t.args))


def _monomial_in(gexpr: sympy.Expr, T: sympy.Symbol):
    """(c, k) when gexpr = c·T^k with a positive constant c and k > 0, else None."""
    c, k = gexpr.as_coeff_exponent(T)
    if c.free_symbols or not (c.is_positive and k.is_positive):
        return None
    return c, k


def _ids(labels) -> str:
    """Quantity labels as they appear in constraint ids (no '|', no spaces)."""
    return ",".join(x.replace("|", "").replace(" ", "") for x in labels)


def fmt(e) -> str:
    """Compact display of an expression in ε and L."""
    if isinstance(e, str):
        return e
    t = sympy.sstr(e, order="none")
    for a, b in (("**", "^"), ("sqrt(", "√("), ("eps", "ε"), ("*", "·")):
        t = t.replace(a, b)
    return t


# -- windows, signs, special ------------------------------------------------------------

@dataclass
class _Window:
    tol: str
    gexpr: sympy.Expr           # g(T) with T a symbol
    T: sympy.Symbol
    relative: bool
    E_lhs: sympy.Expr | None
    R_lhs: sympy.Expr | None
    E_rhs: sympy.Expr
    labels: list
    lines: list


def _window_constraint(dim, alg, w: _Window, v: Values) -> Constraint:
    lo, mid, hi = v.all(w.tol)
    gl, gm, gh = (w.gexpr.subs(w.T, x) for x in (lo, mid, hi))
    Tn = g(w.tol)
    gtxt = fmt(w.gexpr).replace(str(w.T), Tn)
    gsym = lambda which: gtxt.replace(Tn, g(w.tol, which)) if which else gtxt
    what = ", ".join(w.labels)
    if w.relative:
        up_err = w.R_lhs * gh + w.E_rhs
        lo_err = w.R_lhs * gl + w.E_rhs
        stmt = (f"{gsym('hi')} − {gtxt} > R[x]·{gsym('hi')} + E[{gtxt}] and "
                f"{gtxt} − {gsym('lo')} > R[x]·{gsym('lo')} + E[{gtxt}]")
        detail = (f"x ∈ {{{what}}} has relative error R[x] ≤ {fmt(w.R_lhs)}; "
                  f"E[{gtxt}] ≤ {fmt(w.E_rhs)}")
        if w.E_lhs is not None:
            detail += f" (absolute form E[x] + E[{gtxt}] = {fmt(w.E_lhs + w.E_rhs)})"
    else:
        up_err = lo_err = w.E_lhs + w.E_rhs
        stmt = (f"min({gsym('hi')} − {gtxt}, {gtxt} − {gsym('lo')}) > "
                f"E[x] + E[{gtxt}]")
        detail = f"E[x] + E[{gtxt}] = {fmt(up_err)} for x ∈ {{{what}}}"
    c = Constraint(
        f"{dim}D.{alg}.window.{w.tol}[{_ids(w.labels)}]", dim, alg,
        "3", "window", stmt,
        [Inequality(gh - gm, up_err, label=f"{gsym('hi')} − {gtxt} (upper window)"),
         Inequality(gm - gl, lo_err, label=f"{gtxt} − {gsym('lo')} (lower window)")],
        detail=detail, lines=tuple(sorted(set(w.lines))))
    c.info.update(tol=w.tol, g=w.gexpr.subs(w.T, sympy.Symbol(w.tol)), relative=w.relative,
                  error=up_err if not w.relative else None,
                  abs_error=(w.E_lhs + w.E_rhs) if w.E_lhs is not None else None,
                  quantities=list(w.labels))
    return c


def special_argument(dim, alg, chk, x: Tracked, tt: Tracked, T: str, q: Tracked,
                     Tm: str, v: Values, m_geo: Bound | None,
                     lower_line: int | None = None) -> Constraint:
    """Section 5.4.4: the check x² ≤ T²·q (x = d̂, q = m² with no relative bound).

    The automatic rules give E[m²] but not R[m²]; the check on q (m² ≤ λ, line 9) is
    what bounds m² from below once passed: m² > λ−. Two arguments are encoded; the
    constraint holds when either holds for every ε:

    * the paper's (5.4.4), with its structural constants 1/7 and 2/35:
      R[m²] < E[m²]/λ−; R[γ²m²] ≤ (1+R[γ²])(1+R[m²])(1+ε) − 1 < 1/7, so
      E[γ²m²] < γ²m²/7; with g(x) = (8/7·γ²m² + x)ε + 2√(8/7·γ²m² + x)·E[d̂](1+ε)
      + E[d̂]²(1+ε) − x: g(2/35·γ²m²) < 0 and g'(x) < 0 for x ≥ 2/35·γ²m², hence
      E[d̂²] < 2/35·γ²m², and the conclusions 1 + 1/7 + 2/35 = 6/5 ≤ γ+²/γ² and
      1 − 1/7 − 2/35 = 4/5 ≥ γ−²/γ². The steps need a lower bound y0 on γm: on the
      accepting side (d̂² > γ+²m² must be rejected, whether or not the pair
      intersects) only m ≥ √λ− is known; on the rejecting side (a pair with d ≤ γ−
      that should intersect) the geometric bound of section 5.4.1 (m > 4(τ−² − γ+²))
      applies. The paper uses the latter for both sides.
    * a direct two-sided bound: F[d̂²] ≥ (|d̂| − E[d̂])²(1 − ε), F[d̂²] ≤ (|d̂| + E[d̂])²
      (1 + ε), F[γ²m²] = γ²m²(1 ± ρ), ρ = (1+R[γ²])(1+E[m²]/λ−)(1+ε) − 1, so
      accepting side: (γ+ − E[d̂]/√λ−)²(1 − ε) > γ²(1 + ρ) (with γ+ > E[d̂]/√λ−);
      rejecting side: (γ− + E[d̂]/m_geo)²(1 + ε) < γ²(1 − ρ).
    """
    Tsym = g(T)
    E_d = bounds(x, strict=True).E
    R_TT = bounds(tt, strict=True).R
    E_q = bounds(q, strict=True).E
    Tlo, Tn, Thi = v.all(T)
    Tm_lo = v.lo(Tm)
    m_acc = sympy.sqrt(Tm_lo)
    rho_m = E_q / Tm_lo
    rho_Y = (1 + R_TT) * (1 + rho_m) * (1 + eps) - 1
    xq = f"{label(x)}²"
    info = {"E_d": E_d, "R_TT": R_TT, "E_q": E_q, "Tm": Tm, "T": T, "rho_m": rho_m,
            "rho_Y": rho_Y, "line": chk.line, "lower_line": lower_line}

    def h(y):  # g(2/35·y²) with y = γm
        return (y**2 * (R(6, 5) * eps - R(2, 35)) + 2 * sympy.sqrt(R(6, 5)) * y * E_d * (1 + eps)
                + E_d**2 * (1 + eps))

    def dh(y):
        return 2 * y * (R(6, 5) * eps - R(2, 35)) + 2 * sympy.sqrt(R(6, 5)) * E_d * (1 + eps)

    common = [
        Step(f"R[m²] < E[m²]/{g(Tm, 'lo')} < 1",
             [Inequality(sympy.Integer(1), rho_m)],
             f"m² > {g(Tm, 'lo')} once '{label(q)} ≤ {g(Tm)}' (line {lower_line}) is "
             f"passed; derived E[m²] = "
             f"{fmt(E_q)}, so R[m²] < {fmt(rho_m)}"),
        Step(f"R[{Tsym}²m²] ≤ (1+R[{Tsym}²])(1+R[m²])(1+ε) − 1 < 1/7, "
             f"so E[{Tsym}²m²] < {Tsym}²m²/7",
             [Inequality(R(1, 7), rho_Y)],
             f"derived R[{Tsym}·{Tsym}] = {fmt(R_TT)}"),
    ]

    def chain(side, y0, y0txt):
        return [
            Step(f"g(2/35·{Tsym}²m²) < 0 for {Tsym}m = {y0txt} ({side})",
                 [Inequality(sympy.Integer(0), h(y0))],
                 f"g(2/35·y²) = y²(6/5·ε − 2/35) + 2√(6/5)·y·E[d̂](1+ε) + E[d̂]²(1+ε), "
                 f"E[d̂] = {fmt(E_d)} (derived)"),
            Step(f"... and for every {Tsym}m ≥ {y0txt}: concave, decreasing at {y0txt} "
                 f"({side})",
                 [Inequality(R(2, 35), R(6, 5) * eps, label="6/5·ε < 2/35"),
                  Inequality(sympy.Integer(0), dh(y0), label="d/dy g(2/35·y²) < 0")]),
            Step(f"g'(x) ≤ ε + E[d̂](1+ε)/({Tsym}m) − 1 < 0 for x ≥ 2/35·{Tsym}²m² ({side})",
                 [Inequality(sympy.Integer(1), eps + E_d * (1 + eps) / y0)],
                 "hence g(x) < 0 for x ≥ 2/35·γ²m²; as g(E[d̂²]) ≥ 0, E[d̂²] < 2/35·γ²m²"),
        ]

    args = []
    acc_txt = f"{Tsym}·√{g(Tm, 'lo')}"
    steps = common + chain("accepting side: m ≥ √" + g(Tm, "lo"), Tn * m_acc, acc_txt)
    steps.append(Step(f"accepting ⇒ d̂² ≤ {Tsym}+²m²: (1 + 1/7 + 2/35)·{Tsym}² = 6/5·{Tsym}² "
                      f"≤ {Tsym}+²", [Inequality(Thi**2, R(6, 5) * Tn**2, strict=False)]))
    geo = m_geo.text.split("> ")[-1] if m_geo is not None else "a geometric bound"
    note = (f"the paper bounds {Tsym}m from below by {Tsym}·{geo} on both sides; that bound "
            "holds only when the pair should be registered, and the accepting side must "
            f"also hold when it does not, where only m² > {g(Tm, 'lo')} is known (used here)")
    never = [Inequality(sympy.Integer(0), sympy.Integer(1), label="no bound declared")]
    if m_geo is not None:
        mg = m_geo.expr(v)
        geo_txt = f"{Tsym}·{m_geo.text.split('> ')[-1]}"
        steps += chain(f"rejecting side: {m_geo.text} ({m_geo.section})", Tn * mg, geo_txt)
        steps.append(Step(f"rejecting ⇒ d̂² > {Tsym}−²m²: (1 − 1/7 − 2/35)·{Tsym}² = "
                          f"4/5·{Tsym}² ≥ {Tsym}−²",
                          [Inequality(R(4, 5) * Tn**2, Tlo**2, strict=False)]))
    else:
        steps.append(Step("rejecting side: no geometric lower bound on m is declared for "
                          "this algorithm (proofs.constraints.M_LOWER)", never))
    args.append(Argument("paper's argument (5.4.4)", steps, note))

    direct_steps = [
        Step(f"{Tsym}+ > E[d̂]/√{g(Tm, 'lo')}",
             [Inequality(Thi, E_d / m_acc)],
             "so that |d̂| > γ+m implies |F[d̂]| ≥ |d̂| − E[d̂] > 0"),
        Step(f"accepting ⇒ d̂² ≤ {Tsym}+²m²: (γ+ − E[d̂]/√{g(Tm, 'lo')})²(1−ε) > "
             f"{Tsym}²(1+ρ)".replace("γ", Tsym),
             [Inequality((Thi - E_d / m_acc) ** 2 * (1 - eps), Tn**2 * (1 + rho_Y))],
             f"ρ = (1+R[{Tsym}²])(1+E[m²]/{g(Tm, 'lo')})(1+ε) − 1 bounds the relative error "
             f"of F[{Tsym}²m²] on both sides; m ≥ √{g(Tm, 'lo')}"),
    ]
    if m_geo is not None:
        mg = m_geo.expr(v)
        direct_steps.append(Step(
            f"rejecting ⇒ d̂² > {Tsym}−²m²: (γ− + E[d̂]/m_geo)²(1+ε) < {Tsym}²(1−ρ)"
            .replace("γ", Tsym),
            [Inequality(Tn**2 * (1 - rho_Y), (Tlo + E_d / mg) ** 2 * (1 + eps))],
            f"m_geo: {m_geo.text} (section {m_geo.section}), valid when the pair should "
            f"be registered (d ≤ {Tsym}−)"))
    else:
        direct_steps.append(Step("rejecting side: no geometric lower bound on m is declared "
                                 "for this algorithm (proofs.constraints.M_LOWER)", never))
    args.append(Argument("direct two-sided bound", direct_steps))
    stmt = (f"line {chk.line}: F[{xq}] ≤ F[{Tsym}²·m²] must imply d̂² ≤ {Tsym}+²m², and its "
            f"negation d̂² > {Tsym}−²m²  (tolerance model (1) for {xq} ≤ {Tsym}²m²)")
    c = Constraint(f"{dim}D.{alg}.special.line{chk.line}.{T}^2m^2", dim, alg, "5.4.4",
                   "special", stmt, arguments=args, lines=(chk.line,),
                   detail=(f"E[d̂] = {fmt(E_d)}, E[m²] = {fmt(E_q)}, R[{Tsym}²] = {fmt(R_TT)}, "
                           f"m² > {g(Tm, 'lo')} once line {lower_line} is passed"), info=info)
    return c


def run_constraints(ins, v: Values, algorithm: str | None = None) -> list[Constraint]:
    """The floating-point constraints generated from one instrumented run."""
    dim = ins.dim
    alg = algorithm or ins.algorithm
    names = set(v.tab)
    out: list[Constraint] = []
    windows: dict = {}
    signs: dict = {}
    protected_by_check: dict[int, tuple] = {}
    checks = list(ins.checks)

    def fail(cid, stmt, why, lines=()):
        out.append(Constraint(f"{dim}D.{alg}.{cid}", dim, alg, "3", "window", stmt,
                              lines=tuple(lines), error=why))

    # pass 1: tolerance comparisons (windows) and the protections they give
    for chk in checks:
        if chk.is_sign_test:
            continue
        tols = tolerance_nodes(chk.rhs, names)
        lab = label(chk.lhs)
        if len(tols) != 1:
            fail(f"check[{_ids([lab])}]", str(chk),
                 f"comparison against {len(tols)} tolerances is not supported", [chk.line])
            continue
        T = tols[0]
        Tsym = sympy.Symbol(f"_T_{T}", positive=True)
        try:
            gexpr = exact_value(chk.rhs, {T: Tsym})
        except _Impure:
            sp = _special_pattern(chk, T, names)
            if sp is None:
                fail(f"check[{_ids([lab])}]", str(chk), "the right-hand side depends on the "
                     "inputs and is not of the form T²·q handled by section 5.4.4",
                     [chk.line])
                continue
            x, tt, q = sp
            lower = _lower_bound_check(checks, q, chk, names)
            if lower is None:
                fail(f"special.line{chk.line}", str(chk),
                     f"no earlier check bounds {label(q)} from below", [chk.line])
                continue
            try:
                out.append(special_argument(dim, alg, chk, x, tt, T, q, lower[0], v,
                                            M_LOWER.get((dim, alg)), lower[1]))
            except InvalidBound as e:
                fail(f"special.line{chk.line}", str(chk), str(e), [chk.line])
            continue
        mono = _monomial_in(sympy.expand(gexpr), Tsym)
        if mono is None:
            fail(f"check[{_ids([lab])}]", str(chk), f"{gexpr} is not c·T^k", [chk.line])
            continue
        try:
            bl = bounds(chk.lhs, strict=True)
            br = bounds(chk.rhs, strict=True)
        except InvalidBound as e:
            fail(f"window.{T}[{_ids([lab])}]", str(chk), f"no error bound: {e}", [chk.line])
            continue
        if bl.power != br.power:
            fail(f"window.{T}[{_ids([lab])}]", str(chk),
                 f"compares L^{bl.power} with L^{br.power}", [chk.line])
            continue
        rel = bl.R is not None
        key = (T, sympy.srepr(gexpr), rel, sympy.srepr(bl.E), sympy.srepr(bl.R),
               sympy.srepr(br.E))
        w = windows.get(key)
        if w is None:
            w = windows[key] = _Window(T, gexpr, Tsym, rel, bl.E, bl.R, br.E, [], [])
        if lab not in w.labels:
            w.labels.append(lab)
        w.lines.append(chk.line)
        if chk.lhs.rule == "I" and chk.rel in ("<=", "<"):
            protected_by_check[id(chk.lhs.args[0])] = (T, gexpr.subs(Tsym, v.lo(T)),
                                                      chk.line, gexpr, Tsym)
    for w in windows.values():
        out.append(_window_constraint(dim, alg, w, v))

    # pass 2: sign tests
    declared = PROTECTED.get((dim, alg), {})
    for chk in checks:
        if not chk.is_sign_test:
            continue
        x = chk.lhs
        lab = label(x)
        try:
            bx = bounds(x, strict=True)
        except InvalidBound as e:
            fail(f"sign[{_ids([lab])}]", str(chk), f"no error bound: {e}", [chk.line])
            continue
        prot = protected_by_check.get(id(x))
        if bx.R is not None:
            key = ("relative", sympy.srepr(bx.R))
            entry = signs.setdefault(key, {"labels": [], "lines": [], "kind": "relative",
                                           "R": bx.R})
        elif prot is not None and prot[2] is not None and chk.line is not None \
                and prot[2] <= chk.line:
            T, bexpr = prot[0], prot[1]
            gtxt = fmt(prot[3]).replace(str(prot[4]), g(T, "lo"))
            key = ("check", T, sympy.srepr(bexpr), sympy.srepr(bx.E))
            entry = signs.setdefault(key, {
                "labels": [], "lines": [], "kind": "check", "B": bexpr, "E": bx.E,
                "why": f"|x| > {gtxt}: '|x| ≤ {g(T)}' is rejected on line {prot[2]}",
                "section": "3", "tol": T})
        elif x.name in declared:
            b = declared[x.name]
            bexpr = b.expr(v)
            key = ("declared", b.text, sympy.srepr(bx.E))
            entry = signs.setdefault(key, {"labels": [], "lines": [], "kind": "declared",
                                           "B": bexpr, "E": bx.E,
                                           "why": f"|x| > {b.text}", "section": b.section})
        else:
            fail(f"sign[{_ids([lab])}]", str(chk),
                 "unprotected sign test: no '|x| ≤ T' rejection before it and no declared "
                 "geometric lower bound on |x|", [chk.line])
            continue
        if lab not in entry["labels"]:
            entry["labels"].append(lab)
        entry["lines"].append(chk.line)
    for e in signs.values():
        labs = _ids(e["labels"])
        if e["kind"] == "relative":
            out.append(Constraint(
                f"{dim}D.{alg}.sign[{labs}]", dim, alg, "3", "sign",
                "R[x] < 1 (a relative error below 1 keeps the sign)",
                [Inequality(sympy.Integer(1), e["R"])],
                detail=f"R[x] ≤ {fmt(e['R'])}", lines=tuple(sorted(set(e["lines"])))))
            continue
        c = Constraint(
            f"{dim}D.{alg}.sign[{labs}]", dim, alg, e["section"], "sign",
            f"sign of x ∈ {{{', '.join(e['labels'])}}} exact: {e['why']} > E[x]",
            [Inequality(e["B"], e["E"])],
            detail=f"E[x] = {fmt(e['E'])}", lines=tuple(sorted(set(e["lines"]))))
        c.info.update(error=e["E"], bound=e["B"], quantities=list(e["labels"]),
                      tol=e.get("tol"))
        out.append(c)

    # declared divisors
    for qname, b in NONZERO.get((dim, alg), {}).items():
        xq = ins.quantities.get(qname)
        cid = f"{dim}D.{alg}.nonzero[{qname}]"
        stmt = f"{qname} > 0, enforced by {qname} > {b.text.split('  (')[0]} > E[{qname}]"
        if xq is None:
            out.append(Constraint(cid, dim, alg, b.section, "nonzero", stmt,
                                  error=f"quantity {qname!r} not found in the run"))
            continue
        try:
            E = bounds(xq, strict=True).E
        except InvalidBound as e:
            out.append(Constraint(cid, dim, alg, b.section, "nonzero", stmt, error=str(e)))
            continue
        c = Constraint(cid, dim, alg, b.section, "nonzero", stmt,
                       [Inequality(b.expr(v), E)], detail=f"E[{qname}] = {fmt(E)}")
        c.info.update(error=E, quantities=[qname])
        out.append(c)
    return out


def _special_pattern(chk, T: str, names):
    """(x, T·T node, q) when the check is x·x against (T·T)·q, else None."""
    lhs, rhs = chk.lhs, chk.rhs
    if not (lhs.rule == "F" and len(lhs.args) == 2 and lhs.args[0].s == lhs.args[1].s):
        return None
    if not (rhs.rule == "F" and len(rhs.args) == 2):
        return None
    tt, q = rhs.args
    if tolerance_nodes(q, names):
        tt, q = q, tt
    if tolerance_nodes(q, names) or tolerance_nodes(tt, names) != [T]:
        return None
    Ts = sympy.Symbol("_T", positive=True)
    try:
        if sympy.simplify(exact_value(tt, {T: Ts}) - Ts**2) != 0:
            return None
    except _Impure:
        return None
    if not q.v or q.r:
        return None  # q with a relative error bound would be an ordinary window
    return lhs.args[0], tt, q


def _lower_bound_check(checks, q, chk, names):
    """The tolerance T of an earlier check 'q ≤ T' (rejecting: afterwards q > T−)."""
    for c in checks:
        if c is chk or c.line is None or chk.line is None or c.line >= chk.line:
            continue
        if c.lhs is q and c.rel in ("<=", "<") and not c.is_sign_test:
            tols = tolerance_nodes(c.rhs, names)
            if len(tols) == 1 and c.rhs.s == tols[0]:
                return tols[0], c.line
    return None
