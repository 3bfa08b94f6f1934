"""Polynomial utilities for :mod:`proofs.decide`: the variable s = ε^(1/4), the range
ε ∈ (0, 1e-5] as s ∈ (0, S], S = 10^(-5/4) (rational bounds and an exact test against S),
and lhs − rhs brought to num/den, polynomials in s with exact algebraic coefficients
(step 2 of the procedure in :mod:`proofs.decide`), with the resultant that removes their
radicals.
"""
from __future__ import annotations

from fractions import Fraction

import sympy

from fperr.symbols import EPS_MAX, L, eps

#: s = ε^(1/4), the variable the inequalities are decided in.
s = sympy.Symbol("s", positive=True)

EPS64 = sympy.Rational(1, 2**53)
EPS32 = sympy.Rational(1, 2**24)


def _s_bounds() -> tuple[Fraction, Fraction]:
    """Rationals S_lo ≤ S = 10^(-5/4) ≤ S_hi, S_hi − S_lo ≤ 2^-200."""
    # S^4 = 1/100000: bisect on numerators over 2^-200
    den = 2**200
    lo, hi = 0, den
    target = Fraction(1, 100000)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if Fraction(mid, den) ** 4 <= target:
            lo = mid
        else:
            hi = mid
    return Fraction(lo, den), Fraction(hi, den)


S_LO, S_HI = _s_bounds()


def s_le_S(x: Fraction) -> bool:
    """Exactly: x ≤ S (i.e. x⁴ ≤ 10⁻⁵ for x ≥ 0)."""
    return x <= 0 or x**4 <= Fraction(1, 100000)


def eps_of(x: Fraction) -> float:
    """ε = x⁴ as a float, clipped to the range (0, 1e-5]."""
    return min(float(x) ** 4, float(EPS_MAX))


def s_polynomials(expr: sympy.Expr) -> tuple[sympy.Poly, sympy.Poly] | None:
    """expr (in ε and L) at L = 1 and ε = s⁴ as num/den, two polynomials in s with
    constant (algebraic) coefficients; None when it is not such a fraction."""
    e = sympy.expand(sympy.sympify(expr).subs(L, 1).subs(eps, s**4))
    num, den = sympy.fraction(sympy.together(e))
    num, den = sympy.expand(num), sympy.expand(den)
    try:
        pn = sympy.Poly(num, s)
        pd = sympy.Poly(den, s)
    except sympy.PolynomialError:
        return None
    if any(c.has(s) for c in pn.all_coeffs() + pd.all_coeffs()):
        return None
    return pn, pd


def s_expression(expr: sympy.Expr) -> sympy.Expr:
    """expr at L = 1, ε = s⁴ (expanded)."""
    return sympy.expand(sympy.sympify(expr).subs(L, 1).subs(eps, s**4))


def ascending(p: sympy.Poly) -> list:
    cs = p.all_coeffs()[::-1]
    return [sympy.nsimplify(c) if c.is_Float else c for c in cs]


def poly_expr(q: list) -> sympy.Expr:
    return sum((c * s**i for i, c in enumerate(q)), sympy.Integer(0))


def rational_norm(qexpr: sympy.Expr) -> sympy.Poly | None:
    """A polynomial with rational coefficients vanishing wherever qexpr does.

    Each radical atom a = b^(m/n) (b rational) is replaced by a variable r and
    eliminated with the resultant against r^n − b^m: the result is the product of qexpr
    over the conjugate choices of r, so every real zero of qexpr is a zero of it.
    """
    atoms = sorted({a for a in qexpr.atoms(sympy.Pow)
                    if a.base.is_Rational and a.exp.is_Rational and not a.exp.is_Integer},
                   key=sympy.default_sort_key)
    rs = [sympy.Dummy(f"r{i}") for i in range(len(atoms))]
    # replace every radical at once (treating them as independent only enlarges the set
    # of conjugates, so the product still vanishes wherever qexpr does)
    expr = sympy.expand(qexpr.xreplace(dict(zip(atoms, rs))))
    for a, r in zip(atoms, rs):
        m, n = int(a.exp.p), int(a.exp.q)
        rel = r**n - a.base**m if m > 0 else r**n * a.base**(-m) - 1
        expr = sympy.expand(sympy.resultant(expr, rel, r)) if expr.has(r) else expr
    try:
        p = sympy.Poly(expr, s, domain=sympy.QQ)
    except (sympy.PolynomialError, sympy.CoercionFailed):
        return None
    if p.is_zero:
        return None
    return p

