"""What a passed check tells the analysis: lower bounds on computed magnitudes.

A predicate that rejects ``|d| <= t`` continues only with |F[d]| > F[t]. When t is
*tight* (its exact value is c_t·L^p: constants, L^p and the tolerances built from them)
and has a relative bound R[t], then F[t] ≥ c_t·(1 − R[t])·L^p, so afterwards

    |F[d]| > f·L^p,   f = c_t·(1 − a_t·ε − b_t·ε²)          (the *floor* of d).

A floor is what rules GL and HL need (:mod:`fperr.rules`): with E[d] = e·L^p and the
premise D = f − e > 0 (checked by the verifier), the exact |d| ≥ D·L^p. Floors also
follow a sum of terms whose computed signs agree (a rejected ``differ_sign``) or a
difference of terms whose signs differ (a rejected ``same_sign``): |x̂ ± ŷ| = |x̂| + |ŷ|
and rounding to nearest keeps at least (1 − ε) of it. docs/proofs.md, "Quotients and
roots", has the proofs.
"""
from __future__ import annotations

import sympy

from . import rules
from .symbols import eps


def power_of_two(t) -> bool:
    """t is an exact, ε-free constant ±2^k (rule S/SD scale by it without rounding)."""
    return t.rule == "J" and t.v and not t.args and rules._power_of_two(t.state)


def threshold_floor(t, power) -> sympy.Expr | None:
    """f with F[t] ≥ f·L^p, for a tight, non-negative t with a relative bound and
    t's power equal to ``power``; else None (no lower bound follows)."""
    if not (t.v and t.tight and not t.inv) or t.state.p != power:
        return None
    st = t.state
    if not (st.n and st.r) or st.c == 0:
        return None
    return st.c * (1 - st.a * eps - st.b * eps**2)


def record_rejection(check) -> None:
    """A rejected ``lhs <= rhs`` (or ``<``): afterwards F[lhs] > F[rhs]; when rhs
    bounds itself below, lhs (and d for lhs = |d|) gets that floor."""
    if check.rel not in ("<=", "<") or not check.lhs.v:
        return
    f = threshold_floor(check.rhs, check.lhs.state.p)
    if f is None:
        return
    targets = [check.lhs]
    if check.lhs.rule == "I" and check.lhs.args:
        targets.append(check.lhs.args[0])
    for x in targets:
        if x.floor is None:
            x.floor = f


# -- computed-sign relations (a union-find with parities) ---------------------------------
def _find(x):
    parity = 0
    while x.sign_link is not None:
        x, p = x.sign_link
        parity ^= p
    return x, parity


def relate_signs(x, y, parity: int) -> None:
    """Record sign(F[x]) = sign(F[y]) (parity 0) or the opposite (parity 1)."""
    rx, px = _find(x)
    ry, py = _find(y)
    if rx is not ry:
        rx.sign_link = (ry, px ^ py ^ parity)


def sign_relation(x, y) -> int | None:
    """0: the computed signs of x and y agree, 1: they differ, None: unknown."""
    rx, px = _find(x)
    ry, py = _find(y)
    return px ^ py if rx is ry else None


# -- propagation by the operators ------------------------------------------------------------
def after_sum(out, x, y, op: str) -> None:
    """x ± y of terms with floors whose signs make |x̂ ± ŷ| = |x̂| + |ŷ| (same signs
    for +, opposite for −): floor (f_x + f_y)(1 − ε); the result has x's sign."""
    if not out.v or x.floor is None or y.floor is None:
        return
    if sign_relation(x, y) != (0 if op == "+" else 1):
        return
    out.floor = (x.floor + y.floor) * (1 - eps)
    relate_signs(out, x, 0)


def after_unary(out, x, op: str) -> None:
    """−x and |x| keep x's floor exactly; −x has the opposite sign."""
    if not out.v:
        return
    if op in ("neg", "abs"):
        out.floor = x.floor
    if op == "neg":
        relate_signs(out, x, 1)
    if op == "abs":
        out.tight = x.tight


def after_scale(out, x, k) -> None:
    """x·2^k or x/2^k (exact): the floor scales with it, the sign follows k's."""
    if not out.v:
        return
    v = k.state.c
    if x.floor is not None:
        out.floor = x.floor * v if out.rule == "S" else x.floor / v
    relate_signs(out, x, 0 if k.state.n else 1)
    out.tight = x.tight and k.state.n
