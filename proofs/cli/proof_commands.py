"""``fperr tables``, ``fperr verify`` and ``python -m proofs.report`` (``fperr audit``:
:mod:`.audit_command`):
the proofs' commands (options only; the work is :mod:`predicates.tables` and
:mod:`proofs`, imported when run)."""
from __future__ import annotations

import argparse
import sys

from .common import RAW as _RAW
from .common import output_as
from .common import user_systems as _user_systems
from .audit_command import _add_audit, _run_audit
from .synthesize_command import _add_synthesize, _run_synthesize

# -- tables ----------------------------------------------------------------------------
def _add_tables(sub) -> None:
    p = sub.add_parser(
        "tables", help="derived error bounds of every algorithm (the paper's figures)",
        formatter_class=_RAW, description=(
            "The derived error bound of every quantity the paper names, from running the\n"
            "predicates (and the tolerance computation) instrumented: nothing is typed in\n"
            "from the paper. Kinds: E (absolute, coefficient*eps*L^power), R (relative,\n"
            "coefficient*eps) and M (the magnitude bound c*L^power, e.g. m2 <= 12L^4).\n"
            "Coefficients are the paper's integer form; 'exact' is the exact expression."))
    p.add_argument("--dim", type=int, choices=(2, 3), help="only this dimension")
    p.add_argument("--format", choices=("md", "latex", "json"), default="md",
                   help="output format (default md)")
    p.add_argument("--predicates", metavar="MODULE",
                   help="the @predicate functions MODULE declares in FPERR_TOLERANCES "
                        "instead of the paper's (with S: the sign bound of each quantity "
                        "compared with zero)")
    p.set_defaults(_run=_run_tables)


def _run_tables(args) -> int:
    from predicates.tables import predicate_records, records, render

    dims = (args.dim,) if args.dim else (2, 3)
    if not args.predicates:
        print(render(records(dims), args.format))
        return 0
    args.dim = [args.dim] if args.dim else None  # _user_systems takes a list
    systems = _user_systems(args, "tables")
    if isinstance(systems, int):
        return systems
    try:
        recs = [r for d in sorted(systems) for p in systems[d].predicates
                for r in predicate_records(p)]
    except (AttributeError, TypeError, ValueError, ArithmeticError) as e:
        print(f"fperr tables: {args.predicates}: an instrumented run failed: "
              f"{type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(render(recs, args.format))
    return 0


# -- verify, audit, report (proofs/) ---------------------------------------------------------

#: where fperr verify --report and python -m proofs.report write, relative to
#: the current directory (never inside the installed package)
REPORT_PATH = "docs/error-bounds.md"


#: the report (Markdown) of fperr verify --report and python -m proofs.report
_REPORT_FILE = output_as(".md", what="the report (Markdown)", stdout=True)

def _add_verify(parser: argparse.ArgumentParser) -> None:
    """fperr verify: every tolerance constraint of the paper, decided for all ε ≤ 1e-5.

Usage:

    fperr verify                  # 2D and 3D
    fperr verify --dim 3 -v       # with the derived errors and argument steps
    fperr verify --tolerances my.toml
    fperr verify --report         # also write docs/error-bounds.md (current directory)
    fperr verify --predicates mypkg.mypreds   # a module's own predicates and table

--tolerances FILE (TOML or JSON, format: proofs.tables) replaces coefficients of
T−, T, T+. --predicates MODULE imports MODULE and decides the constraints of the
predicates and tolerance table it declares in FPERR_TOLERANCES (proofs.user_predicates,
docs/custom-predicates.md) instead of the paper's. Exit status: 0 when every
constraint holds, 1 when any fails, 2 for bad arguments, an unusable tolerance file
or declaration. See proofs.verify for the constraints.
"""
    parser.add_argument("--dim", type=int, choices=(2, 3), action="append",
                        help="dimension to verify (default: both)")
    parser.add_argument("--tolerances", metavar="FILE",
                        help="TOML/JSON file replacing coefficients of T−, T, T+")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="show derived errors, inequalities and argument steps")
    parser.add_argument("--require-paper-argument", action="store_true",
                        help="fail when the paper's own 5.4.4 argument does not hold "
                             "for every ε (even if another encoded argument does)")
    parser.add_argument("--report", metavar="PATH.md", nargs="?", const=REPORT_PATH,
                        type=_REPORT_FILE,
                        help=f"also write the generated report (default: {REPORT_PATH} "
                             "in the current directory)")
    parser.add_argument("--certificate", metavar="FILE.json",
                        type=output_as(".json", what="the certificate"),
                        help="also write a certificate of every decision, checkable with "
                             "python -m proofs.check_certificate FILE")
    parser.add_argument("--format", choices=("text", "json"), default="text",
                        help="output format (default text; json: every constraint's name, "
                             "status and margin)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--predicates", metavar="MODULE",
                        help="verify the predicates and tolerances MODULE declares in "
                             "FPERR_TOLERANCES instead of the paper's")


