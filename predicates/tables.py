"""``fperr tables``: the derived error bound of every quantity the paper names.

Every figure comes from running the predicates (and the tolerance computation)
instrumented with :class:`fperr.Tracked`; nothing is typed in from the paper. Kinds:
``E`` (absolute, coefficient·ε·L^power), ``S`` (the sign bound of a quantity compared
with zero: E without the last rounding, docs/proofs.md "Sign tests"), ``R`` (relative, coefficient·ε) and ``M`` (the
magnitude bound c·L^power, e.g. the paper's "m² ≤ 12L⁴"). Coefficients are the paper's
integer form (see :func:`fperr.paper_integer`); ``exact`` is the exact sympy expression.
"""
from __future__ import annotations

import json

import sympy

import fperr
from fperr.notation import LATEX_GREEK, lpow

from . import ALL, coefficients
from .tolerances import tracked_tolerances


def records(dims=(2, 3)) -> list[dict]:
    """One record per (quantity, kind) for every algorithm of the given dimensions."""
    out = []
    for dim in dims:
        for name, t in tracked_tolerances(dim).values.items():
            b = fperr.bounds(t)
            out.append(_rec(dim, "tolerances", name, "R", b.R_int, 0, b.R))
        for pred in ALL[dim]:
            out += predicate_records(pred, sign=False)
    return out


def predicate_records(pred, sign: bool = True) -> list[dict]:
    """The records of one ``@predicate`` (the paper's or a user's): E, R and M of every
    named quantity, and (``sign``) S — the sign bound, E without the last rounding
    (docs/proofs.md, "Sign tests") — of every quantity a sign test compares with 0."""
    out, dim = [], pred.dim
    ins = pred.instrumented()
    signs = {id(c.lhs) for c in ins.checks if c.is_sign_test}
    for q, x in ins.quantities.items():
        b = fperr.bounds(x)
        if not b.valid:
            continue
        out.append(_rec(dim, pred.name, q, "E", b.E_int, b.power, b.E))
        if sign and id(x) in signs and b.E is not None:
            s = fperr.bounds(x, sign=True)
            out.append(_rec(dim, pred.name, q, "S", s.E_int, s.power, s.E))
        if b.R is not None:
            out.append(_rec(dim, pred.name, q, "R", b.R_int, 0, b.R))
        c = x.state.c
        if not c.free_symbols:
            out.append(_rec(dim, pred.name, q, "M", fperr.paper_integer(c), b.power,
                            c * fperr.L ** b.power))
    return out


def _rec(dim, alg, q, kind, coef, power, exact):
    return {"dim": dim, "algorithm": alg, "quantity": q, "kind": kind,
            "coefficient": coef, "power": _num(power), "exact": str(exact)}


def _num(p):
    p = sympy.nsimplify(p)
    return int(p) if p.is_integer else float(p)


def _text(r) -> str:
    sym = {"E": "E", "S": "E_sign", "R": "R", "M": r"\|x\|"}[r["kind"]]
    eps = "" if r["kind"] == "M" else "ε"
    return f"{sym} ≤ {r['coefficient']}{eps}{lpow(r['power'], superscript=False)}"


def render(recs: list[dict], fmt: str) -> str:
    if fmt == "json":
        return json.dumps(recs, indent=1, ensure_ascii=False)
    if fmt == "latex":
        rows = [r"\begin{tabular}{rllll}", r"dim & algorithm & quantity & bound & exact \\ \hline"]
        for r in recs:
            rows.append(f"{r['dim']} & {r['algorithm'].replace('_', ' ')} & "
                        f"${_latex_name(r['quantity'])}$ & ${_latex_bound(r)}$ & "
                        f"${_latex_expr(r['exact'])}$ \\\\")
        rows.append(r"\end{tabular}")
        return "\n".join(rows)
    lines = ["| dim | algorithm | quantity | bound | exact |", "|---|---|---|---|---|"]
    for r in recs:
        lines.append(f"| {r['dim']} | {r['algorithm']} | {r['quantity']} | {_text(r)} | "
                     f"`{r['exact']}` |")
    return "\n".join(lines)


def _latex_expr(text: str) -> str:
    """LaTeX of a record's exact expression, read by :mod:`predicates.coefficients` (the
    records are data, e.g. read back from JSON: never evaluated as Python)."""
    expr = coefficients.to_sympy(coefficients.parse(text))
    return sympy.latex(expr, symbol_names={fperr.eps: r"\epsilon"})


def _latex_name(q: str) -> str:
    """LaTeX of a quantity name: greek letters, ``_hat``/``_bar`` accents, subscripts;
    a trailing 2 is a square (d2 = d², m2 = m², d_hat2 = d̂²), as the predicates name
    them (predicates/d2.py, d3.py)."""
    if len(q) > 1 and q.endswith("2") and q[-2] != "_":
        return f"{{{_latex_name(q[:-1])}}}^{{2}}"
    base, _, sub = q.partition("_")
    greek = LATEX_GREEK
    if q.endswith("_hat") or q.endswith("_bar"):
        acc = r"\hat" if q.endswith("_hat") else r"\bar"
        core = q[:-4]
        return f"{acc}{{{greek.get(core, core)}}}"
    return greek.get(base, base) + (f"_{{{sub}}}" if sub else "")


def _latex_bound(r) -> str:
    sym = {"E": r"\mathcal{E}", "S": r"\mathcal{E}_{\mathrm{sign}}", "R": r"\mathcal{R}", "M": "|x|"}[r["kind"]]
    eps = "" if r["kind"] == "M" else r"\epsilon "
    return f"{sym} \\le {r['coefficient']}{eps}{lpow(r['power'], superscript=False)}"

