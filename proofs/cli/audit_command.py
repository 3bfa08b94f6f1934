"""``fperr audit``: the shadow-execution audit of the paper's predicates, or of the
predicates a user's module declares (options only; the work is :mod:`proofs.audit`,
imported when run; docs/custom-predicates.md for users' modules)."""
from __future__ import annotations

import argparse
import sys

from .common import _at_least_0, _at_least_1, output_as
from .common import user_systems as _user_systems


def _dims(text: str) -> tuple[int, ...]:
    """argparse type of --dims: comma-separated dimensions, each 2 or 3."""
    try:
        dims = tuple(int(d) for d in text.split(",") if d.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of 2 and 3")
    bad = [d for d in dims if d not in (2, 3)]
    if bad or not dims:
        raise argparse.ArgumentTypeError(f"dimension {bad[0] if bad else text!r} is not "
                                         "supported (choose from 2, 3)")
    return dims


def _formats(text: str) -> tuple[str, ...]:
    """argparse type of --formats: comma-separated working formats of the audit."""
    from proofs.audit import FORMATS
    formats = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise argparse.ArgumentTypeError(f"unknown format {bad[0] if bad else text!r} "
                                         f"(choose from {', '.join(FORMATS)})")
    return formats


#: audit --dtype names (the same as intersect's and demo's) -> the audit's formats
AUDIT_DTYPES = {"float64": "binary64", "float32": "binary32", "mp17": "mp17"}


def _add_audit(parser: argparse.ArgumentParser) -> None:
    """fperr audit: shadow execution, measured floating-point error against the derived
bounds, in binary64, binary32 and mpmath at 17 bits (see proofs.audit).

    fperr audit                                        # CI size, about 11 s of CPU
    fperr audit --thorough --format json -o audit.json # the worst-case hunt, <= 15 min
    fperr audit --samples 1500 --search-steps 150 --seed 7 --format json -o audit.json
    fperr audit --only edge_edge,vertex_vertex --dim 3 # some of the paper's predicates
    fperr audit --predicates mypkg.mypreds             # a module's own predicates
    fperr audit --predicates mypkg.mypreds --only seg_seg_cross -o report.json

--predicates MODULE imports MODULE (as fperr verify --predicates) and audits the
@predicate functions it declares in FPERR_TOLERANCES with the tolerance table and
sign filters declared there (proofs.audit.user, docs/custom-predicates.md) instead of
the paper's. --only NAME[,NAME] restricts the audit to those predicates (the paper's,
or the module's). The former form --predicates NAME[,NAME] still selects paper
predicates when every item is a paper predicate name (such a value is never read as
a module name; a list with any other item is refused).

Exit status: 0 no violation, 1 a violation was found (a measured error above its
derived bound, or a decision outside its brackets), 2 bad arguments or an unusable
module (one line on stderr, nothing written).
"""
    parser.add_argument("--samples", type=_at_least_1,
                        help="random/adversarial samples per predicate and format "
                             "(default 100, the CI size)")
    parser.add_argument("--search-steps", type=_at_least_0,
                        help="hill-climbing steps per seed (2 seeds per quantity and check; "
                             "default 10; 0 disables the search)")
    parser.add_argument("--format", choices=("md", "json"), default="md",
                        help="report format (default md)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--dtype", choices=tuple(AUDIT_DTYPES), action="append",
                        help="working precision to audit, repeatable (default all three: "
                             "float64, float32 and mp17, mpmath at 17 bits)")
    parser.add_argument("--dim", type=int, choices=(2, 3), action="append",
                        help="dimension to audit, repeatable (default both)")
    # the former names, still accepted and checked (not shown: one name per option)
    parser.add_argument("--formats", type=_formats, help=argparse.SUPPRESS)
    parser.add_argument("--dims", type=_dims, help=argparse.SUPPRESS)
    parser.add_argument("--predicates", metavar="MODULE", default="",
                        help="audit the predicates and tolerances MODULE declares in "
                             "FPERR_TOLERANCES instead of the paper's (a value whose "
                             "items are all paper predicate names: the former form of "
                             "--only)")
    parser.add_argument("--only", metavar="NAME[,NAME]", default="",
                        help="audit only these predicates (default all)")
    parser.add_argument("-o", "--output", metavar="FILE.md|FILE.json",
                        type=output_as(".md", ".json", what="the audit report"),
                        help="also write the report to this file, in the format its "
                             "extension says (.md Markdown, .json JSON; --format is "
                             "stdout's)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.add_argument("--thorough", action="store_true",
                        help="hunt the worst case of every quantity: a wall-clock budget "
                             "per quantity and format (--budget), at most about 15 "
                             "minutes for all")
    parser.add_argument("--budget", type=_positive_seconds,
                        help="seconds of wall clock per quantity and format of --thorough "
                             "(default 6)")


def _positive_seconds(text: str) -> float:
    """argparse type of audit --budget: a positive number of seconds."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds")
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"the budget must be a positive number of seconds, "
                                         f"got {text!r}")
    return v


def _names(text: str) -> tuple[str, ...]:
    return tuple(dict.fromkeys(p.strip() for p in text.split(",") if p.strip()))


def _selection(args) -> tuple[str | None, tuple[str, ...]]:
    """(MODULE or None, predicate names) from --predicates and --only (the grammar of
    the description: a value of paper predicate names only is the former --only)."""
    import predicates

    only = _names(args.only)
    if args.only and not only:
        args._parser.error("argument --only: no predicate name given")
    value = args.predicates.strip()
    if not value:
        return None, only
    items = _names(value)
    paper = {p.name for d in (2, 3) for p in predicates.ALL[d]}
    if items and all(i in paper for i in items):
        if only:
            args._parser.error("argument --predicates: paper predicate names are the former "
                               "form of --only; give the names once, with --only")
        return None, items
    if len(items) != 1 or "," in value:
        bad = next(i for i in items if i not in paper)
        args._parser.error(f"argument --predicates: {bad!r} is not a paper predicate "
                           f"(choose from {', '.join(sorted(paper))}); a module is one "
                           "dotted name, its predicates selected with --only")
    return value, only


def _run_audit(args: argparse.Namespace) -> int:
    from proofs.audit import CI_BUDGET, audit, select_predicates, thorough_budget
    if args.budget is not None and not args.thorough:
        args._parser.error("argument --budget: only with --thorough")
    module, names = _selection(args)
    args.dims = sorted(set(args.dim or args.dims or [2, 3]))
    args.formats = ([AUDIT_DTYPES[d] for d in dict.fromkeys(args.dtype)] if args.dtype else
                    args.formats or ["binary64", "binary32", "mp17"])

    def progress(spec, fmt):
        if not args.quiet:
            print(f"  audited {spec.key} in {fmt}", file=sys.stderr)

    sizes = {k: v for k, v in (("samples", args.samples), ("search_steps", args.search_steps))
             if v is not None}  # None: the library's default
    worst = thorough_budget(args.budget or 6.0) if args.thorough else CI_BUDGET
    if module is not None:
        return _run_module_audit(args, module, names, progress, worst, sizes)
    try:
        select_predicates(args.dims, names)  # bad names fail before any work
    except ValueError as e:
        args._parser.error(f"argument {'--only' if args.only else '--predicates'}: {e}")
    s = audit(dims=args.dims, formats=args.formats, names=names, seed=args.seed,
              progress=progress, worst_budget=worst, **sizes)
    return _emit(args, s)


def _run_module_audit(args, module, names, progress, worst, sizes) -> int:
    """The audit of MODULE's predicates (``--predicates MODULE``): unusable module,
    unknown --only name, failing instrumented run: status 2, nothing written."""
    from proofs.audit import audit_module, user_specs
    args.predicates, args.dim = module, (args.dim or args.dims)  # as fperr verify
    systems = _user_systems(args, "audit")
    if isinstance(systems, int):
        return systems
    decls = [systems[d] for d in sorted(systems)]
    try:
        specs = user_specs(decls, names)  # unknown names, failing runs: before any work
        s = audit_module(decls, names=names, formats=args.formats, seed=args.seed,
                         progress=progress, worst_budget=worst, specs=specs, **sizes)
    except (ValueError, ArithmeticError) as e:
        print(f"fperr audit: {module}: {e}", file=sys.stderr)
        return 2
    return _emit(args, s)


def _emit(args, s: dict) -> int:
    """Print the report (--format), write -o in the format its extension says; the
    exit status (1 when a violation was found)."""
    import json

    from proofs.audit import render_markdown

    def text(fmt):
        return json.dumps(s, indent=1) if fmt == "json" else render_markdown(s)

    print(text(args.format))
    if args.output:  # the format its extension says (checked when parsed)
        from predicates.registration.io.write import write_text_atomic
        write_text_atomic(args.output,
                          text("json" if args.output.lower().endswith(".json") else "md"))
    return 1 if s["violation_count"] else 0
