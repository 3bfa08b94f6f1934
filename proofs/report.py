"""Generate docs/error-bounds.md: the paper's figures and constraint lists, from the code.

    python -m proofs.report            # (re)write ./docs/error-bounds.md
    python -m proofs.report --check    # exit 1 when that copy is stale
    python -m proofs.report -o FILE    # write elsewhere ("-" for stdout)

(run from the repository root; paths are relative to the current directory)

Regenerates Figure 1 and Figure 5 (T−, T, T+ from :mod:`predicates.tolerance_table`,
R[T] derived by the instrumented tolerance computation), the "Floating point:" lines of
every algorithm (instrumented runs) and the "Tolerance constraints:" lines (the
constraints of :mod:`proofs.verify`, each decided for every ε ≤ 1e-5, with margins at
binary64's and binary32's unit roundoff), and sets the paper's printed figures
(:mod:`proofs.paper_printed`) beside them, marking where they differ.
"""
from __future__ import annotations

import sys
from pathlib import Path

import sympy

import predicates
from fperr import bounds
from fperr.notation import GREEK, epow, lpow
from fperr.symbols import EPS_MAX, L, eps
from predicates.registration.io.write import write_text_atomic

from . import paper_printed as paper
from .constraints import fmt
from .decide import EPS32, EPS64
from .tables import TABLES
from .verify import instrument, verify

# -- formatting helpers -------------------------------------------------------------------

def _coef(c: sympy.Expr) -> str:
    c = sympy.nsimplify(c)
    if c.is_Integer:
        return str(c)
    if c.is_Rational:
        q = int(c.q)
        while q % 2 == 0:
            q //= 2
        while q % 5 == 0:
            q //= 5
        if q == 1:  # terminating decimal, printed exactly
            from decimal import Decimal
            return format(Decimal(int(c.p)) / Decimal(int(c.q)), "f")
        return str(c)
    return f"{fmt(c)} ≈ {float(c):.2f}"


def paper_form(err: sympy.Expr):
    """(K, k, p): the smallest integer K with err ≤ K·ε^k·L^p for every ε ≤ 1e-5, k the
    lowest power of ε in err (the paper's integer form of an error bound)."""
    e = sympy.expand(err)
    terms = sympy.Add.make_args(e)
    ks, ps = [], set()
    for t in terms:
        _, k = t.as_coeff_exponent(eps)
        _, p = t.as_coeff_exponent(L)
        ks.append(k)
        ps.add(p)
    k = min(ks)
    p = ps.pop() if len(ps) == 1 else None
    val = sympy.expand(e / eps**k).subs({L: 1, eps: EPS_MAX})
    K = int(sympy.ceiling(sympy.N(val, 50)))
    if sympy.N(val, 50) == K:
        K = int(val)
    return K, k, p


def _form_text(K, k, p) -> str:
    return f"{K}{epow(k)}{lpow(p) if p is not None else ''}"


def _cmp_text(lv: float, rv: float) -> str:
    """lhs/rhs when both sides are positive, else lhs − rhs (> 0: holds)."""
    if lv > 0 and rv > 0:
        return f"×{lv / rv:.4g}"
    return f"Δ = {lv - rv:+.3g}"


def _ratio(d, which) -> str:
    diff, ratio = getattr(d, which)
    if ratio is None:
        return f"Δ = {diff:+.3g}" if diff is not None else ""
    return f"×{ratio:.4g}"


def _status(o) -> str:
    return "holds" if o.holds else "**FAILS**"


def _esc(s: str) -> str:
    return s.replace("|", "\\|")


# -- sections ---------------------------------------------------------------------------

def _figure(dim: int) -> list[str]:
    tol = predicates.tracked_tolerances(dim)
    fig = 1 if dim == 2 else 5
    out = [f"### Figure {fig}: tolerances for {dim}D", "",
           "| Name | T− | T | T+ | R[T] derived | R[T] exact (derived) | paper printed R[T] | "
           "description |", "|---|---|---|---|---|---|---|---|"]
    for name, spec in TABLES[dim].items():
        unit = f"{epow(spec.q)}{lpow(spec.p)}"
        b = bounds(tol.values[name])
        out.append(f"| {GREEK[name]} | {_coef(spec.lo)}{unit} | {_coef(spec.mid)}{unit} | "
                   f"{_coef(spec.hi)}{unit} | {b.R_int}ε | {fmt(b.R)} | {paper.R_T}ε"
                   f"{' (differs)' if b.R_int != paper.R_T else ''} | {spec.description} |")
    out += ["", "T+ entries the paper prints as \"≈\" (ζ+, ξ+, ρ+) are the exact geometric "
            "expressions that define them. R[T] is derived from the instrumented tolerance "
            "computation (predicates.tolerances); it is smaller than the printed 4ε "
            "(see docs/errata.md).", ""]
    return out


