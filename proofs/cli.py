"""The ``fperr`` command: the command-line module, on top of every layer.

Every option of every subcommand is declared here (one ``_add_<cmd>`` / ``_run_<cmd>``
pair per subcommand); the library modules contain no argument parsing, only plain
functions with typed keyword arguments. Each subcommand imports its library inside its
run function, so that ``fperr intersect --help`` loads neither sympy nor numpy.
"""
from __future__ import annotations

import argparse
import os
import sys


_RAW = argparse.RawDescriptionHelpFormatter

_DESCRIPTION = ("Robust intersections under floating point (Wang, Jiang, Schroeder, Teran),\n"
                "with derived and verified error bounds. 'fperr COMMAND --help' shows the\n"
                "options of a command.")


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
    p.set_defaults(_run=_run_tables)


def _run_tables(args) -> int:
    from predicates.tables import records, render

    dims = (args.dim,) if args.dim else (2, 3)
    print(render(records(dims), args.format))
    return 0


# -- intersect -------------------------------------------------------------------------
def _add_intersect(sub) -> None:
    p = sub.add_parser(
        "intersect", help="register intersections of two mesh files", formatter_class=_RAW,
        description=(
            "Register the intersections of a simulation mesh with a cutting mesh.\n\n"
            "SIM: triangles (2D) or tetrahedra (3D); CUT: line segments (2D) or triangles\n"
            "(3D). Any format meshio reads (Gmsh .msh, .vtu/.vtk, Medit .mesh, .obj, .off,\n"
            ".stl, .ply, ...). Prints the tolerances and the number of pairs registered\n"
            "per kind; -o writes the intersection points (kind, vertex ids and barycentric\n"
            "weights as point data) for ParaView; --plot draws a 2D case with matplotlib,\n"
            "colour-coded by kind."),
        epilog=("examples:\n"
                "  fperr intersect grid.msh circle.vtk -o hits.vtu --plot hits.png\n"
                "  fperr intersect cube.vtu sphere.stl --dtype float32 --quiet\n\n"
                "exit status: 0 done (a coarse resolution is warned about on stderr),\n"
                "1 refused by --strict or the memory guard, 2 bad input or arguments"))
    p.add_argument("sim", help="simulation mesh file (triangles in 2D, tetrahedra in 3D)")
    p.add_argument("cut", help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("-o", "--output", metavar="OUT.vtu",
                   help="write the intersection points (any meshio format, e.g. .vtu)")
    p.add_argument("--plot", metavar="OUT.png", help="draw a 2D case (png, pdf or svg)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision (default float64)")
    p.add_argument("--naive", action="store_true",
                   help="zero tolerances: the naive floating-point baseline, for comparison")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--strict", action="store_true",
                   help="refuse (exit 1, nothing written) when the tolerances are coarse for "
                        "the elements near the cut, instead of warning on stderr")
    p.add_argument("--no-refine-cut", action="store_true",
                   help="use the cutting mesh as given (default: refine cutting cells "
                        "coarser than the simulation cells they meet)")
    p.add_argument("--workers", type=_at_least_1, metavar="N",
                   help="run in partitions on a local Dask cluster of N processes (same "
                        "result; needs pip install 'fperr[dask]')")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run in partitions on a running Dask cluster (e.g. tcp://host:8786)")
    p.add_argument("--tolerances", metavar="FILE",
                   help="tolerance table (TOML/JSON as for fperr verify --tolerances, e.g. "
                        "from fperr synthesize) instead of the paper's Figure 1/5")
    p.set_defaults(_run=_run_intersect)


def _dask_client(args):
    """--workers / --scheduler: a Dask Client (closed on exit), else no client."""
    import contextlib

    if args.workers is not None and args.scheduler is not None:
        raise ValueError("--workers starts a local cluster, --scheduler connects to a "
                         "running one: give one of them")
    if args.workers is None and args.scheduler is None:
        return contextlib.nullcontext()
    from predicates.registration.partition_run import client_for

    return client_for(args.workers, args.scheduler)


def _run_intersect(args) -> int:
    import warnings

    from fperr.warnings import ResolutionError, ResolutionWarning
    from predicates.registration import intersect_files

    table = None
    if args.tolerances:
        from proofs.tables import ToleranceFileError, load_overrides
        try:
            table = load_overrides(args.tolerances)
        except ToleranceFileError as e:
            return _error("intersect", e)
    try:
        dask_run = args.workers is not None or args.scheduler is not None
        with _dask_client(args) as client, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ResolutionWarning)
            res = intersect_files(args.sim, args.cut, output=args.output, plot=args.plot,
                                  dtype=args.dtype, naive=args.naive,
                                  progress=not args.quiet and not dask_run, strict=args.strict,
                                  refine_cut=not args.no_refine_cut,
                                  partitions="auto" if dask_run else None, scheduler=client,
                                  tolerances=table)
    except ResolutionError as e:  # valid input this precision cannot resolve: exit 1
        print(f"fperr intersect: error: {e}", file=sys.stderr)
        return 1
    except (ValueError, TypeError, OSError, ArithmeticError, ImportError) as e:
        # bad input (meshes, paths): a message, never a traceback; nothing was written
        return _error("intersect", e)
    for w in caught:  # one line each, no Python warning boilerplate
        print(f"fperr intersect: warning: {w.message}", file=sys.stderr)
    print(res)
    if args.output:
        print(f"wrote {args.output} ({res.total} points)")
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


