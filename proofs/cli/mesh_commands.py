"""``fperr intersect``, ``fperr cut``, ``fperr demo``: the registration's commands
(options only; the work is :mod:`predicates.registration`, imported when run)."""
from __future__ import annotations

import sys

from .common import RAW as _RAW
from .common import _at_least_1, _at_least_2, _partitions, _seconds, error as _error


def _precision_and_quiet(p) -> None:
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision (default float64)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _registration_options(p) -> None:
    """The inputs and options of a registration, one group shared by ``fperr intersect``
    and ``fperr cut`` (the same run feeds both: :func:`_register`)."""
    p.add_argument("sim", nargs="+", metavar="SIM",
                   help="simulation mesh file (triangles in 2D, tetrahedra in 3D), or "
                        "several: the pieces of one mesh, merged where they share points")
    p.add_argument("cut", metavar="CUT",
                   help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("--sim-region", metavar="TAG|NAME",
                   help="use only this gmsh physical group (tag or name) or cell block "
                        "(index) of SIM")
    p.add_argument("--cut-region", metavar="TAG|NAME", help="the same for CUT")
    _precision_and_quiet(p)
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="summary on stdout: text (default) or json (counts per kind, "
                        "tolerances in input units, notes, timings)")
    p.add_argument("--strict", action="store_true",
                   help="refuse (exit 1, nothing written) when the tolerances are coarse for "
                        "the elements near the cut, instead of warning on stderr")
    p.add_argument("--no-refine-cut", action="store_true",
                   help="use the cutting mesh as given (default: refine cutting cells "
                        "coarser than the simulation cells they meet)")
    p.add_argument("--tolerances", metavar="FILE",
                   help="tolerance table (TOML/JSON as for fperr verify --tolerances, e.g. "
                        "from fperr synthesize) instead of the paper's Figure 1/5")
    p.add_argument("--workers", type=_at_least_1, metavar="N",
                   help="run in partitions on a local Dask cluster of N processes (same "
                        "result; at most %d per CPU of this machine; needs pip install "
                        "'fperr[dask]')" % WORKERS_PER_CPU)
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run in partitions on a running Dask cluster (e.g. tcp://host:8786)")
    p.add_argument("--partitions", type=_partitions, metavar="K",
                   help="with --workers/--scheduler: the number of spatial partitions (tasks), "
                        "or 'auto' (default: one per worker thread, at least one per million "
                        "cells); more partitions hold less memory each")
    p.add_argument("--timeout", type=_seconds, metavar="SECONDS",
                   help="with --workers/--scheduler: cancel the partitions' tasks (and the "
                        "split on the workers) and exit 1 (nothing written) when they have "
                        "not all finished this many seconds after submission (default: "
                        "wait)")


#: local worker processes allowed per CPU: more only compete for the CPUs (each takes
#: memory and about a second to start), and a typo like --workers 100000 would hang
#: starting them
WORKERS_PER_CPU = 4


def _cpus() -> int:
    """The CPUs this process may run on (its affinity, else the machine's count)."""
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _check_workers(args) -> None:
    """--workers within the machine (and within --partitions K), before any work."""
    n = args.workers
    if n is None:
        return
    cpus = _cpus()
    if n > WORKERS_PER_CPU * cpus:
        raise ValueError(f"--workers {n}: this machine has {cpus} CPU{'s' * (cpus != 1)}, "
                         f"and more than {WORKERS_PER_CPU} local worker processes per CPU "
                         f"only compete for them: give at most {WORKERS_PER_CPU * cpus}, or "
                         f"--scheduler ADDRESS to run on a cluster")
    if isinstance(args.partitions, int) and n > args.partitions:
        raise ValueError(f"--workers {n} with --partitions {args.partitions}: only "
                         f"{args.partitions} of the workers would have a partition to run: "
                         f"give at most --workers {args.partitions}, or more partitions")


def _register(args, work, check):
    """Run ``work(**options)`` (the registration with the shared options of
    :func:`_registration_options`) and map what goes wrong to the exit status: a refused
    or unfinished run (``--strict``, the memory guard, lost workers, ``--timeout``) is 1,
    bad input or arguments 2, each one line on stderr; resolution warnings are printed
    as one line each. ``check()``: the command's own checks that need no work (its
    outputs), run with the workers' check before a cluster is started or a file read.
    Returns (None, work's result) or (status, None)."""
    import warnings

    from fperr.warnings import ResolutionError, ResolutionWarning
    from predicates.registration.partition.run import PartitionError
    from predicates.registration.plan.inputs import MeshTypeError

    cmd = args.command
    table = None
    if args.tolerances:
        from proofs.tables import ToleranceFileError, load_overrides
        try:
            table = load_overrides(args.tolerances)
        except ToleranceFileError as e:
            return _error(cmd, e), None
    dask_run = args.workers is not None or args.scheduler is not None
    options = dict(dtype=args.dtype, progress=not args.quiet, strict=args.strict,
                   refine_cut=not args.no_refine_cut, sim_region=args.sim_region,
                   cut_region=args.cut_region, tolerances=table, timeout=args.timeout,
                   partitions=(args.partitions or "auto") if dask_run else None)
    try:
        _check_workers(args)
        check()
        with _dask_client(args) as client, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ResolutionWarning)
            out = work(**options, scheduler=client)
    except (ResolutionError, PartitionError, MemoryError) as e:
        # valid input this precision cannot resolve, a partitioned run's tasks that did
        # not finish (a worker died, the timeout), or this machine's memory: exit 1,
        # nothing written
        why = _out_of_memory(e) if isinstance(e, MemoryError) else e
        print(f"fperr {cmd}: error: {why}", file=sys.stderr)
        return 1, None
    except (ValueError, MeshTypeError, OSError, ImportError) as e:
        # bad input (meshes, paths): a message, never a traceback; nothing was written.
        # Any other TypeError or an ArithmeticError is a bug (main: internal error).
        return _error(cmd, e), None
    for w in caught:  # one line each, no Python warning boilerplate
        print(f"fperr {cmd}: warning: {w.message}", file=sys.stderr)
    return None, out