def _floating_point(dim, alg, ins) -> list[str]:
    out = ["**Floating point** (derived from the instrumented run):", ""]
    parts = []
    for name, q in ins.quantities.items():
        b = bounds(q)
        if not b.valid:
            parts.append(f"{name}: invalid ({q.why})")
            continue
        if b.R_int is not None:
            parts.append(f"R[{name}] ≤ {b.R_int}ε")
        if b.E_int is not None:
            parts.append(f"E[{name}] ≤ {b.E_int}ε{lpow(b.power)}")
    out.append(". ".join(parts) + ".")
    out += ["", "| quantity | derived | exact derived bound | paper printed | |",
            "|---|---|---|---|---|"]
    printed = {(q, k): K for q, k, K in paper.FLOATING_POINT.get((dim, alg), [])}
    for name, q in ins.quantities.items():
        b = bounds(q)
        if not b.valid:
            continue
        rows = []
        if b.R is not None:
            rows.append(("R", f"R ≤ {b.R_int}ε", fmt(b.R), b.R_int))
        rows.append(("E", f"E ≤ {b.E_int}ε{lpow(b.power)}", fmt(b.E), b.E_int))
        for kind, txt, exact, K in rows:
            P = printed.get((name, kind))
            ptxt = "" if P is None else (f"R ≤ {P}ε" if kind == "R"
                                         else f"E ≤ {P}ε{lpow(b.power)}")
            mark = "" if P is None else ("same" if P == K else "**differs**")
            out.append(f"| {name} | {txt} | {exact} | {ptxt} | {mark} |")
        P = printed.get((name, "c"))
        if P is not None:
            c = q.state.c
            out.append(f"| {name} | {name} ≤ {c}{lpow(b.power)} | c = {c} | "
                       f"{name} ≤ {P}{lpow(b.power)} | {'same' if c == P else '**differs**'} |")
    out.append("")
    return out


def _find(outcomes, match):
    kind = match[0]
    for o in outcomes:
        c = o.constraint
        if kind == "geometric" and c.kind == "geometric" and c.id.endswith("." + match[1]):
            return o
        if kind == "window" and c.kind == "window" and c.info.get("tol") == match[1] \
                and match[2] in c.info.get("quantities", []):
            return o
        if kind == "sign" and c.kind == "sign" and match[1] in c.info.get("quantities", []):
            return o
        if kind == "nonzero" and c.kind == "nonzero" and c.id.endswith(f"[{match[1]}]"):
            return o
        if kind == "special" and c.kind == "special" and c.info.get("T") == match[1]:
            return o
    return None


def _derived_requirement(o) -> str:
    c = o.constraint
    if c.error:
        return f"cannot be formed: {c.error}"
    if c.kind == "window":
        if c.info.get("relative"):
            return _esc(c.statement) + "; " + _esc(c.detail)
        return f"{_esc(c.statement)}, E[x] + E[T] = {fmt(c.info['error'])}"
    if c.kind == "sign":
        return f"{_esc(c.statement)}, E_sign[x] = {fmt(c.info['error'])}"
    if c.kind == "nonzero":
        return f"{_esc(c.statement)}, E[x] = {fmt(c.info['error'])}"
    if c.kind == "special":
        return _esc(c.statement) + f" (see [section 5.4.4 below](#special-{c.dim}d-{c.algorithm}))"
    return _esc(c.statement)


def _constraints_table(outcomes) -> list[str]:
    out = ["| constraint | status for all ε ∈ (0, 1e-5] | derived requirement | "
           "lhs/rhs at binary64 | at binary32 |", "|---|---|---|---|---|"]
    for o in outcomes:
        d = o.tightest()
        r64 = _ratio(d, "at64") if d else ""
        r32 = _ratio(d, "at32") if d else ""
        st = _status(o)
        if not o.holds and o.reason:
            st += f" ({o.reason})"
        if o.constraint.kind == "geometric" and o.constraint.info.get("equality_holds"):
            st += " (with equality)"
        out.append(f"| `{_esc(o.id)}` | {st} | {_derived_requirement(o)} | {r64} | {r32} |")
    out.append("")
    return out


