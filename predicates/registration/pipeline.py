"""Hierarchical registration of a simulation mesh against a cutting mesh (section 1,
sections 4.1 and 5.1 of the paper).

``intersect(sim_points, sim_cells, cut_points, cut_cells)`` (or two ``meshio.Mesh``, or
two ``(points, cells)`` tuples) registers intersection pairs level by level, from the
most degenerate up, in the paper's order. Kind names read "simulation primitive _
cutting primitive":

* 2D (triangles vs segments): vertex_vertex; vertex_edge, edge_vertex; edge_edge,
  triangle_vertex.
* 3D (tetrahedra vs triangles): vertex_vertex; vertex_edge, edge_vertex; edge_edge,
  vertex_triangle, triangle_vertex; edge_triangle, triangle_edge, tetrahedron_vertex.

A pair is skipped ("degenerate intersection", line 2 of every algorithm) when any pair
of its sub-simplices — faces of either primitive, the primitive itself included, the
pair itself excluded — was registered at a lower level; registered pairs are kept per
kind as sorted int64 keys, so that look-up is a vectorised ``searchsorted``.

How it runs
-----------
1. Validation (:mod:`predicates.registration.plan.inputs`): every bad input is rejected up front.
2. Exact power-of-two scaling: coordinates are multiplied by 2^-e so that
   L_a + L_b ∈ [1/2, 1). Every tolerance and every quantity of the predicates (up to
   L⁶ in 3D edge-edge) is then of order one: no overflow, and nothing that matters can
   underflow. Scaling by a power of two is exact, so the registered pairs are exactly
   those of the unscaled input whenever the unscaled run itself neither overflows nor
   underflows — and the scaled run gives them also when it would. Coordinates are never
   *shifted* (translation is inexact): the predicates only use coordinate differences,
   which rule E makes exact to within one rounding whatever the offset, and the rule K
   bound |coord| ≤ L/2 is only used through |x₁ − x₂| ≤ L, true for any pair processed.
   A large common offset (e.g. coordinates near 10⁶ with cells of 10⁻³) is therefore
   handled; an input whose coordinates cannot be scaled exactly (a coordinate would
   become subnormal and lose bits, or overflow) is refused with a clear error.
3. Primitives: unique vertices, edges, faces (and cells) of each mesh — of the cells
   the first broad-phase stage keeps (step 5; :mod:`predicates.registration.levels.complex`). Inside every primitive the vertices are
   ordered lexicographically by coordinates, so that the predicates see the same
   numbers in the same order whatever the vertex numbering, the cell order or the
   orientation: the result is invariant under all three.
4. Tolerances (Algorithms 1 and 6) from L_a, L_b, the largest bounding-box edge of any
   cell of each mesh, rounded up (they must be upper bounds).
5. Broad phase (:mod:`predicates.registration.spatial.broadphase`): the cells of each mesh sharing a grid
   cell with a cell of the other mesh enlarged by σ+ (a superset of those within σ+),
   then per kind the primitives' boxes within that kind's reach (≤ σ+; see
   ``predicates.catalogue``), tested exactly.
6. Per level, per kind (:mod:`predicates.registration.levels.loop`): suppression by registered sub-pairs, then the predicate in
   numpy batch mode on chunks of candidates.

With ``partitions=`` / ``scheduler=``, steps 3, 5 and 6 run per spatial partition as Dask
tasks (:mod:`predicates.registration.partition.run`; the rest stays global, in
``_plan``), with the identical result (docs/partitioned.md).

``tolerance_scale=0`` runs the same pipeline with every tolerance zero (the naive
floating-point baseline); the broad phase keeps its robust reach, so the baseline only
differs in the predicates.
"""
from __future__ import annotations

import contextlib
import dataclasses
import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from fperr.warnings import ResolutionError, ResolutionWarning

from predicates import compiled
from predicates.catalogue import kinds as catalogue_kinds
from predicates.registration.plan import first_round, resolution, threads as plan_threads
from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.plan.inputs import (
    check_extent, hull_of, mesh_arrays, scale_points, validate_options,
    validate_pair)
from predicates.registration.levels.loop import (
    MemoryGuard, Registration, RegistrationMemoryError)
from predicates.registration.partition import remote, run_arrays  # no Dask
from predicates.registration.plan.refine import refine
from predicates.registration.plan.resolution import (
    Resolution, consistent_scale, estimate_cell_pairs, memory_error, near_cells,
    shortest_edge, t_plus)
