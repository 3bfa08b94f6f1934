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
import math
from dataclasses import dataclass, field
from fractions import Fraction

import mpmath
import sympy
from mpmath import iv

from fperr.symbols import EPS_MAX, L, eps

#: s = ε^(1/4), the variable the inequalities are decided in.
s = sympy.Symbol("s", positive=True)

EPS64 = sympy.Rational(1, 2**53)
EPS32 = sympy.Rational(1, 2**24)

_PREC = 160          # bits of interval arithmetic to start with
_MAX_PREC = 4000
_MAX_REFINE = 220    # bisection steps on one isolating interval (width → 2^-220·S)


class NotHomogeneous(ValueError):
    """A constraint mixes powers of L: its sign could depend on the scale."""


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


# -- rigorous interval evaluation ------------------------------------------------------

def _iv(expr: sympy.Expr, env: dict):
    """Interval enclosure of a sympy expression (outward-rounded mpmath.iv)."""
    if expr.is_Symbol:
        return env[expr]
    if expr.is_Integer:
        return iv.mpf(int(expr))
    if expr.is_Rational:
        return iv.mpf(int(expr.p)) / iv.mpf(int(expr.q))
    if expr.is_Float:
        return iv.mpf(str(expr))
    if expr is sympy.pi:
        return iv.pi
    if expr.is_Add:
        out = iv.mpf(0)
        for a in expr.args:
            out = out + _iv(a, env)
        return out
    if expr.is_Mul:
        out = iv.mpf(1)
        for a in expr.args:
            out = out * _iv(a, env)
        return out
    if expr.is_Pow:
        b, e = expr.args
        if e.is_Integer:
            x = _iv(b, env)
            n = int(e)
            if n >= 0:
                return _ipow(x, n)
            return iv.mpf(1) / _ipow(x, -n)
        if e.is_Rational:
            x = _iv(b, env)
            if e == sympy.Rational(1, 2):
                return iv.sqrt(x)
            if e == sympy.Rational(-1, 2):
                return iv.mpf(1) / iv.sqrt(x)
            return iv.exp(iv.log(x) * (iv.mpf(int(e.p)) / iv.mpf(int(e.q))))
    if isinstance(expr, sympy.Abs):
        x = _iv(expr.args[0], env)
        return abs(x)
    if isinstance(expr, (sympy.Min, sympy.Max)):
        xs = [_iv(a, env) for a in expr.args]
        pick = min if isinstance(expr, sympy.Min) else max
        return iv.mpf([pick(x.a for x in xs), pick(x.b for x in xs)])
    raise TypeError(f"cannot evaluate {expr!r} in interval arithmetic")


def _ipow(x, n: int):
    """x**n for an interval x and integer n ≥ 0 (even powers of intervals through 0)."""
    if n == 0:
        return iv.mpf(1)
    out = x
    for _ in range(n - 1):
        out = out * x
    if n % 2 == 0 and x.a < 0 < x.b:
        return iv.mpf([0, out.b])
    return out


def interval(expr: sympy.Expr, env: dict | None = None, prec: int = _PREC):
    """Enclosure of ``expr`` (sympy) with the symbols of ``env`` bound to intervals
    given as Fractions or (lo, hi) pairs of Fractions."""
    with mpmath.workprec(prec):
        old = iv.prec
        iv.prec = prec
        try:
            e = {}
            for k, v in (env or {}).items():
                lo, hi = (v, v) if not isinstance(v, tuple) else v
                e[k] = iv.mpf([_mpf_down(lo, prec), _mpf_up(hi, prec)])
            return _iv(expr, e)
        finally:
            iv.prec = old


def _mpf_down(q: Fraction, prec: int):
    return iv.mpf(int(q.numerator)) / iv.mpf(int(q.denominator)) if q.denominator != 1 \
        else iv.mpf(int(q.numerator))


_mpf_up = _mpf_down  # iv division already yields an enclosing interval


def sign(expr: sympy.Expr, env: dict | None = None) -> int:
    """The exact sign of a constant (or of ``expr`` at an exact point), by interval
    arithmetic at increasing precision, with an exact zero test as last resort."""
    prec = _PREC
    while prec <= _MAX_PREC:
        x = interval(expr, env, prec)
        if x.a > 0:
            return 1
        if x.b < 0:
            return -1
        if x.a == 0 and x.b == 0:
            return 0
        prec *= 2
    value = expr.subs({k: sympy.Rational(v.numerator, v.denominator)
                       for k, v in (env or {}).items()})
    if sympy.simplify(value) == 0:
        return 0
    mp = sympy.minimal_polynomial(value, sympy.Dummy("x"))
    if mp.is_Symbol:
        return 0
    raise ArithmeticError(f"sign of {expr} undecided at {_MAX_PREC} bits")