def _printed_table(dim, alg, outcomes) -> list[str]:
    rows = paper.CONSTRAINTS.get((dim, alg), [])
    if not rows:
        return []
    out = ["**Tolerance constraints as printed**, beside the derived ones:", "",
           "| paper printed | derived constraint | derived bound | comparison |",
           "|---|---|---|---|"]
    for text, match, compare, note in rows:
        o = _find(outcomes, match)
        if o is None:
            out.append(f"| {_esc(text)} | (no generated constraint) | | **missing** |")
            continue
        c = o.constraint
        derived = ""
        cmp = ""
        if compare is not None:
            err = c.info.get("abs_error") if c.kind == "window" else c.info.get("error")
            if err is not None:
                K, k, p = paper_form(err)
                derived = f"{_form_text(K, k, p)} (exact {fmt(err)})"
                cmp = "same" if K == compare[1] else \
                    f"**differs**: printed {compare[1]}, derived {K}"
        else:
            cmp = "different form" if note else ""
            if c.kind == "geometric":
                cmp = ("holds with equality" if c.info.get("equality_holds") else "holds") \
                    if o.holds else "**FAILS**"
            elif c.kind == "special":
                cmp = f"established by: {o.established_by}" if o.holds else "**FAILS**"
        if note:
            cmp += f"; {note}" if cmp else note
        status = "" if o.holds else " **FAILS**"
        out.append(f"| {_esc(text)} | `{_esc(c.id)}`{status} | {_esc(derived)} | {_esc(cmp)} |")
    out.append("")
    return out


def _eval(expr, epsilon) -> float:
    return float(sympy.N(sympy.sympify(expr).subs({L: 1, eps: epsilon}), 30))


def _special_section(o) -> list[str]:
    c = o.constraint
    out = [f'<a id="special-{c.dim}d-{c.algorithm}"></a>', "",
           f"#### Section 5.4.4 argument for `{c.id}`", "",
           f"{c.statement}.", "", f"Derived inputs: {c.detail}.", ""]
    if c.algorithm == "edge_edge" or c.info.get("T") == "gamma":
        out += ["Paper printed: " + "; ".join(f"{k}: {v}" for k, v in
                                              paper.SECTION_544.items()) + ".", ""]
    else:
        out += ["Paper printed: \"identical to the case addressed in Section 5.4.4\".", ""]
    for (arg, steps, ok) in o.arguments:
        flag = "holds for every ε ∈ (0, 1e-5]" if ok else "**does not hold on the whole range**"
        used = " — establishes the constraint" if o.established_by == arg.name else \
            (" — not relied on" if o.holds else "")
        out += [f"*{arg.name}*: {flag}{used}." + (f" Note: {arg.note}." if arg.note else ""),
                "", "| step | status | where it fails | at ε = 1e-5 | at binary32 | "
                "at binary64 |", "|---|---|---|---|---|---|"]
        for st, ds in zip(arg.steps, steps):
            holds = all(d.holds for d in ds)
            fails = "; ".join(f"ε ∈ ({lo:.4g}, {hi:.4g}]" for d in ds for lo, hi in d.fails_on)
            ineqs = st.inequalities
            vals = []
            for epsilon in (EPS_MAX, EPS32, EPS64):
                vals.append(", ".join(_cmp_text(_eval(i.lhs, epsilon), _eval(i.rhs, epsilon))
                                      for i in ineqs))
            out.append(f"| {_esc(st.title)} | {'holds' if holds else '**fails**'} | "
                       f"{fails} | {vals[0]} | {vals[1]} | {vals[2]} |")
        out.append("")
    return out


