"""Sign tests of users' predicates declared "sign exact or undecided" (docs/proofs.md,
"Sign tests"): the ``sign_filter`` declaration of
:class:`proofs.user_predicates.PredicateTolerances` and the thresholds θ in a working
format.

A sign test ``x > 0`` (or ``x <= 0``, ``ctx.same_sign``, ``ctx.differ_sign``) of such a
predicate decides nothing below its threshold: a lane with |F[x]| > θ has the exact sign
of x, any other lane is undecided (a filtered predicate decides it exactly). θ is
declared, or derived from the sign bound as K·ε·L^p
(:func:`proofs.constraints.generated.sign_threshold`); ``fperr verify`` decides
θ ≥ (1 + ε)·E_sign[x] for every ε ≤ 1e-5.
"""
from __future__ import annotations

from fractions import Fraction

import sympy

import fperr
from fperr.symbols import L, eps
from predicates.core import Predicate

from . import tables
from .constraints.generated import sign_threshold
from .constraints.model import label


def filters(spec, preds, names, dim: int, to_bounds, error) -> dict:
    """The ``sign_filter`` declaration as :class:`proofs.constraints.Declared` holds it:
    {(dim, predicate): {"*": None} | {quantity: Bound θ}} from ``sign_filter``: True
    (every predicate), predicates or their names (θ derived from the sign bound), or
    {predicate: {quantity: θ expression}} (declared thresholds, checked)."""
    if spec is None or spec is False:
        return {}
    known = {p.name for p in preds}
    if spec is True:
        return {(dim, n): {"*": None} for n in known}
    items = spec.items() if isinstance(spec, dict) else ((x, None) for x in spec)
    out: dict = {}
    for pred, thetas in items:
        pname = pred.name if isinstance(pred, Predicate) else pred
        if pname not in known:
            raise error(f"sign_filter names {pname!r}, which is not one of the "
                        f"predicates {', '.join(sorted(known))}")
        if thetas is None or thetas is True:
            out[(dim, pname)] = {"*": None}
            continue
        if not isinstance(thetas, dict):
            raise error(f"sign_filter[{pname!r}] must be True or a mapping "
                        f"quantity → threshold expression, got {thetas!r}")
        out.update(to_bounds({pname: thetas}, names, "sign_filter", dim,
                             lambda q, t: f"θ[{q}] = {t}"))
    return out



def _upper_fraction(expr) -> Fraction:
    """A Fraction ≥ the positive constant sympy expression (exact when rational)."""
    expr = sympy.nsimplify(expr) if isinstance(expr, sympy.Float) else sympy.sympify(expr)
    if expr.is_Rational:
        return Fraction(int(expr.p), int(expr.q))
    return Fraction(str(sympy.N(expr, 60))) * (1 + Fraction(1, 10**50))


def threshold_expressions(decl) -> dict:
    """{predicate: {quantity: θ}} as exact expressions in ε and L, for every sign test
    of a predicate the declaration filters (declared θ, or the derived one)."""
    v = tables.Values(decl.table())
    runs = decl.runs(v.tab)
    out: dict = {}
    for p in decl.predicates:
        flt = decl.declared.filtered.get((decl.dim, p.name))
        if flt is None:
            continue
        for chk in runs[p.name].checks:
            x = chk.lhs
            if not chk.is_sign_test or (x.name not in flt and "*" not in flt):
                continue
            theta = flt[x.name].expr(v) if x.name in flt else \
                sign_threshold(fperr.bounds(x, strict=True, sign=True).E, x.p)
            out.setdefault(p.name, {})[label(x)] = theta
    return out


def thresholds(decl, L_bound, dtype=None) -> dict:
    """{predicate: {quantity: θ}} in the working format of ``dtype`` (as
    :meth:`PredicateTolerances.tolerances`: L rounded up so that its powers are exact,
    the safe scale range checked), each θ rounded up: |F[x]| > θ decides the sign."""
    tol = decl.tolerances(L_bound, dtype)
    ctx = tol.ctx
    Lq = ctx.to_fraction(tol.L)
    e = Fraction(1, 2**ctx.bits) if ctx.bits is not None else Fraction(0)
    out: dict = {}
    for pname, qs in threshold_expressions(decl).items():
        for q, theta in qs.items():
            exact = theta.subs({eps: sympy.Rational(e.numerator, e.denominator),
                                L: sympy.Rational(Lq.numerator, Lq.denominator)})
            with ctx.session():
                out.setdefault(pname, {})[q] = ctx.from_fraction(_upper_fraction(exact), "up")
    return out