from predicates.registration.result.intersection import IntersectionResult
from predicates.registration.spatial.blocks import Blocks

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, DTypeLike

__all__ = ["CHUNK", "MeshLike", "PLAN_STAGES", "PlanMemoryError",
           "RegistrationMemoryError", "intersect", "intersect_files"]

#: Pairs per predicate batch (bounds the gathered coordinates and temporaries).
CHUNK = 1 << 17
#: the plan's stages in ``res.timings`` (wall seconds, inside "setup"); "refine" only
#: when the cutting mesh is refined
PLAN_STAGES = ("plan_validate", "plan_boxes", "refine", "plan_scale", "plan_report")


#: what a mesh argument of :func:`intersect` may be
MeshLike = "tuple[ArrayLike, ArrayLike] | meshio.Mesh | pyvista.DataSet | trimesh.Trimesh"


def intersect(sim: MeshLike | ArrayLike, cut: MeshLike | ArrayLike,
              cut_points: ArrayLike | None = None, cut_cells: ArrayLike | None = None,
              /, *, dtype: DTypeLike = np.float64, tolerance_scale: float = 1.0,
              refine_cut: bool = True, strict: bool = False,
              tolerances: str | os.PathLike | dict | None = None,
              sim_region: int | str | None = None, cut_region: int | str | None = None,
              progress: bool = False, chunk: int = CHUNK, memory_limit: int | None = None,
              partitions: int | str | None = None, scheduler: str | object | None = None,
              timeout: float | None = None, accelerate: bool | None = None
              ) -> IntersectionResult:
    """Register the intersections of a simulation mesh with a cutting mesh.

    ``intersect(sim_mesh, cut_mesh)``: each a ``(points, cells)`` pair, a ``meshio.Mesh``,
    a pyvista grid or a trimesh (``sim_region``/``cut_region``: a gmsh physical group or
    cell block, by tag or name); or the four arrays ``intersect(sim_points, sim_cells,
    cut_points, cut_cells)`` (then ``sim`` and ``cut`` are the simulation mesh's points
    and cells). 2D: triangles (M, 3) vs segments (K, 2), points (N, 2); 3D:
    tetrahedra (M, 4) vs triangles (K, 3), points (N, 3). An empty cutting mesh gives an
    empty result.

    ``dtype``: float64 or float32, the working precision (coordinates are converted;
    ``res.rounded_inputs`` says whether that rounded them). ``tolerance_scale``: 1 for the
    robust method, 0 for the naive zero-tolerance baseline (values in [0, 1]).
    ``progress``: a tqdm bar on stderr (shown after one second; of the kinds, or of the
    partitions in a partitioned run). ``refine_cut``: refine cutting cells coarser than
    the simulation cells they meet (conforming midpoint
    splits, :mod:`~predicates.registration.plan.refine`); the registered cutting ids then
    refer to ``res.cut_points`` / ``res.cut_cells``, the refined mesh (input points keep
    their ids; ``res.refinement`` maps back). ``strict``: raise
    :class:`fperr.ResolutionError` (a ValueError) instead of issuing a
    :class:`fperr.ResolutionWarning` when the tolerances are coarse relative to the
    elements near the cut (``res.resolution``). ``memory_limit``: bytes (default half
    the available memory); a run estimated to need more is refused with
    :class:`fperr.ResolutionError`. ``partitions`` (an int or "auto") / ``scheduler``
    ("threads", "processes", "synchronous", a ``dask.distributed.Client`` or an
    address): run on Dask in spatial partitions, with the identical result
    (:mod:`predicates.registration.partition.run`; needs ``fperr[dask]``); the default
    is serial, without Dask. ``tolerances``: a tolerance table (e.g. from ``fperr
    synthesize``; see :func:`predicates.tolerance_table.resolve_table`) instead of
    Figure 1/5 — sound only if ``fperr verify --tolerances`` accepts it. ``timeout``:
    seconds a partitioned run on a dask.distributed scheduler waits for its tasks once
    submitted, then cancels them and raises
    :class:`~predicates.registration.partition.run.PartitionError` (as when a worker
    dies under a task). ``accelerate``: the compiled candidate chain, same bits
    (:mod:`predicates.compiled`; None: by FPERR_ACCELERATE, else when installed and
    the run is large enough, :func:`predicates.compiled.resolve`). Returns an
    :class:`~predicates.registration.IntersectionResult`.
    """
    args = [sim, cut, cut_points, cut_cells]
    while len(args) > 2 and args[-1] is None:  # the two-mesh form, or a bad count
        args.pop()
    t0, c0 = time.perf_counter(), time.process_time()
    timings, accelerate = {}, compiled.resolve(accelerate)
    serial = partitions is None and scheduler is None
    if timeout is not None:  # before any work (Dask is imported only for a partitioned run)
        from predicates.registration.partition.run import check_timeout

        timeout = check_timeout(timeout, not serial, scheduler)
    with _connected(scheduler) as scheduler:  # an address: one Client, plan and tasks
        plan = _plan(  # partitioned: threads per worker, the workers' cells on the workers
            args, dtype, tolerance_scale, progress, chunk, refine_cut, timings, sim_region,
            cut_region, tolerances,
            threads=1 if serial else plan_threads.threads_for(scheduler),
            scheduler=None if serial else (scheduler or "threads"), accelerate=accelerate)
        timings["setup"], timings["cpu_setup"] = time.perf_counter() - t0, time.process_time() - c0
        check = partial(_check, plan.report, strict, memory_limit, plan.dim)
        if serial:
            check()
            with MemoryGuard(plan, timings, _mib(args)):  # the plan is not held in it
                reg, plan = _ranked(plan, chunk, timings)  # plan: lean, its arrays reg's
                pairs = reg.run(progress, timings, give_back=_held_much(plan))  # reg empty
        else:
            from predicates.registration.partition.run import run_partitioned
            # checked there, before any task: the memory guard counts the partitions
            # held at once, not the whole run
            pairs = run_partitioned(plan, partitions, scheduler, chunk, timings, check,
                                    progress, timeout)
    timings["total"] = time.perf_counter() - t0
    timings["accelerated"] = plan.accelerate  # which ran: the compiled chain, or numpy
    return _result(plan, pairs, timings)


