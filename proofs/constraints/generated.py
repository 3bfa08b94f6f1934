"""Constraints generated from an instrumented run (:mod:`proofs.constraints`): the
window of every comparison against a tolerance, the protection of every sign test, the
declared divisors; comparisons of the form x² ≤ T²·q go to :mod:`.special`."""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from fperr import InvalidBound, Tracked
from fperr.notation import greek
from fperr.ops import BY_RULE
from fperr.symbols import EPS_MAX, L, eps

from ..tables import Values
from .facts import PAPER, Declared
from .model import Constraint, Inequality, _ids, bounds, fmt, label
from .special import special_argument


def sign_threshold(E_sign: sympy.Expr, power) -> sympy.Expr:
    """θ = K·ε·L^p, K the smallest integer ≥ (1 + ε)·E_sign/(ε·L^p) for every
    ε ≤ 1e-5 (the coefficients are non-negative: the largest is at ε = 1e-5); a lane
    with |F[x]| > θ has the exact sign (docs/proofs.md, "Sign tests")."""
    unit = sympy.expand((1 + eps) * E_sign / (eps * L**power))
    K = sympy.ceiling(unit.subs(eps, EPS_MAX))
    return sympy.Integer(K) * eps * L**power


class _Impure(Exception):
    """The expression depends on input coordinates."""


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



@dataclass
class _Window:
    """Checks of quantities against one g(T) with one error model, merged."""

    tol: str
    gexpr: sympy.Expr           # g(T) with T a symbol
    T: sympy.Symbol
    relative: bool
    error: sympy.Expr           # E[x] + E[g(T)]: Check.error()
    R_lhs: sympy.Expr | None    # R[x], when x has a relative bound
    E_rhs: sympy.Expr           # E[g(T)], for the relative form
    labels: list
    lines: list


def _window_constraint(dim, alg, w: _Window, v: Values) -> Constraint:
    """Section 3's window of a comparison: g(T+) − g(T) and g(T) − g(T−) exceed the
    error of the check (or, with a relative bound, R[x]·g(T±) + E[g(T)])."""
    lo, mid, hi = v.all(w.tol)
    gl, gm, gh = (w.gexpr.subs(w.T, x) for x in (lo, mid, hi))
    Tn = greek(w.tol)
    gtxt = fmt(w.gexpr).replace(str(w.T), Tn)
    gsym = lambda which: gtxt.replace(Tn, greek(w.tol, which)) if which else gtxt
    what = ", ".join(w.labels)
    if w.relative:
        up_err = w.R_lhs * gh + w.E_rhs
        lo_err = w.R_lhs * gl + w.E_rhs
        stmt = (f"{gsym('hi')} − {gtxt} > R[x]·{gsym('hi')} + E[{gtxt}] and "
                f"{gtxt} − {gsym('lo')} > R[x]·{gsym('lo')} + E[{gtxt}]")
        detail = (f"x ∈ {{{what}}} has relative error R[x] ≤ {fmt(w.R_lhs)}; "
                  f"E[{gtxt}] ≤ {fmt(w.E_rhs)}"
                  f" (absolute form E[x] + E[{gtxt}] = {fmt(w.error)})")
    else:
        up_err = lo_err = w.error
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
                  error=up_err if not w.relative else None, abs_error=w.error,
                  quantities=list(w.labels))
    return c