def _out_of_memory(e: MemoryError) -> str:
    """The message of a run that ran out of memory: the plan's and the registration's
    name their stage and the meshes' size (``PlanMemoryError``,
    ``RegistrationMemoryError``); any other says what to try."""
    from predicates.registration.pipeline import PlanMemoryError, RegistrationMemoryError

    if isinstance(e, (PlanMemoryError, RegistrationMemoryError)):
        return str(e)
    return (f"not enough memory for this run ({type(e).__name__}: {str(e) or 'no detail'}); "
            f"nothing was written: free memory, use a machine with more, or partition "
            f"the run (--workers N --partitions K, each partition then holds less: "
            f"docs/partitioned.md)")

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
            "Exit status: 0 done, 1 refused or unfinished (below), 2 bad arguments or\n"
            "unusable input (one line on stderr)."),
        epilog=("examples:\n"
                "  fperr intersect grid.msh circle.vtk -o hits.vtu --plot hits.png\n"
                "  fperr intersect cube.msh sphere.stl --sim-region 1 --sim-output cut.vtu\n"
                "  fperr intersect cube.vtu sphere.stl --dtype float32 --format json\n"
                "  fperr intersect cube.vtu sphere.stl --workers 4 -o 'hits_{part}.vtu'\n"
                "  fperr intersect piece0.vtu piece1.vtu piece2.vtu sphere.stl --workers 3\n\n"
                "exit status: 0 done (a coarse resolution is warned about on stderr),\n"
                "1 refused by --strict or the memory guard, or a partitioned run whose\n"
                "tasks did not finish (a worker lost, --timeout), 2 bad input or arguments"))
    _registration_options(p)
    p.add_argument("-o", "--output", metavar="OUT.vtu",
                   help="write the intersection points (.vtu, for ParaView); with "
                        "--workers/--scheduler a name with {part} (hits_{part}.vtu) writes "
                        "one file per partition, each pair in the file of the partition "
                        "that owns it")
    p.add_argument("--sim-output", metavar="CELLS.vtu",
                   help="write the simulation mesh with cut-cell data (.vtu): 'cut' marks "
                        "every cell the cut meets (a registered pair on one of its "
                        "vertices, edges, faces or inside)")
    p.add_argument("--plot", metavar="OUT.png", help="draw a 2D case (png, pdf or svg)")
    p.add_argument("--naive", action="store_true",
                   help="zero tolerances: the naive floating-point baseline, for comparison")
    p.set_defaults(_run=_run_intersect)


def _dask_client(args):
    """--workers / --scheduler: a Dask Client (closed on exit), else no client."""
    import contextlib

    if args.workers is not None and args.scheduler is not None:
        raise ValueError("--workers starts a local cluster, --scheduler connects to a "
                         "running one: give one of them")
    if args.workers is None and args.scheduler is None:
        for flag, value in (("--timeout", args.timeout), ("--partitions", args.partitions)):
            if value is not None:
                raise ValueError(f"{flag} is for a partitioned run: give --workers or "
                                 f"--scheduler")
        return contextlib.nullcontext()
    from predicates.registration.partition.run import client_for

    return client_for(args.workers, args.scheduler)


