"""Declared facts of the proofs (:mod:`proofs.constraints`): the geometric relations
between T−, T, T+ each section of the paper relies on, the lower bounds that protect sign
tests and divisions, and the table-wide facts of sections 3, 4.1 and 5.1."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple

import sympy

from fperr.notation import greek
from fperr.symbols import L, eps
from predicates.tolerance_table import L_SIGMA_PLUS

from ..tables import Values
from .model import LENGTHS, Constraint, Inequality

SQRT3 = sympy.sqrt(3)


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


class Declared(NamedTuple):
    """The declared facts a constraint system uses, keyed by (dim, algorithm): the
    paper's (:data:`PAPER`) or a user's (:mod:`proofs.user_predicates`)."""

    geometric: dict
    protected: dict
    nonzero: dict
    m_lower: dict
    #: predicates whose sign tests without a protecting bound are "sign exact or
    #: undecided" (docs/proofs.md, "Sign tests"): (dim, algorithm) → {quantity: Bound
    #: of the threshold θ}, the key "*" with None meaning "θ derived from the sign bound"
    filtered: dict = {}


def table_constraints(dim: int, v: Values, setup: bool = True) -> list[Constraint]:
    """Section 3 (brackets) and section 4.1/5.1 (the scale L) facts of a table;
    ``setup=False``: the brackets only (a user's table has no σ+ that sizes L)."""
    out = []
    for name in v.tab:
        lo, mid, hi = v.all(name)
        out.append(Constraint(
            f"{dim}D.tolerances.bracket.{name}", dim, "tolerances", "3", "bracket",
            f"0 < {greek(name, 'lo')} < {greek(name)} < {greek(name, 'hi')}",
            [Inequality(lo, sympy.Integer(0), label=f"{greek(name, 'lo')} > 0"),
             Inequality(mid, lo, label=f"{greek(name)} > {greek(name, 'lo')}"),
             Inequality(hi, mid, label=f"{greek(name, 'hi')} > {greek(name)}")]))
    if not setup:
        return out
    sec = "4.1" if dim == 2 else "5.1"
    for name in LENGTHS[dim]:
        if name == "sigma":
            continue
        out.append(Constraint(
            f"{dim}D.tolerances.setup.{name}+<=sigma+", dim, "tolerances", sec, "setup",
            f"{greek(name, 'hi')} ≤ σ+  (σ+ is the largest tolerance: pairs are processed "
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


def geometric_constraints(dim: int, algorithm: str, v: Values,
                          declared: Declared | None = None) -> list[Constraint]:
    """The declared geometric facts of ``algorithm`` (the paper's unless ``declared``)."""
    out = []
    for f in (declared or PAPER).geometric.get((dim, algorithm), []):
        lhs, rhs = f.relation(v)
        c = Constraint(f"{dim}D.{algorithm}.geometric.{f.key}", dim, algorithm, f.section,
                       "geometric", f.statement, [Inequality(lhs, rhs, f.strict)],
                       printed=f.printed or f.statement.split("  (")[0])
        if f.equality:
            c.info["equality_holds"] = sympy.simplify(lhs - rhs) == 0
        out.append(c)
    return out



#: the paper's declared facts (sections 4 and 5)
PAPER = Declared(GEOMETRIC, PROTECTED, NONZERO, M_LOWER)