class _Run:
    """The constraints of one instrumented run, built check by check (section 3)."""

    def __init__(self, ins, v: Values, alg: str, declared: Declared = PAPER):
        self.ins, self.v, self.dim, self.alg = ins, v, ins.dim, alg
        self.declared = declared
        self.names = set(v.tab)
        self.checks = list(ins.checks)
        self.out: list[Constraint] = []
        self.windows: dict = {}
        self.signs: dict = {}
        self.protected_by_check: dict[int, tuple] = {}

    def fail(self, cid, chk, why):
        self.out.append(Constraint(f"{self.dim}D.{self.alg}.{cid}", self.dim, self.alg, "3",
                                   "window", str(chk), lines=(chk.line,), error=why))

    def comparison(self, chk) -> None:
        """A comparison against a tolerance: a window, or the 5.4.4 special case."""
        tols = tolerance_nodes(chk.rhs, self.names)
        lab = label(chk.lhs)
        if len(tols) != 1:
            self.fail(f"check[{_ids([lab])}]", chk,
                      f"comparison against {len(tols)} tolerances is not supported")
            return
        T = tols[0]
        Tsym = sympy.Symbol(f"_T_{T}", positive=True)
        try:
            gexpr = exact_value(chk.rhs, {T: Tsym})
        except _Impure:
            self.special(chk, T, lab)
            return
        if _monomial_in(sympy.expand(gexpr), Tsym) is None:
            self.fail(f"check[{_ids([lab])}]", chk, f"{gexpr} is not c·T^k")
            return
        try:
            error = chk.error()  # the error model of a check, written once
        except InvalidBound as e:
            self.fail(f"window.{T}[{_ids([lab])}]", chk, f"no error bound: {e}")
            return
        R_lhs, E_rhs = bounds(chk.lhs).R, bounds(chk.rhs).E
        rel = R_lhs is not None
        key = (T, sympy.srepr(gexpr), rel, sympy.srepr(error), sympy.srepr(R_lhs),
               sympy.srepr(E_rhs))
        w = self.windows.get(key)
        if w is None:
            w = self.windows[key] = _Window(T, gexpr, Tsym, rel, error, R_lhs, E_rhs, [], [])
        if lab not in w.labels:
            w.labels.append(lab)
        w.lines.append(chk.line)
        if chk.lhs.rule == "I" and chk.rel in ("<=", "<"):
            self.protected_by_check[id(chk.lhs.args[0])] = (
                T, gexpr.subs(Tsym, self.v.lo(T)), chk.line, gexpr, Tsym)

    def special(self, chk, T: str, lab: str) -> None:
        """x² ≤ T²·q with an input-dependent q: section 5.4.4's argument."""
        sp = _special_pattern(chk, T, self.names)
        if sp is None:
            self.fail(f"check[{_ids([lab])}]", chk, "the right-hand side depends on the "
                      "inputs and is not of the form T²·q handled by section 5.4.4")
            return
        x, tt, q = sp
        lower = _lower_bound_check(self.checks, q, chk, self.names)
        if lower is None:
            self.fail(f"special.line{chk.line}", chk,
                      f"no earlier check bounds {label(q)} from below")
            return
        try:
            self.out.append(special_argument(self.dim, self.alg, chk, x, tt, T, q, lower[0],
                                             self.v,
                                             self.declared.m_lower.get((self.dim, self.alg)),
                                             lower[1]))
        except InvalidBound as e:
            self.fail(f"special.line{chk.line}", chk, str(e))

    def sign(self, chk) -> None:
        """A sign test: the lower bound on |x| that protects it (section 3, case 2), or,
        for a predicate declared "sign exact or undecided", its filter threshold. The
        error is the sign bound (docs/proofs.md, "Sign tests")."""
        x = chk.lhs
        lab = label(x)
        try:
            E = chk.error()  # E_sign[x] + E[0]
        except InvalidBound as e:
            self.fail(f"sign[{_ids([lab])}]", chk, f"no error bound: {e}")
            return
        R_x = bounds(x, sign=True).R
        prot = self.protected_by_check.get(id(x))
        declared = self.declared.protected.get((self.dim, self.alg), {})
        filtered = self.declared.filtered.get((self.dim, self.alg))
        if R_x is not None:
            key = ("relative", sympy.srepr(R_x))
            entry = self.signs.setdefault(key, {"labels": [], "lines": [], "kind": "relative",
                                                "R": R_x})
        elif prot is not None and prot[2] is not None and chk.line is not None \
                and prot[2] <= chk.line:
            T, bexpr = prot[0], prot[1]
            gtxt = fmt(prot[3]).replace(str(prot[4]), greek(T, "lo"))
            key = ("check", T, sympy.srepr(bexpr), sympy.srepr(E))
            entry = self.signs.setdefault(key, {
                "labels": [], "lines": [], "kind": "check", "B": bexpr, "E": E,
                "why": f"|x| > {gtxt}: '|x| ≤ {greek(T)}' is rejected on line {prot[2]}",
                "section": "3", "tol": T})
        elif x.name in declared:
            b = declared[x.name]
            key = ("declared", b.text, sympy.srepr(E))
            entry = self.signs.setdefault(key, {"labels": [], "lines": [], "kind": "declared",
                                                "B": b.expr(self.v), "E": E,
                                                "why": f"|x| > {b.text}",
                                                "section": b.section})
        elif filtered is not None and (x.name in filtered or "*" in filtered):
            theta = filtered.get(x.name)
            key = ("filter", x.name if theta is not None else None, sympy.srepr(E))
            entry = self.signs.setdefault(key, {
                "labels": [], "lines": [], "kind": "filter", "E": E,
                "theta": theta.expr(self.v) if theta is not None
                else sign_threshold(E, x.p), "declared": theta is not None})
        else:
            self.fail(f"sign[{_ids([lab])}]", chk,
                      "unprotected sign test: no '|x| ≤ T' rejection before it, no "
                      "declared geometric lower bound on |x|, and the predicate is not "
                      "declared sign-exact-or-undecided (sign_filter)")
            return
        if lab not in entry["labels"]:
            entry["labels"].append(lab)
        entry["lines"].append(chk.line)

    def sign_constraint(self, e: dict) -> Constraint:
        dim, alg, labs = self.dim, self.alg, _ids(e["labels"])
        lines = tuple(sorted(set(e["lines"])))
        if e["kind"] == "relative":
            return Constraint(
                f"{dim}D.{alg}.sign[{labs}]", dim, alg, "3", "sign",
                "R[x] < 1 (a relative error below 1 keeps the sign)",
                [Inequality(sympy.Integer(1), e["R"])],
                detail=f"R[x] ≤ {fmt(e['R'])}", lines=lines)
        if e["kind"] == "filter":
            return self.filter_constraint(e, labs, lines)
        c = Constraint(
            f"{dim}D.{alg}.sign[{labs}]", dim, alg, e["section"], "sign",
            f"sign of x ∈ {{{', '.join(e['labels'])}}} exact: {e['why']} > E_sign[x]",
            [Inequality(e["B"], e["E"])], detail=f"E_sign[x] = {fmt(e['E'])}", lines=lines)
        c.info.update(error=e["E"], bound=e["B"], quantities=list(e["labels"]),
                      tol=e.get("tol"))
        return c

    def filter_constraint(self, e: dict, labs: str, lines: tuple) -> Constraint:
        """"Sign exact or undecided" (docs/proofs.md, "Sign tests"): a lane with
        |F[x]| > θ is decided by the sign of F[x], any other is undecided; sound when
        θ ≥ (1 + ε)·E_sign[x] (|y| ≥ |F[x]|/(1 + ε) for the value y the last operation
        rounds)."""
        dim, alg = self.dim, self.alg
        theta, E = e["theta"], e["E"]
        how = "declared" if e["declared"] else "derived"
        c = Constraint(
            f"{dim}D.{alg}.sign_filter[{labs}]", dim, alg, "3", "sign",
            f"sign of x ∈ {{{', '.join(e['labels'])}}} exact or undecided: |F[x]| > θ = "
            f"{fmt(theta)} ({how}) decides it, and θ ≥ (1 + ε)·E_sign[x]",
            [Inequality(theta, sympy.expand((1 + eps) * E), strict=False,
                        label="θ ≥ (1 + ε)·E_sign[x]")],
            detail=f"E_sign[x] = {fmt(E)}", lines=lines)
        c.info.update(error=E, bound=theta, quantities=list(e["labels"]), threshold=theta)
        return c

    def nonzero(self, qname: str, b) -> Constraint:
        """A declared divisor (m in edge-vertex) is bounded away from 0 beyond its error."""
        dim, alg = self.dim, self.alg
        xq = self.ins.quantities.get(qname)
        cid = f"{dim}D.{alg}.nonzero[{qname}]"
        stmt = f"{qname} > 0, enforced by {qname} > {b.text.split('  (')[0]} > E[{qname}]"
        if xq is None:
            return Constraint(cid, dim, alg, b.section, "nonzero", stmt,
                              error=f"quantity {qname!r} not found in the run")
        try:
            E = bounds(xq, strict=True).E
        except InvalidBound as e:
            return Constraint(cid, dim, alg, b.section, "nonzero", stmt, error=str(e))
        c = Constraint(cid, dim, alg, b.section, "nonzero", stmt,
                       [Inequality(b.expr(self.v), E)], detail=f"E[{qname}] = {fmt(E)}")
        c.info.update(error=E, quantities=[qname])
        return c