def _run_verify(args: argparse.Namespace) -> int:
    if args.report is not None:
        try:
            _REPORT_FILE(args.report)  # the default (const) is not checked by argparse
        except argparse.ArgumentTypeError as e:
            args._parser.error(f"argument --report: {e}")
        if args.predicates:
            args._parser.error("--report writes the paper's report; it does not apply to "
                               "--predicates")
    from proofs import tables
    from proofs.verify import verify
    systems = _user_systems(args, "verify") if args.predicates else None
    if isinstance(systems, int):
        return systems
    known = {d: s.base for d, s in systems.items()} if systems else None
    try:
        overrides = tables.load_overrides(args.tolerances, known) if args.tolerances else None
    except tables.ToleranceFileError as e:
        print(f"fperr verify: {e}", file=sys.stderr)
        return 2
    ok, reports = True, {}
    as_json = args.format == "json"
    for dim in sorted(systems or set(args.dim or [2, 3])):
        try:
            if systems:
                s = systems[dim]
                rep = s.verify((overrides or {}).get(dim), args.require_paper_argument,
                               progress=not args.quiet)
            else:
                rep = verify(dim, overrides,
                             require_paper_argument=args.require_paper_argument,
                             progress=not args.quiet)
        except (ValueError, TypeError) as e:
            print(f"fperr verify: {dim}D: {e}", file=sys.stderr)
            return 2
        reports[dim] = rep
        ok = ok and rep.ok
        if not as_json:
            _print_report(dim, rep, overrides, args, systems and systems[dim])
    if as_json:
        import json

        from proofs.verify import outcome_dict
        print(json.dumps({"ok": ok, "dims": {str(d): {
            "constraints": [outcome_dict(o) for o in r.outcomes],
            "hold": len(r.outcomes) - len(r.failures), "fail": len(r.failures),
            "seconds": r.seconds} for d, r in reports.items()}}, indent=1))
    out = sys.stderr if as_json else sys.stdout  # json: stdout holds the document only
    if args.certificate:
        from proofs import certificate
        try:
            certificate.write(args.certificate, reports, args.require_paper_argument)
        except OSError as e:
            print(f"fperr verify: cannot write certificate: {e}", file=sys.stderr)
            return 2
        print(f"certificate written to {args.certificate}", file=out)
    if args.report is not None:
        from proofs.report import write_report
        write_report(args.report)
        print(f"report written to {args.report}", file=out)
    return 0 if ok else 1


def _print_report(dim, rep, overrides, args, system=None) -> None:
    from proofs.verify import format_outcome

    src = "paper's Figure 1" if dim == 2 else "paper's Figure 5"
    if system is not None:
        src = (f"{', '.join(p.name for p in system.predicates)}: the table declared in "
               f"{system.name}")
    if overrides and dim in overrides:
        src += f" with overrides from {args.tolerances}"
    print(f"{dim}D constraints ({src}), decided for every ε in (0, 1e-5]:")
    for o in rep.outcomes:
        print(format_outcome(o, args.verbose))
    n, nf = len(rep.outcomes), len(rep.failures)
    print(f"{dim}D: {n} constraints, {n - nf} hold, {nf} fail  ({rep.seconds:.1f} s)")
    if nf:
        print(f"{dim}D FAILED: " + ", ".join(o.id for o in rep.failures))
    print()


def report_main(argv: list[str] | None = None) -> int:
    """python -m proofs.report: write docs/error-bounds.md, or check it is current."""
    from proofs import report
    p = argparse.ArgumentParser(prog="python -m proofs.report", description=report.__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", default=REPORT_PATH, type=_REPORT_FILE,
                   help=f"file to write or check (default {REPORT_PATH}; '-': stdout)")
    p.add_argument("--check", action="store_true",
                   help="do not write; exit 1 when the file differs from a fresh render")
    a = p.parse_args(argv)
    if a.check:
        if not report.is_current(a.output):
            print(f"{a.output} is stale: regenerate with `python -m proofs.report`",
                  file=sys.stderr)
            return 1
        print(f"{a.output} is up to date")
        return 0
    report.write_report(a.output)
    if a.output != "-":
        print(f"wrote {a.output}")
    return 0


def _add_proofs_commands(sub) -> None:
    """verify and audit: their options above, their docstrings as descriptions."""
    for name, help_, add, run in (
            ("verify", "check every tolerance constraint for all eps <= 1e-5", _add_verify,
             _run_verify),
            ("audit", "shadow execution: measured error against derived bounds", _add_audit,
             _run_audit),
            ("synthesize", "the smallest tolerance coefficients the proofs accept",
             _add_synthesize, _run_synthesize)):
        p = sub.add_parser(name, help=help_, description=add.__doc__, formatter_class=_RAW)
        add(p)
        p.set_defaults(_run=run, _parser=p)

