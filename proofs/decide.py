"""Deciding ``lhs > rhs`` for EVERY unit roundoff ε in (0, 1e-5], rigorously.

Every constraint the proofs need is an inequality between expressions in ε and L whose
ε-dependence is through ε^(k/4) (tolerances are c·ε^(1/4), c·ε^(1/2), c·ε^(3/4), c·ε;
error bounds are polynomials in ε). The procedure:

1. **Homogeneity in L.** Every side of a constraint is homogeneous of one degree p in
   L (checked term by term: a constraint that mixes degrees is refused), so
   lhs − rhs = L^p·(lhs − rhs)|_(L=1) and its sign does not depend on L > 0. We set L = 1.
   This is the only place the scale is eliminated.
2. **ε = s⁴.** With s = ε^(1/4) every ε^(k/4) is the monomial s^k; ε ∈ (0, 1e-5]
   is s ∈ (0, S], S = 10^(-5/4). lhs − rhs is brought to one fraction num/den, each a
   polynomial in s whose coefficients are exact algebraic numbers (√2, √3, √910, ...).
   The denominator's sign is decided first, by the same procedure.
3. **Positivity of a polynomial q(s) on (0, S]:** factor out s^k (positive there); then
   * if the lowest coefficient c_k ≤ 0, the inequality fails for all small ε (a witness
     is computed);
   * *dominance*: c_k > Σ_{i>k} |c_i|·S^(i−k) (all in rigorous interval arithmetic,
     mpmath.iv with outward rounding, S replaced by a rational upper bound) proves
     q > 0 on [0, S];
   * otherwise *exact root isolation*: the radicals √a of the coefficients are
     eliminated by resultants (N(s) = Π over sign choices of q, a polynomial with
     rational coefficients whose real roots include those of q); the real roots of N in
     (0, S] are isolated exactly (sympy, rational isolating intervals, refined against
     S exactly via s⁴ vs 10⁻⁵). Between consecutive roots q has no zero, so its sign is
     the sign at one rational point (interval arithmetic at increasing precision, never
     ambiguous because q ≠ 0 there). On each isolating interval q is bounded by
     interval arithmetic, refining the interval until q is proven positive, proven
     negative somewhere (failure, with a witness), or the interval is below 1e-60 wide
     with 0 still inside (q touches zero: reported as failing, since > 0 is not proven).
   Expressions that are not polynomial after step 2 fall back to interval
   branch-and-bound on (0, S] (proves positivity or finds a witness; undecided pieces
   are reported as failures).

Sampling is never used to decide. The result also carries the value of lhs − rhs and
lhs/rhs at binary64's unit roundoff (2^-53) and binary32's (2^-24), for display.
"""
from __future__ import annotations

import functools
from fractions import Fraction

import sympy

from fperr.symbols import EPS_MAX, L, eps

from .decision import Decision, NotHomogeneous
from .interval_eval import interval, sign
from .root_isolation import branch_and_bound, failure_from_roots, root_isolation
from .s_polynomial import (EPS32, EPS64, S_HI, S_LO, ascending, eps_of, poly_expr,
                           s, s_expression, s_le_S, s_polynomials)

__all__ = ["Decision", "NotHomogeneous", "decide", "decide_positive", "l_degree", "s",
           "S_LO", "S_HI", "EPS64", "EPS32", "interval", "sign", "s_le_S", "eps_of"]


def l_degree(expr: sympy.Expr) -> sympy.Rational | None:
    """The degree in L of a homogeneous expression (None for 0); raises when mixed."""
    e = sympy.expand(expr)
    if e == 0:
        return None
    degs = set()
    for term in sympy.Add.make_args(e):
        coeff, p = term.as_coeff_exponent(L)
        if coeff.has(L):
            raise NotHomogeneous(f"L appears non-monomially in {term}")
        degs.add(sympy.nsimplify(p))
    if len(degs) != 1:
        raise NotHomogeneous(f"mixed powers of L {sorted(degs)} in {expr}")
    return degs.pop()


