"""Certificates of ``fperr verify``: for every constraint, a record a checker with only
exact rational arithmetic re-establishes (``python -m proofs.check_certificate FILE``).

For each inequality lhs > rhs (or ≥) of a constraint (its own, and every step of every
encoded argument of section 5.4.4) the record holds lhs − rhs at L = 1 (homogeneity,
checked by :func:`proofs.decide.l_degree`) and ε = s⁴ as num(s)/den(s) with exact
coefficients (rationals "p/q", or sums of rationals times rational powers of rationals
such as √3), the sign claimed for both on (0, S], S = 10^(-5/4), a rational polynomial
below σ·P coefficientwise, and the evidence that this rational polynomial is positive on
(0, S]: dominance of its lowest-order term at a rational s_max ≥ S, or a partition of
(0, s_end] into isolating intervals of its roots (all beyond S) and gaps with a rational
sample point and the exact sign there. Schema: docs/proofs.md, "Certificates".

The evidence is computed here with exact rational arithmetic and sympy's real-root
isolation, independently of the decision's own pieces; the decision of
:mod:`proofs.decide` is recorded next to it ("decided") for comparison.
"""
from __future__ import annotations

import functools
import json
from fractions import Fraction

import mpmath
import sympy

from predicates.registration.io.write import write_text_atomic

from .check_certificate import FORMAT, VERSION, below_S
from .decide import S_HI, l_degree
from .interval_eval import interval
from .s_polynomial import ascending, s, s_polynomials

_BOUND_BITS = 220    # a radical coefficient's rational bound is within 2^-220 below it


def rat(x) -> str:
    """A rational as "p/q" (or "p")."""
    x = Fraction(int(x.p), int(x.q)) if isinstance(x, sympy.Rational) else Fraction(x)
    return str(x)


def coefficient_record(c: sympy.Expr):
    """"p/q", or {"terms": [["p/q", [["base", "exp"], ...]], ...]} for Σ r·Π b^e."""
    c = sympy.nsimplify(c) if c.is_Float else c
    if c.is_Rational:
        return rat(c)
    terms = []
    for term in sympy.Add.make_args(sympy.expand(c)):
        r, rest = term.as_coeff_Mul()
        if not r.is_Rational:
            raise ValueError(f"coefficient term {term} has no rational factor")
        factors = []
        for f in sympy.Mul.make_args(rest):
            b, e = f.as_base_exp()
            if not (b.is_Rational and b > 0 and e.is_Rational):
                raise ValueError(f"coefficient factor {f} is not a rational power of a "
                                 "positive rational")
            factors.append([rat(b), rat(e)])
        terms.append([rat(r), factors])
    return {"terms": terms}


def lower_bound(c: sympy.Expr, sgn: int) -> Fraction:
    """A rational ≤ sgn·c (exact for rationals; rigorous interval bound otherwise)."""
    if c.is_Rational:
        return sgn * Fraction(int(c.p), int(c.q))
    x = interval(sgn * c, prec=_BOUND_BITS + 200)
    p, q = mpmath.libmp.to_rational(x._mpi_[0])
    lo = Fraction(p, q)
    scale = 2**_BOUND_BITS
    return Fraction((lo * scale).__floor__() - 1, scale)


def _qpoly(q: list) -> sympy.Poly:
    return sympy.Poly([sympy.Rational(c.numerator, c.denominator) for c in reversed(q)],
                      s, domain=sympy.QQ)


def _peval(q: list, x: Fraction) -> Fraction:
    acc = Fraction(0)
    for c in reversed(q):
        acc = acc * x + c
    return acc


def _sgn(v: Fraction) -> int:
    return (v > 0) - (v < 0)


def _fr(x) -> Fraction:
    return Fraction(int(x.p), int(x.q))


def _one_side_of_S(sqf: sympy.Poly, a: Fraction, b: Fraction) -> tuple:
    """An isolating interval (a, b) of one root of ``sqf`` (square-free) with a and b
    not roots, not straddling S, width ≤ 2^-40·b (exact roots a == b are widened)."""
    if a == b:
        d = Fraction(1, 2**40) * max(a, Fraction(1, 2**40))
        while (sqf.count_roots(sympy.Rational(*_nd(a - d)), sympy.Rational(*_nd(a + d))) != 1
               or below_S(a - d) != below_S(a + d)
               or sqf.eval(sympy.Rational(*_nd(a - d))) == 0
               or sqf.eval(sympy.Rational(*_nd(a + d))) == 0):
            d /= 2
        return a - d, a + d
    # narrow enough to name the ε where a root lies, and on one side of S
    while (below_S(a) and not below_S(b)) or b - a > b / 2**40:
        m = (a + b) / 2
        fm = sqf.eval(sympy.Rational(*_nd(m)))
        if fm == 0:
            return _one_side_of_S(sqf, m, m)
        fa = sqf.eval(sympy.Rational(*_nd(a)))
        a, b = (a, m) if (fa > 0) != (fm > 0) else (m, b)
    return a, b


def _nd(x: Fraction) -> tuple:
    return x.numerator, x.denominator