# -- cut -------------------------------------------------------------------------------
def _add_cut(sub) -> None:
    p = sub.add_parser(
        "cut", help="split a mesh along a cutting mesh (virtual node algorithm)",
        formatter_class=_RAW,
        description=(
            "Cut a simulation mesh along a cutting mesh: the virtual-node split.\n\n"
            "SIM: triangles (2D) or tetrahedra (3D); CUT: line segments (2D) or triangles\n"
            "(3D), any format meshio reads. Registers the intersections robustly, then\n"
            "splits every cell into its material fragments and glues them into pieces\n"
            "(rules: docs/split.md). -o writes the split mesh with cell data piece,\n"
            "cell_origin, material (bitmask of material corners), material_count and point\n"
            "data node_origin (.vtu or .vtk: other formats drop cell data); --explode moves\n"
            "the pieces apart in the written mesh and the picture; --png draws them."),
        epilog=("examples:\n"
                "  fperr cut cube.vtu sphere.stl -o pieces.vtu --png pieces.png --explode 0.3\n"
                "  fperr cut square.msh polyline.vtk -o pieces.vtk"))
    p.add_argument("sim", help="simulation mesh file (triangles in 2D, tetrahedra in 3D)")
    p.add_argument("cut", help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("-o", "--output", metavar="PIECES.vtu",
                   help="write the split mesh with its cell data (.vtu or .vtk)")
    p.add_argument("--explode", type=float, default=0.0, metavar="FACTOR",
                   help="move each piece by FACTOR x (its centroid - the mesh centroid), "
                        "in -o and --png (default 0; --png alone uses 0.3)")
    p.add_argument("--png", metavar="FILE", help="draw the pieces (png, pdf or svg)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision of the registration (default float64)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(_run=_run_cut)


def _run_cut(args) -> int:
    from predicates.registration.split import cut_files

    try:
        res, sm = cut_files(args.sim, args.cut, output=args.output, png=args.png,
                            explode=args.explode, dtype=args.dtype, progress=not args.quiet)
    except (ValueError, TypeError, OSError, ArithmeticError) as e:
        return _error("cut", e)
    print(res)
    print(sm)
    if args.output:
        print(f"wrote {args.output} ({len(sm.cells)} cells, {sm.n_pieces} pieces)")
    if args.png:
        print(f"wrote {args.png}")
    return 0


# -- demo ------------------------------------------------------------------------------
def _at_least_1(text: str) -> int:
    n = _integer(text)
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {n}")
    return n


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def _at_least_2(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if n < 2:
        raise argparse.ArgumentTypeError(f"must be at least 2, got {n}")
    return n


def _add_demo(sub) -> None:
    p = sub.add_parser(
        "demo", help="run the built-in 2D and 3D examples", formatter_class=_RAW,
        description=(
            "Run the built-in examples (generated, no download):\n"
            "1. 2D: an NxN grid of squares (two triangles each) cut by a circle polygon;\n"
            "2. 3D: the unit cube as N/2 cubes per side, six tetrahedra each, cut by an\n"
            "   icosphere;\n"
            "3. degenerate cases (cuts on mesh edges, through vertices, on faces, also\n"
            "   rotated), the robust registration against the naive zero-tolerance\n"
            "   baseline, with their inconsistency counts.\n"
            "Prints the tables and writes demo_2d.png, demo_2d.vtu, demo_3d.vtu and the\n"
            "meshes (demo_2d_sim.vtu, demo_2d_cut.vtu, demo_3d_sim.vtu, demo_3d_cut.vtu)\n"
            "into --out."))
    p.add_argument("--out", default="fperr-demo", metavar="DIR",
                   help="output directory (default ./fperr-demo, created if missing)")
    p.add_argument("--n", type=_at_least_2, default=16, metavar="N",
                   help="grid resolution: NxN squares in 2D, N/2 cubes per side in 3D "
                        "(default 16, at least 2)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision (default float64)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(_run=_run_demo)


def _run_demo(args) -> int:
    from predicates.registration.demo import demo

    try:
        demo(args.out, n=args.n, dtype=args.dtype, progress=not args.quiet)
    except (ValueError, OSError) as e:  # e.g. --out names a file, or is not writable
        return _error("demo", e)
    return 0


# -- verify, audit, report (proofs/) ---------------------------------------------------------

#: where fperr verify --report and python -m proofs.report write, relative to
#: the current directory (never inside the installed package)
REPORT_PATH = "docs/error-bounds.md"


def _output_file(text: str) -> str:
    """argparse type of a file to write: its directory must exist ("-": stdout)."""
    from pathlib import Path
    path = Path(text)
    if text != "-" and path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory, not a file")
    if text != "-" and not path.resolve().parent.is_dir():
        raise argparse.ArgumentTypeError(
            f"directory {path.parent} does not exist (create it first)")
    return text


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


def _add_verify(parser: argparse.ArgumentParser) -> None:
    """fperr verify: every tolerance constraint of the paper, decided for all ε ≤ 1e-5.

Usage:

    fperr verify                  # 2D and 3D
    fperr verify --dim 3 -v       # with the derived errors and argument steps
    fperr verify --tolerances my.toml
    fperr verify --report         # also write docs/error-bounds.md (current directory)

--tolerances FILE (TOML or JSON, format: proofs.tables) replaces coefficients of
T−, T, T+. Exit status: 0 when every constraint holds, 1 when any fails, 2 for bad
arguments or an unusable tolerance file. See proofs.verify for the constraints.
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
    parser.add_argument("--report", metavar="PATH", nargs="?", const=REPORT_PATH,
                        type=_output_file,
                        help=f"also write the generated report (default: {REPORT_PATH} "
                             "in the current directory)")
    parser.add_argument("--certificate", metavar="FILE", type=_output_file,
                        help="also write a certificate of every decision, checkable with "
                             "python -m proofs.check_certificate FILE")


def _run_verify(args: argparse.Namespace) -> int:
    if args.report is not None:
        try:
            _output_file(args.report)  # the default (const) is not checked by argparse
        except argparse.ArgumentTypeError as e:
            args._parser.error(f"argument --report: {e}")
    from proofs import tables
    from proofs.verify import format_outcome, verify
    try:
        overrides = tables.load_overrides(args.tolerances) if args.tolerances else None
    except tables.ToleranceFileError as e:
        print(f"fperr verify: {e}", file=sys.stderr)
        return 2
    ok, reports = True, {}
    for dim in sorted(set(args.dim or [2, 3])):
        try:
            rep = verify(dim, overrides, require_paper_argument=args.require_paper_argument)
        except (ValueError, TypeError) as e:
            print(f"fperr verify: {dim}D: {e}", file=sys.stderr)
            return 2
        reports[dim] = rep
        src = "paper's Figure 1" if dim == 2 else "paper's Figure 5"
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
        ok = ok and rep.ok
    if args.certificate:
        from proofs import certificate
        try:
            certificate.write(args.certificate, reports, args.require_paper_argument)
        except OSError as e:
            print(f"fperr verify: cannot write certificate: {e}", file=sys.stderr)
            return 2
        print(f"certificate written to {args.certificate}")
    if args.report is not None:
        from proofs.report import write_report
        write_report(args.report)
        print(f"report written to {args.report}")
    return 0 if ok else 1


def _add_audit(parser: argparse.ArgumentParser) -> None:
    """fperr audit: shadow execution, measured floating-point error against the derived
bounds, in binary64, binary32 and mpmath at 17 bits (see proofs.audit).

    fperr audit                                        # CI size, about 25 s of CPU
    fperr audit --samples 1500 --search-steps 150 --seed 7 --format json -o audit.json

Exit status 1 when any violation was found, 2 for bad arguments.
"""
    parser.add_argument("--samples", type=int,
                        help="random/adversarial samples per predicate and format "
                             "(default 100, the CI size)")
    parser.add_argument("--search-steps", type=int,
                        help="hill-climbing steps per seed (2 seeds per quantity and check; "
                             "default 10; 0 disables the search)")
    parser.add_argument("--format", choices=("md", "json"), default="md",
                        help="report format (default md)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--formats", type=_formats, default="binary64,binary32,mp17",
                        help="comma-separated working formats (default all three)")
    parser.add_argument("--dims", type=_dims, default="2,3",
                        help="dimensions to audit (default 2,3)")
    parser.add_argument("--predicates", default="",
                        help="comma-separated predicate names to audit (default all)")
    parser.add_argument("-o", "--output", type=_output_file,
                        help="also write the report to this file")


def _run_audit(args: argparse.Namespace) -> int:
    import json

    from proofs.audit import audit, render_markdown, select_predicates
    names = tuple(p.strip() for p in args.predicates.split(",") if p.strip())
    try:
        select_predicates(args.dims, names)  # bad names fail before any work
    except ValueError as e:
        args._parser.error(f"argument --predicates: {e}")

    def progress(spec, fmt):
        print(f"  audited {spec.key} in {fmt}", file=sys.stderr)

    sizes = {k: v for k, v in (("samples", args.samples), ("search_steps", args.search_steps))
             if v is not None}  # None: the library's default
    s = audit(dims=args.dims, formats=args.formats, names=names, seed=args.seed,
              progress=progress, **sizes)
    text = json.dumps(s, indent=1) if args.format == "json" else render_markdown(s)
    print(text)
    if args.output:
        with open(args.output, "w") as fh:
            fh.write(text)
    return 1 if s["violation_count"] else 0


def _add_synthesize(parser: argparse.ArgumentParser) -> None:
    """fperr synthesize: the smallest tolerance coefficients the proofs accept.

    fperr synthesize --dim 2 -o synth_2d.toml
    fperr synthesize --dim 3 --check proofs/tables/synth_3d.toml

Every coefficient of T−, T, T+ is bisected (to within 1 %) against the decision
procedure of fperr verify, bottom-up along the declared facts (proofs.synthesize);
the table written is accepted by fperr verify --tolerances. Prints, per tolerance,
the paper's and the synthesized coefficients and their ratios. --check FILE: exit 1
when FILE differs from a fresh synthesis (stale). Exit status 2 for bad arguments.
"""
    parser.add_argument("--dim", type=int, choices=(2, 3), action="append",
                        help="dimension (default: both)")
    parser.add_argument("-o", "--output", metavar="FILE", type=_output_file,
                        help="write the table (TOML) for fperr verify --tolerances")
    parser.add_argument("--check", metavar="FILE",
                        help="exit 1 when FILE is not what a fresh synthesis writes")


def _run_synthesize(args: argparse.Namespace) -> int:
    from pathlib import Path

    from proofs.synthesize import ratio_table, synthesize, to_toml, write
    results = []
    for dim in sorted(set(args.dim or [2, 3])):
        r = synthesize(dim, progress=lambda n, f, v: print(f"  {dim}D {n}.{f} = {v}",
                                                           file=sys.stderr))
        print(ratio_table(r))
        print(f"{dim}D: {r.probes} probes, {r.seconds:.1f} s; T+ set by a fact equality: "
              f"{', '.join(r.equalities) or 'none'}; all {len(r.report.outcomes)} "
              "constraints hold")
        results.append(r)
    if args.output:
        write(args.output, results)
        print(f"wrote {args.output}")
    if args.check:
        from proofs.synthesize import table_section
        try:
            old = Path(args.check).read_text()
        except OSError as e:
            return _error("synthesize", e)
        if table_section(old) != table_section(to_toml(results)):
            print(f"{args.check} is stale: regenerate with fperr synthesize "
                  f"--dim {','.join(str(r.dim) for r in results)} -o {args.check}",
                  file=sys.stderr)
            return 1
        print(f"{args.check} is up to date")
    return 0


def report_main(argv: list[str] | None = None) -> int:
    """python -m proofs.report: write docs/error-bounds.md, or check it is current."""
    from proofs import report
    p = argparse.ArgumentParser(prog="python -m proofs.report", description=report.__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", default=REPORT_PATH, type=_output_file,
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


# -- the command -----------------------------------------------------------------------
#: the subcommands declared here, in the order of "fperr --help"
_NATIVE = (_add_tables, _add_intersect, _add_cut, _add_demo, _add_proofs_commands)


def _error(command: str, e: Exception) -> int:
    print(f"fperr {command}: error: {e}", file=sys.stderr)
    return 2


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fperr")
    except PackageNotFoundError:  # run from a source tree that is not installed
        import fperr

        return fperr.__version__


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser of ``fperr`` (no library is imported: each run function imports its own)."""
    parser = argparse.ArgumentParser(prog="fperr", description=_DESCRIPTION,
                                     formatter_class=_RAW)
    parser.add_argument("--version", action="version", version=f"fperr {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in _NATIVE:
        add(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``fperr`` with the arguments ``argv`` (default: the command line); returns
    the exit status. Bad arguments exit with status 2 (argparse's SystemExit)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser(argv).parse_args(argv)
    try:
        status = int(args._run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows up here, not at interpreter exit
    except BrokenPipeError:
        # the reader went away (fperr tables | head -1): stop quietly, as Unix tools do;
        # Python would otherwise report the failed flush of stdout again at exit
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the shell's status for a tool killed by the pipe
    return status


if __name__ == "__main__":
    sys.exit(main())