def run_constraints(ins, v: Values, algorithm: str | None = None,
                    declared: Declared = PAPER) -> list[Constraint]:
    """The floating-point constraints generated from one instrumented run: windows of
    the comparisons against tolerances first (they also record which sign tests they
    protect), then the sign tests, then the declared divisors. ``declared``: the facts
    keyed by (dim, algorithm), the paper's by default (a user's predicates bring theirs)."""
    run = _Run(ins, v, algorithm or ins.algorithm, declared)
    for chk in run.checks:
        if not chk.is_sign_test:
            run.comparison(chk)
    run.out += [_window_constraint(run.dim, run.alg, w, v) for w in run.windows.values()]
    for chk in run.checks:
        if chk.is_sign_test:
            run.sign(chk)
    run.out += [run.sign_constraint(e) for e in run.signs.values()]
    run.out += [run.nonzero(q, b) for q, b in
                run.declared.nonzero.get((run.dim, run.alg), {}).items()]
    run.out += divisor_constraints(run)
    return run.out


_DIVISIONS = ("G", "GL")  # SD divides by ±2^k: never zero


def divisor_constraints(run) -> list[Constraint]:
    """The premises of rules GL/HL: a divisor (or radicand) d whose computed value
    passed |F[d]| > f·L^p needs f·L^p > k·E[d] (k = 1: the exact |d| > 0; k = 2: d's
    relative error below 1), docs/proofs.md "Quotients and roots". A division in a
    returned weight whose divisor no check bounds below fails, naming the divisor: it
    may be 0 (a weight of −inf, or ZeroDivisionError)."""
    ins = run.ins
    declared = run.declared.nonzero.get((run.dim, run.alg), {})
    need: dict[int, list] = {}  # id(d) -> [d, k, radicand]
    roots = [*ins.quantities.values(), *(x for c in ins.checks for x in (c.lhs, c.rhs))]
    weights = {id(w) for w in ins.weights}
    for top in [*ins.weights, *roots]:
        for t in top.walk():
            for d, k in t.premises:
                role = "radicand" if t.rule == "HL" else \
                    "divisor" if d is t.args[-1] else "numerator"
                entry = need.setdefault(id(d), [d, k, role])
                entry[1] = max(entry[1], k)
            if id(top) in weights and t.rule in _DIVISIONS and t.args:
                d = t.args[1]
                if d.floor is None and d.name not in declared:
                    need.setdefault(id(d), [d, 1, "divisor"])
    return [_divisor(run, d, k, role) for d, k, role in need.values()]