def _result(plan, pairs: dict, timings: dict) -> IntersectionResult:
    """The result of a run: its plan, {kind: KindPairs} and timings."""
    sim, cut, sc_ = plan.sim, plan.cut, plan.scale
    return IntersectionResult(
        dim=plan.dim, dtype=plan.dtype, kinds=tuple(k.name for k in plan.kinds), pairs=pairs,
        tolerances=plan.tol, scale_exponent=sc_.e, tolerance_scale=plan.ts, L_a=sc_.L_a,
        L_b=sc_.L_b, sim_points=sim.points, sim_cells=sim.cells, cut_points=cut.points,
        cut_cells=cut.cells, rounded_inputs=sim.rounded or cut.rounded, timings=timings,
        resolution=plan.report, refinement=plan.refinement, notes=plan.arrays.notes,
        plane=plan.arrays.plane)


class PlanMemoryError(MemoryError):
    """The plan (validation, boxes, L, refinement, report) ran out of memory: the
    message names the stage, the mesh's size and what to do (docs/partitioned.md)."""


def _too_large(args, timings: dict, serial: bool, err: MemoryError) -> str:
    """The message of :class:`PlanMemoryError`: the stage reached, the meshes' bytes."""
    stage = next((s for s in PLAN_STAGES if s not in timings), "plan_report")
    what = "" if serial else (" (on the client; give the simulation cells as a dask "
                              "array or pieces to run its per-cell passes on the workers)")
    return (f"not enough memory for the plan ({stage.replace('plan_', '')}) of meshes "
            f"of {_mib(args):.0f} MiB{what}: besides the meshes themselves it needs "
            f"about as many bytes again as the simulation mesh (docs/partitioned.md "
            f"section 2); free memory or run on a machine with more "
            f"({type(err).__name__}: {str(err) or 'no detail'})")


def _mib(args) -> float:
    """The meshes' bytes (MiB) as given to :func:`intersect` (arrays; else 0)."""
    return sum(getattr(a, "nbytes", 0) for a in args if a is not None) / 2**20