def _run_intersect(args) -> int:
    from predicates.registration import intersect_files

    sim = args.sim[0] if len(args.sim) == 1 else args.sim  # one file, or the pieces
    per_part = args.output is not None and "{part}" in args.output
    outputs = {"output": args.output, "plot": args.plot, "sim_output": args.sim_output}

    def check():
        from predicates.registration.io.files import check_outputs, input_roles

        if per_part:  # one file per partition: checked now, written after the run
            _check_parts(args, args.workers is not None or args.scheduler is not None)
        else:
            check_outputs(input_roles(sim, args.cut),
                          {("-o", "mesh"): args.output, ("--plot", "plot"): args.plot,
                           ("--sim-output", "mesh"): args.sim_output})

    def work(**options):
        if per_part:  # each partition's file written by its task, on the workers
            from predicates.registration.partition.intersect_parts import intersect_files_parts

            res = intersect_files_parts(sim, args.cut, args.output, plot=args.plot,
                                        sim_output=args.sim_output, naive=args.naive,
                                        **options)
        else:
            res = intersect_files(sim, args.cut, **outputs, naive=args.naive, **options)
        # the summary's cut cells, counted while the cluster is open: cells read by its
        # workers (pieces with global ids) stay there
        res.intersected_cells()
        return res, (res.timings["partition_count"] if per_part else None)

    status, out = _register(args, work, check)
    if status is not None:
        return status
    res, n_parts = out
    points = f"{res.total} points" + (f" in {n_parts} files" if per_part else "")
    cells = f"{len(res.sim_cells)} cells, {len(res.intersected_cells())} meet the cut"
    written = [(f, what) for f, what in ((args.output, points),
                                         (args.sim_output, cells),
                                         (args.plot, "plot")) if f]
    return _summary(args, res, written)


def _summary(args, res, written: list, split=None) -> int:
    """Print the run's summary on stdout (text, or one JSON document) and the files
    written; ``split``: ``fperr cut``'s split mesh."""
    sim = args.sim[0] if len(args.sim) == 1 else args.sim
    if args.format == "json":
        import json

        d = res.to_dict()
        if split is not None:
            d["split"] = split.summary()
        d["inputs"] = {"sim": sim, "cut": args.cut}
        d["outputs"] = {f: what for f, what in written}
        print(json.dumps(d, indent=1))
        return 0
    print(res)
    print("candidate chain: " + ("compiled (numba)" if res.timings.get("accelerated")
                                 else "numpy"))
    if split is not None:
        print(split)
    for f, what in written:
        print(f"wrote {f} ({what})")
    return 0


def _check_parts(args, dask_run: bool) -> None:
    """-o with {part} (one file per partition): a partitioned run, a valid pattern,
    checked with the other outputs before any work."""
    from predicates.registration.io.files import check_outputs, input_roles
    from predicates.registration.partition.files import part_paths

    if not dask_run:
        raise ValueError(f"{args.output}: '{{part}}' writes one file per partition of a "
                         f"partitioned run: give --workers or --scheduler")
    first = part_paths(args.output, 1)[0]  # the name's form and directory, now
    check_outputs(input_roles(args.sim, args.cut),
                  {("-o", "mesh"): first, ("--plot", "plot"): args.plot,
                   ("--sim-output", "mesh"): args.sim_output})


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
            "cell_origin, material (bitmask of material corners), material_count, volume,\n"
            "volume_fraction, centroid, unclaimed_fraction and point data node_origin\n"
            "(.vtu: other formats drop cell or field data); --surface writes the cut\n"
            "surface's polygons; --explode moves the pieces apart in the written mesh and\n"
            "the picture; --png (--plot) draws them with the cut surface.\n"
            "The inputs and the registration's options are fperr intersect's (the same\n"
            "run); 'split' counts the cells cut into several fragments, fewer than the\n"
            "cells the cut meets (fperr intersect's 'cut': a cell touched at a vertex or\n"
            "crossed on one edge only stays whole).\n\n"
            "Exit status: 0 done, 1 refused (--strict, the memory guard) or unfinished\n"
            "(a partitioned run), 2 bad arguments or unusable input (one line on stderr)."),
        epilog=("examples:\n"
                "  fperr cut cube.vtu sphere.stl -o pieces.vtu --png pieces.png --explode 0.3\n"
                "  fperr cut square.msh polyline.vtk -o pieces.vtu\n"
                "  fperr cut cube.vtu plane_x.stl --then plane_z.stl -o quarters.vtu"))
    _registration_options(p)
    p.add_argument("-o", "--output", metavar="PIECES.vtu",
                   help="write the split mesh with its cell data (.vtu)")
    p.add_argument("--explode", type=float, default=0.0, metavar="FACTOR",
                   help="move each piece by FACTOR x (its centroid - the mesh centroid), "
                        "in -o and --png (default 0; --png alone uses 0.3)")
    p.add_argument("--png", "--plot", metavar="FILE", dest="png",
                   help="draw the pieces and the cut surface (png, pdf or svg)")
    p.add_argument("--no-volumes", action="store_true",
                   help="leave the fragments' volumes out of -o (they cost a Python pass "
                        "over the cells the cut crosses)")
    p.add_argument("--surface", metavar="SURFACE.vtu",
                   help="write the cut surface: per cell and cutting cell the polygon of "
                        "the cut inside it (2D: segment), cell data cell, cut_cell, "
                        "input_cut_cell (.vtu)")
    p.add_argument("--conforming", action="store_true",
                   help="write each piece as tetrahedra (2D: triangles) conforming to the "
                        "cut, cell data piece, cell_origin, fragment, side (docs/split.md); "
                        "exit 1 if some cell cannot be filled")
    p.add_argument("--then", action="append", default=[], metavar="CUT",
                   help="cut the conforming mesh again with this cutting mesh (repeat for "
                        "more, in order; implies --conforming; registered serially). "
                        "Crossing sheets, which one cut cannot split, cut one at a time")
    p.set_defaults(_run=_run_cut)