def _summary(reps) -> list[str]:
    """The summary: constraint counts, failing 5.4.4 steps, printed integers that differ."""
    out = []
    for dim, rep in reps.items():
        n, nf = len(rep.outcomes), len(rep.failures)
        out.append(f"- {dim}D: {n} constraints; {n - nf} hold for every ε ∈ (0, 1e-5]"
                   + (f"; **{nf} FAIL**: " + ", ".join(f"`{o.id}`" for o in rep.failures)
                      if nf else "; none fails."))
    diffs = []
    for dim, rep in reps.items():
        for (d, alg), rows in paper.CONSTRAINTS.items():
            if d != dim:
                continue
            alg_os = [o for o in rep.outcomes if o.constraint.algorithm == alg]
            for text, match, compare, note in rows:
                o = _find(alg_os, match)
                if o is None or compare is None:
                    continue
                c = o.constraint
                err = c.info.get("abs_error") if c.kind == "window" else c.info.get("error")
                if err is None:
                    continue
                K, k, p = paper_form(err)
                item = f"`{c.id}`: printed {compare[1]}, derived {_form_text(K, k, p)}"
                if K != compare[1] and item not in diffs:
                    diffs.append(item)
    specials = [o for rep in reps.values() for o in rep.outcomes
                if o.constraint.kind == "special"]
    for o in specials:
        for arg, steps, ok in o.arguments:
            if arg.name.startswith("paper") and not ok:
                bad = [(st, ds) for st, ds in zip(arg.steps, steps)
                       if not all(d.holds for d in ds)]
                rng = "; ".join(f"'{st.title}' fails for ε ∈ ({lo:.3g}, {hi:.3g}]"
                                for st, ds in bad for d in ds for lo, hi in d.fails_on)
                out.append(f"- `{o.id}`: the paper's own argument of section 5.4.4 does "
                           f"**not** hold for every ε ≤ 1e-5 ({rng}); the constraint is "
                           f"established by the {o.established_by or 'NO argument'} "
                           "(all steps below).")
    out.append("- Derived window/sign bounds that differ from the printed integers "
               "(the paper bounds E[T − x] as a computed subtraction, one rounding more than "
               "the exact comparison F[x] ≤ F[T]; a sign test is decided with the sign bound, "
               "E without the last rounding, docs/proofs.md \"Sign tests\"): " + ("; ".join(diffs) or "none") + ".")
    out.append("")
    return out


def render() -> str:
    reps = {dim: verify(dim) for dim in (2, 3)}
    out = ["# Error bounds and tolerance constraints (generated)", "",
           "<!-- generated by `python -m proofs.report`; do not edit by hand. "
           "tests/test_proofs/test_proofs.py fails when this file is stale. -->", "",
           "Every figure below is computed from the code: tolerances from "
           "`predicates.tolerance_table`, R[T] and all floating-point errors from the "
           "instrumented runs (`fperr`, rules A–K), the constraints by `proofs.verify` and "
           "decided for **every** unit roundoff ε ∈ (0, 1e-5] by `proofs.decide` (ε = s⁴, "
           "L = 1 by homogeneity, exact root isolation or rigorous interval bounds; see "
           "docs/proofs.md). \"paper printed\" columns copy the paper for comparison only "
           "(`proofs/paper_printed.py`); they never enter a constraint. Margins are "
           "shown as ×(lhs/rhs) of the tightest inequality of a constraint at L = 1 "
           "(> 1: holds), or as Δ = lhs − rhs (> 0: holds) when a side is not positive.",
           "",
           "## Summary", ""]
    out += _summary(reps)
    out += ["## Tolerances", ""]
    for dim in (2, 3):
        out += _figure(dim)
    for dim, rep in reps.items():
        out += [f"## {dim}D", ""]
        table_os = [o for o in rep.outcomes if o.constraint.algorithm == "tolerances"]
        out += ["### Table-wide constraints (sections 3, " + ("4.1" if dim == 2 else "5.1")
                + ")", ""]
        out += _constraints_table(table_os)
        for pred in predicates.ALL[dim]:
            alg = pred.name
            sec, title = pred.section, pred.title
            ins = instrument(pred)
            mod = "d2" if dim == 2 else "d3"
            out += [f"### {sec} {title} (Algorithm {pred.algorithm}, "
                    f"`predicates.{mod}.{alg}`)", ""]
            out += _floating_point(dim, alg, ins)
            os_ = [o for o in rep.outcomes if o.constraint.algorithm == alg]
            out += ["**Tolerance constraints** (derived and decided):", ""]
            out += _constraints_table(os_)
            out += _printed_table(dim, alg, os_)
            for o in os_:
                if o.constraint.kind == "special":
                    out += _special_section(o)
    return "\n".join(out).rstrip() + "\n"


def write_report(path) -> str:
    """Render the report and write it to ``path`` ("-": stdout); returns the text."""
    text = render()
    if str(path) == "-":
        sys.stdout.write(text)
    else:
        write_text_atomic(path, text)
    return text


def is_current(path) -> bool:
    """True when the file at ``path`` is exactly what :func:`render` produces now."""
    try:
        old = Path(path).read_text(encoding="utf-8")
    except OSError:
        return False
    return old == render()


if __name__ == "__main__":  # the arguments are parsed by the command-line module
    from proofs.cli import report_main
    sys.exit(report_main())
