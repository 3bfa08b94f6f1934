"""fperr verify: every tolerance constraint of the paper, decided for all ε ≤ 1e-5.

For each algorithm of section 4 (2D) and 5 (3D) the constraints are (see
:mod:`proofs.constraints`): the geometric facts of the proofs (declared, exact), the
tolerance windows and sign-test protections generated from the instrumented run of the
predicate (errors derived by :mod:`fperr`, never typed in), and the special argument of
section 5.4.4. Each is decided for EVERY unit roundoff ε in (0, 1e-5] by
:mod:`proofs.decide` (ε = s⁴, L = 1 by homogeneity, exact root isolation / rigorous
interval bounds; no sampling). The margin shown is at binary64's ε = 2^-53, L = 1:
lhs − rhs and lhs/rhs of the tightest inequality of the constraint.

Command line (:mod:`proofs.cli`)::

    fperr verify                  # 2D and 3D
    fperr verify --dim 3 -v       # with the derived errors and argument steps
    fperr verify --tolerances my.toml
    fperr verify --report docs/error-bounds.md   # also write the report

``--tolerances FILE`` (TOML or JSON) replaces coefficients of T−, T, T+; e.g.::

    [3.phi]
    lo = 200

(format: :mod:`proofs.tables`). A constraint the new table breaks is printed as FAIL
with its name and the ε-range where it fails. Exit status: 0 when every constraint
holds, 1 when any fails, 2 for an unusable tolerance file.

``--require-paper-argument`` additionally requires the paper's own argument of
section 5.4.4 to hold (by default a constraint with several encoded arguments holds
when one of them is proven for every ε; see docs/proofs.md).

Python API: :func:`verify` accepts predicates or instrumented runs, so a modified
predicate can be checked without touching the built-in ones; :func:`format_outcome`
is the text the command prints.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field


import predicates
from predicates.core import Instrumented, Predicate

from . import tables
from .constraints import (Constraint, fmt, geometric_constraints, run_constraints,
                          table_constraints)
from .decide import Decision, NotHomogeneous, decide


@dataclass
class Outcome:
    """A decided constraint. ``holds``; per-inequality decisions; for arguments, the
    decisions of every step; ``established_by`` names the argument that proves it."""

    constraint: Constraint
    holds: bool
    decisions: list = field(default_factory=list)
    arguments: list = field(default_factory=list)   # [(Argument, [[Decision]], holds)]
    established_by: str | None = None
    reason: str = ""

    @property
    def id(self):
        return self.constraint.id

    def tightest(self) -> Decision | None:
        """The decision with the smallest lhs/rhs at binary64 among those that count."""
        ds = list(self.decisions)
        for arg, steps, ok in self.arguments:
            if self.established_by in (None, arg.name) or not self.holds:
                ds += [d for st in steps for d in st]
        ds = [d for d in ds if d.at64[0] is not None]
        if not ds:
            return None
        failing = [d for d in ds if not d.holds]
        pool = failing or ds
        return min(pool, key=lambda d: (d.at64[1] if d.at64[1] is not None else float("inf"),
                                        d.at64[0]))

    def fails_on(self):
        out = []
        for d in self.decisions:
            out += list(d.fails_on)
        if self.arguments and not self.holds:
            for arg, steps, ok in self.arguments:
                for st in steps:
                    for d in st:
                        out += list(d.fails_on)
        return sorted(set(out))


@dataclass
class Report:
    dim: int
    outcomes: list
    seconds: float
    table: dict

    @property
    def ok(self) -> bool:
        return all(o.holds for o in self.outcomes)

    @property
    def failures(self) -> list:
        return [o for o in self.outcomes if not o.holds]

    def by_id(self, cid: str) -> Outcome:
        for o in self.outcomes:
            if o.id == cid:
                return o
        raise KeyError(cid)


# -- instrumented runs ------------------------------------------------------------------

def instrument(pred: Predicate, table: dict | None = None) -> Instrumented:
    """The instrumented run of ``pred`` with the tolerances of ``table`` (cached)."""
    if table is None or tables.is_default(table, pred.dim):
        return pred.instrumented()
    return pred.instrumented(table)


# -- deciding ---------------------------------------------------------------------------

def decide_constraint(c: Constraint, require_paper_argument: bool = False,
                      decide=decide) -> Outcome:
    """Decide one constraint; ``decide`` (default :func:`proofs.decide.decide`) may be a
    memoised wrapper of it (``fperr synthesize`` re-decides unchanged inequalities)."""
    if c.error:
        return Outcome(c, False, reason=c.error)
    try:
        ds = [decide(i.lhs, i.rhs, i.strict) for i in c.inequalities]
        args = []
        for a in c.arguments:
            steps = [[decide(i.lhs, i.rhs, i.strict) for i in st.inequalities]
                     for st in a.steps]
            args.append((a, steps, all(d.holds for st in steps for d in st)))
    except NotHomogeneous as e:
        return Outcome(c, False, reason=f"not homogeneous in L: {e}")
    holds = all(d.holds for d in ds)
    by = None
    if args:
        proven = [a.name for a, _, ok in args if ok]
        if require_paper_argument:
            paper = [ok for a, _, ok in args if a.name.startswith("paper")]
            holds = holds and all(paper)
            by = args[0][0].name if holds else None
        else:
            holds = holds and bool(proven)
            by = proven[0] if proven else None
    reason = ""
    if not holds:
        fr = [r for d in ds for r in d.fails_on]
        reason = _ranges_text(fr) if fr else ""
        if args and not reason:
            reason = "no encoded argument holds for every ε"
    return Outcome(c, holds, ds, args, by, reason)


def _ranges_text(ranges) -> str:
    if not ranges:
        return ""
    parts = []
    for lo, hi in sorted(set(ranges)):
        parts.append(f"ε ∈ ({lo:.4g}, {hi:.4g}]" if lo > 0 else f"ε ∈ (0, {hi:.4g}]")
    return "fails for " + ", ".join(parts)


def _as_runs(dim, runs, table):
    """Normalise the ``runs`` argument to [(algorithm name, Instrumented)]."""
    if runs is None:
        runs = predicates.ALL[dim]
    items = runs.items() if isinstance(runs, dict) else [(None, r) for r in runs]
    out = []
    for name, r in items:
        if isinstance(r, Predicate):
            if r.dim != dim:
                raise ValueError(f"{r!r} is not a {dim}D predicate")
            ins = instrument(r, table)
        elif isinstance(r, Instrumented):
            if r.dim != dim:
                raise ValueError(f"instrumented run {r.algorithm} is not {dim}D")
            ins = r
        else:
            raise TypeError(f"expected a Predicate or an Instrumented run, got {r!r}")
        out.append((name or ins.algorithm, ins))
    return out


def constraints(dim: int, overrides: dict | None = None, runs=None) -> list[Constraint]:
    """Every constraint of ``dim`` (table facts, then per algorithm: geometric facts
    and the constraints generated from its instrumented run)."""
    tab = tables.table(dim, overrides)
    v = tables.Values(tab)
    out = table_constraints(dim, v)
    for alg, ins in _as_runs(dim, runs, tab):
        out += geometric_constraints(dim, alg, v)
        out += run_constraints(ins, v, alg)
    return out


def verify(dim: int, overrides: dict | None = None, runs=None,
           require_paper_argument: bool = False, progress: bool = False) -> Report:
    """Decide every constraint of ``dim`` for every ε ∈ (0, 1e-5].

    ``overrides``: coefficient overrides ({dim: {name: {"lo"|"mid"|"hi": value}}}, see
    :mod:`proofs.tables`). ``runs``: predicates and/or :class:`Instrumented` runs to
    verify instead of ``predicates.ALL[dim]`` (a list, or a dict keyed by the paper
    algorithm whose declared facts apply, e.g. {"edge_vertex": my_variant}). An
    Instrumented run is used as given (its tolerance errors are those it was run with);
    a Predicate is re-run with the overridden tolerances. ``progress``: a bar on stderr.
    """
    t0 = time.perf_counter()
    tab = tables.table(dim, overrides)
    cs = constraints(dim, overrides, runs)
    return decide_all(dim, cs, tab, t0, require_paper_argument, progress)


def decide_all(dim: int, cs: list[Constraint], tab: dict, t0: float,
               require_paper_argument: bool = False, progress: bool = False) -> Report:
    """Decide the constraints ``cs`` of the table ``tab`` (generated since ``t0``,
    :func:`time.perf_counter`); also the path of a user's predicates
    (:mod:`proofs.user_predicates`)."""
    if progress:
        import sys

        from tqdm import tqdm
        cs = tqdm(cs, desc=f"fperr verify {dim}D", unit="constraint", leave=False,
                  delay=1.0, file=sys.stderr)
    outs = [decide_constraint(c, require_paper_argument) for c in cs]
    return Report(dim, outs, time.perf_counter() - t0, tab)


def outcome_dict(o: Outcome) -> dict:
    """One decided constraint as plain data: name, status, margin (binary64, L = 1)."""
    d = o.tightest()
    diff, ratio = d.at64 if d is not None else (None, None)
    return {"name": o.id, "status": "pass" if o.holds else "fail",
            "section": o.constraint.section, "statement": o.constraint.statement,
            "margin": None if diff is None else float(diff),
            "ratio": None if ratio is None else float(ratio),
            "established_by": o.established_by or None, "reason": o.reason or None}


# -- text --------------------------------------------------------------------------------

def _margin_text(o: Outcome) -> str:
    d = o.tightest()
    if d is None:
        return ""
    diff, ratio = d.at64
    r = f"×{ratio:.4g}" if ratio is not None else ""
    return f"{diff:+.3e} {r}".strip()


def format_outcome(o: Outcome, verbose: bool = False) -> str:
    c = o.constraint
    status = "pass" if o.holds else "FAIL"
    lines = [f"  {status}  {c.id}"]
    sec = f"[{c.section}]" if c.section else ""
    lines.append(f"        {sec} {c.statement}")
    m = _margin_text(o)
    if m:
        lines.append(f"        margin at binary64 (L = 1, tightest: lhs − rhs, lhs/rhs): {m}")
    if o.established_by and len(c.arguments) > 1:
        lines.append(f"        established by: {o.established_by}")
    for a, steps, ok in o.arguments:
        if not ok:
            bad = [(st, ds) for st, ds in zip(a.steps, steps) if not all(d.holds for d in ds)]
            head = "note: not relied on, " if o.holds else ""
            for st, ds in bad[:3]:
                fr = [r for d in ds for r in d.fails_on]
                lines.append(f"        {head}{a.name} does not hold: step '{st.title}' "
                             f"{_ranges_text(fr) or 'fails'}")
    if not o.holds:
        lines.append(f"        -> {o.reason or 'fails'}")
    if verbose:
        if c.detail:
            lines.append(f"        derived: {c.detail}")
        for i, d in zip(c.inequalities, o.decisions):
            lines.append(f"        {'ok ' if d.holds else 'NO '} {i.label or 'lhs > rhs'}: "
                         f"{fmt(i.lhs)} {'>' if i.strict else '≥'} {fmt(i.rhs)}  "
                         f"[{d.method}]")
        for a, steps, ok in o.arguments:
            lines.append(f"        argument: {a.name}: {'holds' if ok else 'does not hold'}")
            for st, ds in zip(a.steps, steps):
                okst = all(d.holds for d in ds)
                lines.append(f"          {'ok ' if okst else 'NO '} {st.title}")
    return "\n".join(lines)