def _run_cut(args) -> int:
    from predicates.registration.split.files import check_cut_outputs, cut_files

    sim = args.sim[0] if len(args.sim) == 1 else args.sim
    outputs = dict(output=args.output, png=args.png, explode=args.explode,
                   surface=args.surface, volumes=not args.no_volumes)

    def work(**options):
        return cut_files(sim, args.cut, **outputs, conforming=args.conforming,
                         then=args.then, **options)

    checked = {k: v for k, v in outputs.items() if k != "volumes"}
    checked["then"] = args.then
    status, out = _register(args, work, lambda: check_cut_outputs(sim, args.cut, **checked))
    if status is not None:
        return status
    import numpy as np

    res, sm, cs, fv, cm = out
    s = sm.summary()
    vols = ""
    if fv is not None:
        vols = ("; piece volumes " + ", ".join(f"{v:.6g}" for v in fv.piece_volume)
                + (f"; {len(fv.claim_report())} cells with material no fragment owns "
                   f"(unclaimed {np.nansum(fv.unclaimed):.3g})" if len(fv.claim_report()) else ""))
    what = (f"{s['cells']} cells; {s['split_cells']} of the "
            f"{len(res.intersected_cells())} cells the cut meets split into "
            f"several fragments; {sm.n_pieces} pieces{vols}")
    if cm is not None:
        c = cm.summary()
        what = (f"conforming: {c['simplices']} simplices, {c['points']} points "
                f"({c['interior_points']} interior), {c['cut_faces']} cut faces, "
                f"{cm.n_pieces} pieces"
                + (f" after {len(args.then) + 1} cuts" if args.then else ""))
    written = [(f, what) for f, what in (
        (args.output, what),
        (args.surface, f"{len(cs) if cs is not None else 0} cut polygons"),
        (args.png, "plot")) if f]
    return _summary(args, res, written, split=sm)


# -- demo ------------------------------------------------------------------------------


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
            "Prints the tables and writes into --out the pictures demo_2d.png,\n"
            "demo_degenerate_2d.png (robust beside naive), demo_3d.png (cut tetrahedra),\n"
            "demo_split_3d.png (the virtual-node split of a cube by a sphere and by a\n"
            "plane through grid vertices), the results demo_2d.vtu, demo_3d.vtu and the\n"
            "meshes (demo_2d_sim.vtu, demo_2d_cut.vtu, demo_3d_sim.vtu, demo_3d_cut.vtu)."))
    p.add_argument("--out", default="fperr-demo", metavar="DIR",
                   help="output directory (default ./fperr-demo, created if missing)")
    p.add_argument("--n", type=_at_least_2, default=16, metavar="N",
                   help="grid resolution: NxN squares in 2D, N/2 cubes per side in 3D "
                        "(default 16, at least 2)")
    _precision_and_quiet(p)
    p.set_defaults(_run=_run_demo)


def _run_demo(args) -> int:
    from predicates.registration.pictures.demo import demo

    try:
        demo(args.out, n=args.n, dtype=args.dtype, progress=not args.quiet)
    except (ValueError, OSError) as e:  # e.g. --out names a file, or is not writable
        return _error("demo", e)
    return 0