def _short(t: Tracked, budget: int = 6) -> str:
    """t written with the names of its named parts (``a_A + a_B + a_C``), else label."""
    if t.name or not t.args or t.rule not in BY_RULE or budget <= 0:
        return label(t)
    parts = [_short(a, budget - 1) for a in t.args]
    parts = [f"({p})" if " " in p and len(t.args) == 2 and t.rule in ("F", "G", "GL")
             else p for p in parts]
    return BY_RULE[t.rule].text.format(*parts)


def _divisor(run, d: Tracked, k: int, what: str) -> Constraint:
    lab = _short(d)
    lab = lab if len(lab) <= 60 else label(d)
    cid = f"{run.dim}D.{run.alg}.{what}[{_ids([lab])}]"
    if d.floor is None:
        return Constraint(cid, run.dim, run.alg, "3", "nonzero", f"{lab} ≠ 0",
                          error=f"unguarded divisor {lab} of a returned weight: no check "
                                f"bounds |{lab}| from below, so it may be 0; reject "
                                f"|{lab}| <= T (a tolerance) before dividing, or declare "
                                f"it nonzero (docs/custom-predicates.md, 'A quotient')")
    times = "" if k == 1 else f"{k}·"
    stmt = (f"|{lab}| > 0: |F[{lab}]| > f·L^p (a passed check) and f·L^p > {times}E[{lab}]"
            + ("" if k == 1 else f" ({k}: a relative error below 1)"))
    try:
        E = bounds(d, strict=True).E
    except InvalidBound as e:
        return Constraint(cid, run.dim, run.alg, "3", "nonzero", stmt, error=str(e))
    from fperr.symbols import L
    f = d.floor * L**d.state.p
    c = Constraint(cid, run.dim, run.alg, "3", "nonzero", stmt, [Inequality(f, k * E)],
                   detail=f"f·L^p = {fmt(f)}, E[{lab}] = {fmt(E)}")
    c.info.update(error=E, quantities=[lab])
    return c


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