def _value_at(expr: sympy.Expr, epsilon: sympy.Rational) -> float:
    v = expr.subs({L: 1, eps: epsilon})
    return float(sympy.N(v, 30))


def _display(lhs, rhs, epsilon):
    lv, rv = _value_at(lhs, epsilon), _value_at(rhs, epsilon)
    ratio = lv / rv if (rv > 0 and lv > 0) else None
    return (lv - rv, ratio)


def decide(lhs: sympy.Expr, rhs: sympy.Expr, strict: bool = True) -> Decision:
    """Decide lhs > rhs (``strict``) or lhs ≥ rhs for every ε in (0, 1e-5], L > 0."""
    return _decide_cached(sympy.sympify(lhs), sympy.sympify(rhs), strict)


@functools.lru_cache(maxsize=None)
def _decide_cached(lhs, rhs, strict) -> Decision:
    diff = sympy.expand(lhs - rhs)
    dl, dr = l_degree(lhs), l_degree(rhs)
    if dl is not None and dr is not None and dl != dr:
        raise NotHomogeneous(f"sides have different powers of L: L^{dl} vs L^{dr}")
    at64, at32 = _display(lhs, rhs, EPS64), _display(lhs, rhs, EPS32)
    if diff == 0:
        return Decision(not strict, "identical sides", (), None if not strict else 0.0,
                        at64, at32, "lhs − rhs ≡ 0")
    d = decide_positive(diff)
    return Decision(d.holds, d.method, d.fails_on, d.witness, at64, at32, d.note)


def decide_positive(expr: sympy.Expr) -> Decision:
    """Decide expr > 0 for every ε ∈ (0, 1e-5] (expr in eps and L; L set to 1)."""
    polys = s_polynomials(expr)
    if polys is None:
        return branch_and_bound(s_expression(expr))
    pn, pd = polys
    dd = _positive_poly(ascending(pd))
    if not dd.holds:
        # a denominator that is not positive on the whole range: decide the other sign
        dneg = _positive_poly([-c for c in ascending(pd)])
        if not dneg.holds:
            return branch_and_bound(s_expression(expr))
        nn = _positive_poly([-c for c in ascending(pn)])
        return Decision(nn.holds, nn.method + " (negative denominator)", nn.fails_on,
                        nn.witness, note=nn.note)
    return _positive_poly(ascending(pn))


def _positive_poly(coeffs: list) -> Decision:
    """q(s) = Σ coeffs[i]·s^i > 0 for every s ∈ (0, S]."""
    coeffs = list(coeffs)
    signs = [sign(c) if c != 0 else 0 for c in coeffs]
    nz = [i for i, sg in enumerate(signs) if sg != 0]
    if not nz:
        return Decision(False, "identically zero", ((0.0, float(EPS_MAX)),), float(EPS_MAX))
    k = nz[0]
    q = coeffs[k:]
    # lowest-order coefficient decides the behaviour as ε → 0
    if signs[k] < 0:
        w = _small_witness(q)
        return failure_from_roots(q, "lowest-order term negative", w)
    # dominance: c_k > Σ |c_i| S^(i-k)
    tail_expr = sum((abs(c) * s**i for i, c in enumerate(q[1:], start=1) if c != 0),
                    sympy.Integer(0))
    c0 = interval(q[0])
    tail = interval(tail_expr, {s: S_HI}) if tail_expr != 0 else None
    if tail is None or c0.a > tail.b:
        return Decision(True, "dominance of the lowest-order term")
    return root_isolation(q)


def _small_witness(q: list) -> float:
    """An ε small enough that the lowest-order (negative) term dominates q."""
    x = Fraction(S_LO)
    for _ in range(400):
        if sign(poly_expr(q), {s: x}) < 0:
            return eps_of(x)
        x /= 2
    return 0.0