# -- decisions ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Decision:
    """Outcome of deciding lhs > rhs on ε ∈ (0, 1e-5].

    ``holds``: proven for every ε. ``method``: how. ``fails_on``: ε-ranges (lo, hi)
    where it fails (approximate endpoints, from exact isolating intervals), ``witness``:
    an ε at which lhs − rhs ≤ 0 is proven. ``at64``/``at32``: (lhs − rhs, lhs/rhs)
    at binary64's and binary32's unit roundoff, L = 1 (floats, for display).
    """

    holds: bool
    method: str
    fails_on: tuple = ()
    witness: float | None = None
    at64: tuple = (None, None)
    at32: tuple = (None, None)
    note: str = ""

    @property
    def holds_up_to(self) -> float | None:
        """Largest ε0 with the inequality proven on (0, ε0] (None if it fails near 0)."""
        if self.holds:
            return float(EPS_MAX)
        if not self.fails_on:
            return None
        lo = self.fails_on[0][0]
        return lo if lo > 0 else None


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
    e = sympy.expand(sympy.sympify(expr).subs(L, 1).subs(eps, s**4))
    num, den = sympy.fraction(sympy.together(e))
    num, den = sympy.expand(num), sympy.expand(den)
    try:
        pn = sympy.Poly(num, s)
        pd = sympy.Poly(den, s)
        if any(c.has(s) for c in pn.all_coeffs() + pd.all_coeffs()):
            raise sympy.PolynomialError("coefficients depend on s")
    except sympy.PolynomialError:
        return _branch_and_bound(e)
    dd = _positive_poly(_ascending(pd))
    if not dd.holds:
        # a denominator that is not positive on the whole range: decide the other sign
        dneg = _positive_poly([-c for c in _ascending(pd)])
        if not dneg.holds:
            return _branch_and_bound(e)
        nn = _positive_poly([-c for c in _ascending(pn)])
        return Decision(nn.holds, nn.method + " (negative denominator)", nn.fails_on,
                        nn.witness, note=nn.note)
    return _positive_poly(_ascending(pn))


def _ascending(p: sympy.Poly) -> list:
    cs = p.all_coeffs()[::-1]
    return [sympy.nsimplify(c) if c.is_Float else c for c in cs]


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
        return _failure_from_roots(q, "lowest-order term negative", w)
    # dominance: c_k > Σ |c_i| S^(i-k)
    tail_expr = sum((abs(c) * s**i for i, c in enumerate(q[1:], start=1) if c != 0),
                    sympy.Integer(0))
    c0 = interval(q[0])
    tail = interval(tail_expr, {s: S_HI}) if tail_expr != 0 else None
    if tail is None or c0.a > tail.b:
        return Decision(True, "dominance of the lowest-order term")
    return _root_isolation(q)


def _small_witness(q: list) -> float:
    """An ε small enough that the lowest-order (negative) term dominates q."""
    x = Fraction(S_LO)
    for _ in range(400):
        if sign(_poly_expr(q), {s: x}) < 0:
            return eps_of(x)
        x /= 2
    return 0.0


def _poly_expr(q: list) -> sympy.Expr:
    return sum((c * s**i for i, c in enumerate(q)), sympy.Integer(0))


def _rational_norm(qexpr: sympy.Expr) -> sympy.Poly | None:
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


def _root_isolation(q: list) -> Decision:
    qexpr = _poly_expr(q)
    N = _rational_norm(qexpr)
    if N is None:
        return _branch_and_bound(qexpr, assume_poly=True)
    # strip zeros at s = 0 (irrelevant: s ∈ (0, S])
    while N.eval(0) == 0:
        N = sympy.Poly(sympy.quo(N.as_expr(), s), s, domain=sympy.QQ)
    N = N.sqf_part()
    S_up = sympy.Rational(S_HI.numerator, S_HI.denominator)
    raw = N.intervals(inf=0, sup=S_up)
    ivals = []
    for (a, b), _mult in raw:
        a, b = Fraction(int(a.p), int(a.q)), Fraction(int(b.p), int(b.q))
        # make the interval lie entirely on one side of S
        while a != b and not s_le_S(b) and s_le_S(a):
            a, b = _refine(N, a, b)
        if not s_le_S(a):
            continue  # root beyond S
        while b - a > b * Fraction(1, 10**12):  # narrow, for precise failure ranges
            a, b = _refine(N, a, b)
        ivals.append((a, b))
    ivals.sort()
    # gaps between roots: one exact sign each
    bad_ranges = []
    pts = []
    prev = Fraction(0)
    for a, b in ivals + [(None, None)]:
        hi = a if a is not None else S_LO
        if hi > prev:
            x = _gap_point(N, prev, hi)
            if x is not None:
                pts.append((prev, hi, sign(qexpr, {s: x}), x))
        if b is not None:
            prev = b
    witness = None
    for lo, hi, sg, x in pts:
        if sg < 0:
            bad_ranges.append((eps_of(lo), eps_of(hi)))
            witness = witness if witness is not None else eps_of(x)
    # isolating intervals: prove q > 0 there or find where it is not
    undecided = []
    for a, b in ivals:
        status, where = _on_interval(N, qexpr, a, b)
        if status < 0:
            bad_ranges.append((eps_of(where[0]), eps_of(where[1])))
        elif status == 0:
            undecided.append((eps_of(where[0]), eps_of(where[1])))
    # the right end S itself (S is irrational, handled by the last gap up to S_LO and
    # an enclosure on [S_LO, S_HI])
    if not bad_ranges:
        end = interval(qexpr, {s: (S_LO, S_HI)})
        if end.b < 0:
            bad_ranges.append((eps_of(S_LO), float(EPS_MAX)))
        elif not end.a > 0:
            undecided.append((eps_of(S_LO), float(EPS_MAX)))
    fails = _merge(bad_ranges + undecided)
    if not fails:
        return Decision(True, f"exact root isolation ({len(ivals)} root(s) of the "
                              f"rational norm in range, q > 0 throughout)")
    note = ""
    if undecided and not bad_ranges:
        note = "q may touch zero (not proven positive)"
    w = witness if witness is not None else (bad_ranges or undecided)[0][1]
    return Decision(False, "exact root isolation", tuple(fails), w, note=note)