def evidence(bound: list) -> tuple[dict, bool]:
    """Evidence that B(s) = Σ bound[i]·s^i > 0 on (0, S], and whether it establishes it."""
    nz = [i for i, c in enumerate(bound) if c != 0]
    if not nz:
        return {"method": "dominance"}, False
    q = bound[nz[0]:]
    tail = sum((abs(c) * S_HI**i for i, c in enumerate(q) if i > 0), Fraction(0))
    if q[0] > tail:
        return {"method": "dominance"}, True
    sqf = _qpoly(q).sqf_part()
    ivals = []
    for (a, b), _mult in sqf.intervals(inf=0, sup=sympy.Rational(*_nd(S_HI))):
        ivals.append(_one_side_of_S(sqf, _fr(a), _fr(b)))
    ivals.sort()
    pieces, prev, ok = [], Fraction(0), True
    for a, b in ivals + [(max(S_HI, prev), None)]:
        if a > prev:
            x = (prev + a) / 2
            sg = _sgn(_peval(q, x))
            pieces.append({"kind": "gap", "lo": str(prev), "hi": str(a), "sample": str(x),
                           "sign": sg})
            ok = ok and (sg > 0 or not below_S(prev))
        if b is None:
            break
        pieces.append({"kind": "root", "lo": str(a), "hi": str(b)})
        ok = ok and not below_S(a)
        prev = b
    return {"method": "isolation", "pieces": pieces}, ok


def poly_record(coeffs: list, sgn: int) -> tuple[dict, bool]:
    """The record of one polynomial (ascending exact coefficients) claimed of sign sgn."""
    bound = [lower_bound(c, sgn) for c in coeffs]
    ev, ok = evidence(bound)
    return {"coefficients": [coefficient_record(c) for c in coeffs], "sign": sgn,
            "bound": [str(b) for b in bound], "evidence": ev}, ok


@functools.lru_cache(maxsize=None)
def _ineq_record(lhs: sympy.Expr, rhs: sympy.Expr, strict: bool) -> dict:
    deg = l_degree(lhs)
    out = {"lhs": str(lhs), "rhs": str(rhs), "strict": strict,
           "L_degree": None if deg is None else str(deg), "identical": False}
    diff = sympy.expand(lhs - rhs)
    if diff == 0:
        out["identical"] = True
        return out
    polys = s_polynomials(diff)
    if polys is None:
        out["unsupported"] = "lhs − rhs is not a fraction of polynomials in s"
        return out
    try:
        num, den = (ascending(p) for p in polys)
        for sgn in (1, -1):
            drec, dok = poly_record(den, sgn)
            if dok or sgn == -1:
                break
        out["numerator"], _ = poly_record(num, sgn)
        out["denominator"] = drec
    except ValueError as e:
        out.pop("numerator", None)
        out["unsupported"] = str(e)
    return out


def inequality_record(ineq, decision=None) -> dict:
    """The record of one :class:`proofs.constraints.Inequality` (and its decision)."""
    rec = dict(_ineq_record(sympy.sympify(ineq.lhs), sympy.sympify(ineq.rhs), ineq.strict))
    rec["label"] = ineq.label
    if decision is not None:
        rec["decided"] = {"holds": decision.holds, "method": decision.method}
    return rec


def constraint_record(outcome, require_paper_argument: bool = False) -> dict:
    """The record of one decided constraint (:class:`proofs.verify.Outcome`)."""
    c = outcome.constraint
    args = []
    for a, steps, _ok in outcome.arguments:
        if require_paper_argument and not a.name.startswith("paper"):
            continue
        args.append({"name": a.name, "steps": [
            {"title": st.title,
             "inequalities": [inequality_record(i, d) for i, d in zip(st.inequalities, ds)]}
            for st, ds in zip(a.steps, steps)]})
    return {"id": c.id, "section": c.section, "kind": c.kind, "statement": c.statement,
            "holds": outcome.holds, "error": c.error or None,
            "inequalities": [inequality_record(i, d)
                             for i, d in zip(c.inequalities, outcome.decisions)],
            "arguments": args, "argument_rule": "all" if require_paper_argument else "any"}


def build(reports: dict, require_paper_argument: bool = False) -> dict:
    """The certificate of {dim: :class:`proofs.verify.Report`}."""
    dims = []
    for dim, rep in sorted(reports.items()):
        recs = [constraint_record(o, require_paper_argument) for o in rep.outcomes]
        dims.append({"dim": dim,
                     "tolerances": {k: str(v) for k, v in rep.table.items()},
                     "constraint_ids": [r["id"] for r in recs], "constraints": recs})
    return {"format": FORMAT, "version": VERSION, "eps_max": "1/100000",
            "s_max": str(S_HI), "require_paper_argument": require_paper_argument,
            "dims": dims}


def write(path, reports: dict, require_paper_argument: bool = False) -> None:
    """Write the certificate of ``reports`` to ``path`` (JSON)."""
    doc = build(reports, require_paper_argument)
    write_text_atomic(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
