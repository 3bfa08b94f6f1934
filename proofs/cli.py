"""The ``fperr`` command: the command-line module, on top of every layer.

Every option of every subcommand is declared here (one ``_add_<cmd>`` / ``_run_<cmd>``
pair per subcommand); the library modules contain no argument parsing, only plain
functions with typed keyword arguments. Each subcommand imports its library inside its
run function, so that ``fperr intersect --help`` loads neither sympy nor numpy.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

#: subcommands whose module still declares its own options: subcommand -> (module,
#: help). Each module defines add_arguments(parser) and run(args); it is imported only
#: when its subcommand is chosen.
COMMANDS = {
    "verify": ("proofs.verify", "check every tolerance constraint for all eps <= 1e-5"),
    "audit": ("proofs.audit", "shadow execution: measured error against derived bounds"),
}

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
            ".stl, .ply, ...). Second-order cells are used through their corner nodes; a\n"
            "tetrahedral CUT through its boundary triangles (both with a note). Prints the\n"
            "tolerances (in the input's units) and the number of pairs per kind.\n"
            "-o writes the intersection points (kind code with its legend as field data,\n"
            "vertex ids, barycentric weights) and --sim-output the simulation mesh with\n"
            "cell data 'cut', 'cut_kinds' and 'cut_by_KIND' (threshold it in ParaView),\n"
            "both .vtu; --plot draws a 2D case. Outputs are checked before the run\n"
            "and written atomically: a refused or failed run leaves no file.\n\n"
            "Exit status: 0 done, 2 bad arguments or unusable input (one line on stderr)."),
        epilog=("examples:\n"
                "  fperr intersect grid.msh circle.vtk -o hits.vtu --plot hits.png\n"
                "  fperr intersect cube.msh sphere.stl --sim-region 1 --sim-output cut.vtu\n"
                "  fperr intersect cube.vtu sphere.stl --dtype float32 --format json"))
    p.add_argument("sim", help="simulation mesh file (triangles in 2D, tetrahedra in 3D)")
    p.add_argument("cut", help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("-o", "--output", metavar="OUT.vtu",
                   help="write the intersection points (.vtu, for ParaView)")
    p.add_argument("--sim-output", metavar="CELLS.vtu",
                   help="write the simulation mesh with cut-cell data (.vtu)")
    p.add_argument("--plot", metavar="OUT.png", help="draw a 2D case (png, pdf or svg)")
    p.add_argument("--sim-region", metavar="TAG|NAME",
                   help="use only this gmsh physical group (tag or name) or cell block "
                        "(index) of SIM")
    p.add_argument("--cut-region", metavar="TAG|NAME", help="the same for CUT")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision (default float64)")
    p.add_argument("--naive", action="store_true",
                   help="zero tolerances: the naive floating-point baseline, for comparison")
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="summary on stdout: text (default) or json (counts per kind, "
                        "tolerances in input units, notes, timings)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(_run=_run_intersect)


def _run_intersect(args) -> int:
    from predicates.registration import intersect_files

    try:
        res = intersect_files(args.sim, args.cut, output=args.output, plot=args.plot,
                              sim_output=args.sim_output, dtype=args.dtype,
                              naive=args.naive, progress=not args.quiet,
                              sim_region=args.sim_region, cut_region=args.cut_region)
    except (ValueError, TypeError, OSError, ArithmeticError, MemoryError) as e:
        # bad input (meshes, paths): a message, never a traceback; nothing was written
        return _error("intersect", e)
    written = [(f, what) for f, what in ((args.output, f"{res.total} points"),
                                         (args.sim_output, f"{len(res.sim_cells)} cells, "
                                          f"{len(res.intersected_cells())} cut"),
                                         (args.plot, "plot")) if f]
    if args.format == "json":
        import json

        d = res.to_dict()
        d["inputs"] = {"sim": args.sim, "cut": args.cut}
        d["outputs"] = {f: what for f, what in written}
        print(json.dumps(d, indent=1))
        return 0
    print(res)
    for f, what in written:
        print(f"wrote {f} ({what})")
    return 0


# -- demo ------------------------------------------------------------------------------
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


# -- the command -----------------------------------------------------------------------
#: the subcommands declared here, in the order of "fperr --help"
_NATIVE = (_add_tables, _add_intersect, _add_demo)


def _plain(doc: str) -> str:
    """A module docstring as help text: Sphinx roles and literals as plain text."""
    import re

    doc = re.sub(r":\w+:`~?([^`]+)`", r"\1", doc)
    doc = doc.replace("``", "'")
    return re.sub(r"::$", ":", doc, flags=re.M)


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


def _chosen(argv: list[str]) -> str | None:
    """The subcommand named on the command line (the first word not an option)."""
    return next((a for a in argv if not a.startswith("-")), None)


def _add_legacy(sub, parser, name: str, modname: str, help_: str, chosen: str | None):
    """A subcommand of :data:`COMMANDS`: listed by name; its module is imported (and its
    options declared) only when it is the one chosen."""
    if name != chosen:
        sub.add_parser(name, help=help_)
        return
    try:
        mod = importlib.import_module(modname)
    except ModuleNotFoundError as e:
        if e.name != modname:
            raise
        parser.error(f"the {name} command is not available in this installation")
    p = sub.add_parser(name, help=help_, description=_plain(mod.__doc__ or ""),
                       formatter_class=_RAW)
    mod.add_arguments(p)
    p.set_defaults(_run=mod.run)


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser of ``fperr``; only the subcommand chosen in ``argv`` has its module
    imported."""
    parser = argparse.ArgumentParser(prog="fperr", description=_DESCRIPTION,
                                     formatter_class=_RAW)
    parser.add_argument("--version", action="version", version=f"fperr {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in _NATIVE:
        add(sub)
    chosen = _chosen(argv)
    for name, (modname, help_) in COMMANDS.items():
        _add_legacy(sub, parser, name, modname, help_, chosen)
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