class Plan(NamedTuple):
    """Everything global a registration decides before the levels: a partitioned run
    computes it once and every partition uses it unchanged (docs/partitioned.md)."""

    dim: int
    dtype: np.dtype
    sim: object  # inputs.MeshInput (validated, working dtype)
    cut: object  # the same, refined when refine_cut
    scale: object  # resolution.Scale: L_a, L_b, e, reach, masks
    P_sim: np.ndarray  # coordinates scaled by 2^-e
    P_cut: np.ndarray
    sim_cells: np.ndarray  # the cells that can meet (scale.masks): the run's cells
    cut_cells: np.ndarray
    tol: object  # Tolerances of the run (scaled by tolerance_scale)
    ts: float
    kinds: tuple
    report: object  # resolution.Resolution
    refinement: object
    arrays: object  # inputs.Arrays: the meshes as arrays, with notes and plane
    accelerate: bool = False  # the compiled candidate chain (predicates.compiled)
    # partitioned: P_sim holds only the run's vertices, these global ids ascending,
    # sim_cells in their positions (None: every point; run_arrays.DeferredRun: not yet)
    sim_vertex_ids: np.ndarray | None = None


def _plan(args, dtype, tolerance_scale, progress, chunk, refine_cut, timings, sim_region,
          cut_region, tolerances=None, threads: int = 1, scheduler=None,
          accelerate: bool | None = False) -> Plan:
    """Validation, refinement, L over the cells that can meet, exact scaling,
    tolerances, reach and the resolution report: the global part of the run.
    ``threads`` > 1: the per-cell work in chunks on a thread pool, identical values
    (:mod:`~predicates.registration.plan.threads`); ``accelerate``: its passes compiled
    (recorded in the plan for the registration)."""
    try:
        if threads <= 1:
            return _plan_with(plan_threads.Work(accelerate=accelerate), args, dtype,
                              tolerance_scale, progress, chunk, refine_cut, timings,
                              sim_region, cut_region, tolerances, scheduler)
        with ThreadPoolExecutor(threads, thread_name_prefix="fperr-plan") as pool:
            return _plan_with(plan_threads.Work(pool, threads, accelerate), args, dtype,
                              tolerance_scale, progress, chunk, refine_cut, timings,
                              sim_region, cut_region, tolerances, scheduler)
    except MemoryError as e:  # a refusal that says what was too large, not a bare one
        raise PlanMemoryError(_too_large(args, timings, scheduler is None, e)) from e


def _plan_with(work, args, dtype, tolerance_scale, progress, chunk, refine_cut, timings,
               sim_region, cut_region, tolerances, scheduler=None) -> Plan:
    """:func:`_plan` with ``work`` (a :class:`~predicates.registration.plan.threads.Work`);
    ``scheduler``: a partitioned run's, whose workers run the per-cell passes when the
    simulation cells are a dask array (:mod:`~predicates.registration.partition.remote`)."""
    dtype, ts = validate_options(dtype, tolerance_scale, progress, chunk)
    arrays = mesh_arrays(args, sim_region, cut_region)
    sp, sc, cp, cc = arrays
    if work.accelerate is None:  # auto: compiled when the run repays loading it
        work.use_compiled(compiled.resolve(None, cells=len(sc) + len(cc)))  # lists too
    clock = _Stages(timings)
    if scheduler is not None and remote.is_remote(sc, scheduler):  # dask-array cells
        dim, sim, cut, sim_box = remote.validate_pair_remote(sp, sc, cp, cc, dtype,
                                                             scheduler, work.blocks)
        timings["plan_remote"] = sim_box.stats
    else:
        dim, sim, cut = validate_pair(sp, sc, cp, cc, dtype, work.blocks,
                                      grid := first_round.from_cut(work.boxes, work.blocks))
        sim_box = CellBoxes(sim.points, sim.cells, work.blocks, sim.summary, checked=True)
        sim_box.sweep_grid = None if work.blocks.accelerate else grid(cut, len(sim.cells))
    clock("plan_validate")
    S, cut_box = sim_box.summary(), first_round.cut_boxes(sim_box, cut, work.boxes)
    check_extent("simulation", sim, sp, dtype, (S.lo_min, S.hi_max))
    check_extent("cutting", cut, cp, dtype, hull_of(*cut_box))
    clock("plan_boxes")
    refinement = None
    if refine_cut and len(cut.cells):
        refinement = refine(cut.points, cut.cells, sim_box.lo, sim_box.hi, boxes=cut_box,
                            sim_stats=S.scan_stats(), accelerate=work.blocks.accelerate)
        cut.points, cut.cells = refinement.points, refinement.cells
        if refinement.rounds:  # else the same cells: the same boxes
            cut_box = work.boxes(cut.points, cut.cells)
        clock("refine")

    # L over the cells that can meet, then the exact power-of-two scaling from it
    sc_ = consistent_scale(dim, sim_box, cut_box, dtype, table=tolerances, flags=work.flags)
    ms, mc = sc_.masks
    run = sim_box.cells_of(ms)
    # partitioned: every point checked (a piece's on the workers, partition/points.py),
    # only the run's vertices scaled and kept, the run's cells renumbered to them
    # (docs/partitioned.md 6), deferred when the split is the workers'; serial: every point
    fast = work.blocks.accelerate
    keep, P_sim, run = run_arrays.run_arrays(sim, run, sc_.e, scheduler is not None, fast,
                                             isinstance(sim, remote.CellsOnWorkers))
    P_cut = scale_points(cut.points, sc_.e, "cutting", accelerate=fast)
    tol_run = sc_.tol if ts == 1 else sc_.tol.scaled(dtype.type(ts))
    clock("plan_scale")
    report = _report(dim, dtype, sim, cut, sim_box, cut_box, sc_, refinement, ts, work)
    clock("plan_report")
    return Plan(dim, dtype, sim, cut, sc_, P_sim, P_cut, run, cut.cells[mc], tol_run, ts,
                catalogue_kinds(dim), report, refinement, arrays, work.blocks.accelerate,
                keep)