def _merge(ranges):
    ranges = sorted(ranges)
    out = []
    for lo, hi in ranges:
        if out and lo <= out[-1][1] * (1 + 1e-9):
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return tuple(out)


def _refine(N: sympy.Poly, a: Fraction, b: Fraction):
    m = (a + b) / 2
    fa, fm = N.eval(sympy.Rational(a.numerator, a.denominator)), \
        N.eval(sympy.Rational(m.numerator, m.denominator))
    if fm == 0:
        return (m, m)
    if fa == 0:
        return (a, a)
    return (a, m) if (fa > 0) != (fm > 0) else (m, b)


def _gap_point(N: sympy.Poly, lo: Fraction, hi: Fraction) -> Fraction | None:
    """A rational point strictly inside (lo, hi) where N ≠ 0 (so q ≠ 0 there)."""
    for k in range(1, 12):
        for j in range(1, 2**k, 2):
            x = lo + (hi - lo) * Fraction(j, 2**k)
            if N.eval(sympy.Rational(x.numerator, x.denominator)) != 0:
                return x
    return None


def _on_interval(N, qexpr, a: Fraction, b: Fraction):
    """Sign of q on an isolating interval of N: 1 (proven > 0), −1 with a sub-interval
    where q < 0, or 0 (q may vanish: not decided)."""
    if a == b:
        sg = sign(qexpr, {s: a})
        return (sg, (a, b)) if sg != 0 else (0, (a, b))
    for _ in range(_MAX_REFINE):
        x = interval(qexpr, {s: (a, b)})
        if x.a > 0:
            return 1, (a, b)
        if x.b < 0:
            return -1, (a, b)
        # does q change sign on [a, b]? endpoints are not roots of N, so q ≠ 0 there
        sa, sb = sign(qexpr, {s: a}), sign(qexpr, {s: b})
        if sa < 0:
            return -1, (a, a)
        if sb < 0:
            return -1, (b, b)
        a, b = _refine(N, a, b)
        if a == b:
            sg = sign(qexpr, {s: a})
            return (sg, (a, b)) if sg != 0 else (0, (a, b))
        if b - a < Fraction(1, 2**200):
            break
    return 0, (a, b)


def _failure_from_roots(q: list, method: str, witness: float) -> Decision:
    iso = _root_isolation(q)
    fails = iso.fails_on or ((0.0, float(EPS_MAX)),)
    return Decision(False, method, fails, witness)


def _branch_and_bound(expr: sympy.Expr, assume_poly: bool = False) -> Decision:
    """Interval bisection of (0, S] (fallback when exact isolation does not apply)."""
    e = expr
    stack = [(Fraction(0), S_HI)]
    bad, undecided = [], []
    steps = 0
    while stack and steps < 3000:
        a, b = stack.pop()
        steps += 1
        try:
            x = interval(e, {s: (a if a > 0 else Fraction(1, 2**400), b)})
        except (ZeroDivisionError, ValueError):
            x = None
        if x is not None and x.a > 0:
            continue
        if x is not None and x.b < 0:
            bad.append((eps_of(a), min(eps_of(b), float(EPS_MAX))))
            continue
        if b - a < Fraction(1, 2**120):
            undecided.append((eps_of(a), eps_of(b)))
            continue
        m = (a + b) / 2
        stack.extend([(m, b), (a, m)])
    if stack:
        undecided.append((0.0, float(EPS_MAX)))
    fails = _merge(bad + undecided)
    if not fails:
        return Decision(True, "interval branch-and-bound")
    return Decision(False, "interval branch-and-bound", fails, fails[0][1],
                    note="" if bad else "not proven (undecided pieces)")
