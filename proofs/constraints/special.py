"""Section 5.4.4 of the paper: the check x̂² ≤ T²·q where q (= m²) has no relative
error bound, proven by the paper's argument and by a direct two-sided bound."""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from fperr import Tracked
from fperr.notation import greek
from fperr.symbols import eps

from ..tables import Values
from .facts import Bound
from .model import Argument, Constraint, Inequality, Step, bounds, fmt, label

R = sympy.Rational


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
    a = _Derived(greek(T), bounds(x, strict=True).E, bounds(tt, strict=True).R,
                 bounds(q, strict=True).E, *v.all(T), Tm, v.lo(Tm), label(q), lower_line)
    xq = f"{label(x)}²"
    info = {"E_d": a.E_d, "R_TT": a.R_TT, "E_q": a.E_q, "Tm": Tm, "T": T, "rho_m": a.rho_m,
            "rho_Y": a.rho_Y, "line": chk.line, "lower_line": lower_line}
    mg = m_geo.expr(v) if m_geo is not None else None
    args = [_paper_argument(a, m_geo, mg), _direct_argument(a, m_geo, mg)]
    Tsym = a.Tsym
    stmt = (f"line {chk.line}: F[{xq}] ≤ F[{Tsym}²·m²] must imply d̂² ≤ {Tsym}+²m², and its "
            f"negation d̂² > {Tsym}−²m²  (tolerance model (1) for {xq} ≤ {Tsym}²m²)")
    return Constraint(f"{dim}D.{alg}.special.line{chk.line}.{T}^2m^2", dim, alg, "5.4.4",
                      "special", stmt, arguments=args, lines=(chk.line,),
                      detail=(f"E[d̂] = {fmt(a.E_d)}, E[m²] = {fmt(a.E_q)}, "
                              f"R[{Tsym}²] = {fmt(a.R_TT)}, m² > {greek(Tm, 'lo')} once "
                              f"line {lower_line} is passed"), info=info)


@dataclass
class _Derived:
    """The derived inputs of the argument: E[d̂], R[T·T], E[m²], T−, T, T+, and the
    tolerance Tm of the earlier check m² ≤ Tm (so m² > Tm− afterwards)."""

    Tsym: str
    E_d: sympy.Expr
    R_TT: sympy.Expr
    E_q: sympy.Expr
    Tlo: sympy.Expr
    Tn: sympy.Expr
    Thi: sympy.Expr
    Tm: str
    Tm_lo: sympy.Expr
    q_label: str
    lower_line: int | None

    @property
    def m_acc(self):  # m ≥ √Tm− once the check on m² is passed
        return sympy.sqrt(self.Tm_lo)

    @property
    def rho_m(self):
        return self.E_q / self.Tm_lo

    @property
    def rho_Y(self):
        return (1 + self.R_TT) * (1 + self.rho_m) * (1 + eps) - 1


_NEVER = [Inequality(sympy.Integer(0), sympy.Integer(1), label="no bound declared")]


def _h(a: _Derived, y):
    """g(2/35·y²) with y = γm."""
    return (y**2 * (R(6, 5) * eps - R(2, 35)) + 2 * sympy.sqrt(R(6, 5)) * y * a.E_d * (1 + eps)
            + a.E_d**2 * (1 + eps))


def _dh(a: _Derived, y):
    return 2 * y * (R(6, 5) * eps - R(2, 35)) + 2 * sympy.sqrt(R(6, 5)) * a.E_d * (1 + eps)


def _chain(a: _Derived, side: str, y0, y0txt: str) -> list[Step]:
    """E[d̂²] < 2/35·γ²m² for every γm ≥ y0 (one side of the paper's argument)."""
    Tsym = a.Tsym
    return [
        Step(f"g(2/35·{Tsym}²m²) < 0 for {Tsym}m = {y0txt} ({side})",
             [Inequality(sympy.Integer(0), _h(a, y0))],
             f"g(2/35·y²) = y²(6/5·ε − 2/35) + 2√(6/5)·y·E[d̂](1+ε) + E[d̂]²(1+ε), "
             f"E[d̂] = {fmt(a.E_d)} (derived)"),
        Step(f"... and for every {Tsym}m ≥ {y0txt}: concave, decreasing at {y0txt} "
             f"({side})",
             [Inequality(R(2, 35), R(6, 5) * eps, label="6/5·ε < 2/35"),
              Inequality(sympy.Integer(0), _dh(a, y0), label="d/dy g(2/35·y²) < 0")]),
        Step(f"g'(x) ≤ ε + E[d̂](1+ε)/({Tsym}m) − 1 < 0 for x ≥ 2/35·{Tsym}²m² ({side})",
             [Inequality(sympy.Integer(1), eps + a.E_d * (1 + eps) / y0)],
             "hence g(x) < 0 for x ≥ 2/35·γ²m²; as g(E[d̂²]) ≥ 0, E[d̂²] < 2/35·γ²m²"),
    ]