def _connected(scheduler):
    """A scheduler address connected once for the plan and the tasks (a Client, closed
    after: :func:`~predicates.registration.partition.run.connected`), else as given."""
    if not isinstance(scheduler, str) or "://" not in scheduler:
        return contextlib.nullcontext(scheduler)
    from predicates.registration.partition.run import connected

    return connected(scheduler)


class _Stages:
    """Wall seconds of the plan's consecutive stages into ``timings`` (inside "setup")."""

    def __init__(self, timings: dict):
        self.timings, self.t = timings, time.perf_counter()

    def __call__(self, stage: str) -> None:
        t = time.perf_counter()
        self.timings[stage], self.t = t - self.t, t


def _ranked(plan: Plan, chunk: int, timings: dict) -> tuple[Registration, Plan]:
    """Rank space of the cells that can meet (they hold every pair within reach,
    docs/resolution.md): the registration, whose ``run()`` gives {kind: KindPairs},
    and the plan without the arrays it now holds its own copies of (:func:`_lean`)."""
    t = time.perf_counter()
    reg = Registration(plan.dim, plan.P_sim, plan.sim_cells, plan.P_cut, plan.cut_cells,
                       plan.tol, plan.scale.reach, chunk, accelerate=plan.accelerate)
    timings["ranks"] = time.perf_counter() - t
    return reg, _lean(plan)


def _held_much(plan: Plan) -> bool:
    """Whether giving the plan's freed memory back before the levels pays
    (:func:`~predicates.registration.levels.loop.trim_freed`: glibc's heap trimmed,
    ~10 ms at W4): for a mesh of 2^20 cells or more, whose serial peak it lowers."""
    return len(plan.sim.cells) >= 2**20


def _lean(plan: Plan) -> Plan:
    """The plan without what only the rank space read (the scaled points, the run's
    cells, the masks): the result's fields, a serial run's peak lower by their bytes."""
    return plan._replace(P_sim=None, P_cut=None, sim_cells=None, cut_cells=None,
                         scale=dataclasses.replace(plan.scale, masks=(), first=()))


