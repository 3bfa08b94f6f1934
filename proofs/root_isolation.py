"""Exact root isolation of q(s) on (0, S] (step 3 of :mod:`proofs.decide`), and the
interval branch-and-bound fallback for expressions that are not polynomials in s.

The radicals of q are removed by resultants (:func:`proofs.s_polynomial.rational_norm`);
the real roots of that rational polynomial N in (0, S] are isolated exactly (sympy) and
placed against S exactly; q has one sign between consecutive roots (read at one
rational point) and is enclosed on each isolating interval until proven positive or
negative.
"""
from __future__ import annotations

from fractions import Fraction

import sympy

from fperr.symbols import EPS_MAX

from .decision import Decision
from .interval_eval import interval, sign
from .s_polynomial import S_HI, S_LO, eps_of, poly_expr, rational_norm, s, s_le_S

_MAX_REFINE = 220    # bisection steps on one isolating interval (width → 2^-220·S)


def root_isolation(q: list) -> Decision:
    qexpr = poly_expr(q)
    N = rational_norm(qexpr)
    if N is None:
        return branch_and_bound(qexpr, assume_poly=True)
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


def failure_from_roots(q: list, method: str, witness: float) -> Decision:
    iso = root_isolation(q)
    fails = iso.fails_on or ((0.0, float(EPS_MAX)),)
    return Decision(False, method, fails, witness)


def branch_and_bound(expr: sympy.Expr, assume_poly: bool = False) -> Decision:
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