def _paper_argument(a: _Derived, m_geo: Bound | None, mg) -> Argument:
    """The paper's 5.4.4 argument with its constants 1/7 and 2/35, on both sides."""
    Tsym, Tm, Tn = a.Tsym, a.Tm, a.Tn
    steps = [
        Step(f"R[m²] < E[m²]/{greek(Tm, 'lo')} < 1",
             [Inequality(sympy.Integer(1), a.rho_m)],
             f"m² > {greek(Tm, 'lo')} once '{a.q_label} ≤ {greek(Tm)}' (line {a.lower_line}) "
             f"is passed; derived E[m²] = "
             f"{fmt(a.E_q)}, so R[m²] < {fmt(a.rho_m)}"),
        Step(f"R[{Tsym}²m²] ≤ (1+R[{Tsym}²])(1+R[m²])(1+ε) − 1 < 1/7, "
             f"so E[{Tsym}²m²] < {Tsym}²m²/7",
             [Inequality(R(1, 7), a.rho_Y)],
             f"derived R[{Tsym}·{Tsym}] = {fmt(a.R_TT)}"),
    ]
    acc_txt = f"{Tsym}·√{greek(Tm, 'lo')}"
    steps += _chain(a, "accepting side: m ≥ √" + greek(Tm, "lo"), Tn * a.m_acc, acc_txt)
    steps.append(Step(f"accepting ⇒ d̂² ≤ {Tsym}+²m²: (1 + 1/7 + 2/35)·{Tsym}² = 6/5·{Tsym}² "
                      f"≤ {Tsym}+²", [Inequality(a.Thi**2, R(6, 5) * Tn**2, strict=False)]))
    geo = m_geo.text.split("> ")[-1] if m_geo is not None else "a geometric bound"
    note = (f"the paper bounds {Tsym}m from below by {Tsym}·{geo} on both sides; that bound "
            "holds only when the pair should be registered, and the accepting side must "
            f"also hold when it does not, where only m² > {greek(Tm, 'lo')} is known (used here)")
    if m_geo is not None:
        geo_txt = f"{Tsym}·{m_geo.text.split('> ')[-1]}"
        steps += _chain(a, f"rejecting side: {m_geo.text} ({m_geo.section})", Tn * mg, geo_txt)
        steps.append(Step(f"rejecting ⇒ d̂² > {Tsym}−²m²: (1 − 1/7 − 2/35)·{Tsym}² = "
                          f"4/5·{Tsym}² ≥ {Tsym}−²",
                          [Inequality(R(4, 5) * Tn**2, a.Tlo**2, strict=False)]))
    else:
        steps.append(Step("rejecting side: no geometric lower bound on m is declared for "
                          "this algorithm (proofs.constraints.M_LOWER)", _NEVER))
    return Argument("paper's argument (5.4.4)", steps, note)


def _direct_argument(a: _Derived, m_geo: Bound | None, mg) -> Argument:
    """A direct two-sided bound of F[d̂²] and F[γ²m²] (no structural constants)."""
    Tsym, Tm, Tn, Thi, E_d = a.Tsym, a.Tm, a.Tn, a.Thi, a.E_d
    steps = [
        Step(f"{Tsym}+ > E[d̂]/√{greek(Tm, 'lo')}",
             [Inequality(Thi, E_d / a.m_acc)],
             "so that |d̂| > γ+m implies |F[d̂]| ≥ |d̂| − E[d̂] > 0"),
        Step(f"accepting ⇒ d̂² ≤ {Tsym}+²m²: (γ+ − E[d̂]/√{greek(Tm, 'lo')})²(1−ε) > "
             f"{Tsym}²(1+ρ)".replace("γ", Tsym),
             [Inequality((Thi - E_d / a.m_acc) ** 2 * (1 - eps), Tn**2 * (1 + a.rho_Y))],
             f"ρ = (1+R[{Tsym}²])(1+E[m²]/{greek(Tm, 'lo')})(1+ε) − 1 bounds the relative error "
             f"of F[{Tsym}²m²] on both sides; m ≥ √{greek(Tm, 'lo')}"),
    ]
    if m_geo is not None:
        steps.append(Step(
            f"rejecting ⇒ d̂² > {Tsym}−²m²: (γ− + E[d̂]/m_geo)²(1+ε) < {Tsym}²(1−ρ)"
            .replace("γ", Tsym),
            [Inequality(Tn**2 * (1 - a.rho_Y), (a.Tlo + E_d / mg) ** 2 * (1 + eps))],
            f"m_geo: {m_geo.text} (section {m_geo.section}), valid when the pair should "
            f"be registered (d ≤ {Tsym}−)"))
    else:
        steps.append(Step("rejecting side: no geometric lower bound on m is declared "
                          "for this algorithm (proofs.constraints.M_LOWER)", _NEVER))
    return Argument("direct two-sided bound", steps)