def _report(dim, dtype, sim, cut, sim_box, cut_box, sc_, refinement, ts,
            work=None) -> Resolution:
    """The resolution report (before the work): edges of the cells that can meet.
    ``work``: its independent parts run concurrently on a threaded plan's pool."""
    work = plan_threads.Work() if work is None else work
    ms, mc = sc_.masks
    # counts and the cut's edge compiled serially: a pool thread waiting on its own pool starves
    serial = Blocks(accelerate=work.blocks.accelerate)
    run_box = sim_box.rows(ms) if hasattr(sim_box, "rows") else (sim_box[0][ms], sim_box[1][ms])
    cut_run = cut_box if mc.all() else (cut_box[0][mc], cut_box[1][mc])  # (no copy of all)
    pairs = work.submit(estimate_cell_pairs, *run_box, *cut_run, sc_.pad, serial)
    # near the cut: the run's cells (flagged at the final pad or a larger one: a superset
    # of the cells within σ+); flagged at the pad if no round was kept (masks: all cells)
    if len(sc_.history) == 1:  # round one's flags were at this pad: not computed again
        ms, mc = sc_.first or near_cells(sim_box, cut_box, sc_.pad, sc_.masks, work.flags)
    h_cut = work.submit(shortest_edge, cut.points, cut.cells, mc, serial,
                        cut_run if mc is sc_.masks[1] else None)
    h_sim = getattr(sim_box, "shortest_edge", lambda _: None)(ms)  # workers' summaries
    if h_sim is None:  # here, on the same cells in the same order as sim.cells[ms]
        run = sim_box.cells_of(ms)
        h_sim = (shortest_edge(sim.points, run, np.ones(len(run), bool), work.blocks,
                               run_box if ms is sc_.masks[0] else None),)
    ref = refinement and (refinement.input_cells, len(refinement.cells), refinement.rounds)
    return Resolution(dim, dtype.name, t_plus(dim, sc_), h_sim[0], h_cut.result(), sc_.L_a,
                      sc_.L_b, sc_.history[0], len(sc_.history) - 1, ref, pairs.result(), ts)


def _check(report: Resolution, strict: bool, limit: int | None, dim: int,
           share: float = 1.0, stacklevel: int = 3) -> None:
    """Warn (or raise, ``strict``) when coarse; refuse runs that would exhaust memory
    (``share``: the fraction of the cell pairs held at once, see
    :func:`~predicates.registration.plan.resolution.memory_error`). The naive baseline
    (tolerance_scale 0) is never called coarse; ``stacklevel``: the user's frame."""
    if report.coarse:
        if strict:
            raise ResolutionError(report.message() + " (strict: refused)")
        warnings.warn(report.message(), ResolutionWarning, stacklevel=stacklevel)
    err = memory_error(report, resolution.memory_limit() if limit is None else limit, dim,
                       share)
    if err is not None:
        raise err


def intersect_files(sim, cut: str | os.PathLike, *,
                    output: str | os.PathLike | None = None,
                    plot: str | os.PathLike | None = None,
                    sim_output: str | os.PathLike | None = None, dtype: str = "float64",
                    naive: bool = False, progress: bool = False, refine_cut: bool = True,
                    strict: bool = False, sim_region=None, cut_region=None,
                    **options) -> IntersectionResult:
    """Register two mesh files (any format meshio reads) and write the intersection
    points to ``output`` (.vtu), the simulation mesh with cut-cell data to
    ``sim_output`` and a 2D picture to ``plot``. ``sim``: a file, or a list of files
    holding the pieces of one simulation mesh (merged where they share points:
    :func:`~predicates.registration.io.files.merge_pieces`).

    Output paths are checked before any work (format, directory, not an input file), the
    inputs are read under guard, and every problem raises an error naming the file, so
    a refused run writes nothing; files are written atomically. ``naive``: the
    zero-tolerance baseline (``tolerance_scale=0``); ``refine_cut``, ``strict`` and other
    ``options``: as in :func:`intersect`; ``sim_region``/``cut_region``: a gmsh physical
    group or cell block (tag or name).
    """
    from predicates.registration.io.files import (
        check_outputs, input_roles, load_pair, write_results)

    validate_options(dtype, 0.0, progress, options.get("chunk", CHUNK))  # before any work
    if not isinstance(naive, (bool, np.bool_)):
        raise TypeError(f"naive must be True or False, got {naive!r}")
    check_outputs(input_roles(sim, cut),
                  {("-o", "mesh"): output, ("--plot", "plot"): plot,
                   ("--sim-output", "mesh"): sim_output})
    arrays = load_pair(sim, cut, dtype=dtype, sim_region=sim_region, cut_region=cut_region,
                       scheduler=options.get("scheduler"))  # pieces: read by its workers
    if plot is not None and arrays[0].shape[1] != 2:
        raise ValueError("plots are drawn for 2D meshes only (this case is 3D; open the "
                         "output in ParaView instead)")
    res = intersect(*arrays, dtype=np.dtype(dtype), progress=progress,
                    tolerance_scale=0.0 if naive else 1.0, refine_cut=refine_cut,
                    strict=strict, **options)
    res.notes[:0] = arrays.notes
    res.plane = arrays.plane
    write_results(res, output=output, plot=plot, sim_output=sim_output)
    return res
