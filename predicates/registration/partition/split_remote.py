"""The split where the cells are (docs/partitioned.md 3, "The split where the cells
are"): with the simulation cells on the workers (:mod:`.remote`), the partitions'
Parts are assembled on the workers from the chunks that hold the run cells; the client
sends no Part and holds no run cell for the split.

1. the Morton box and the k runs from per-chunk summaries (:mod:`.split_keys`: exact
   min/max and an exact selection of the k − 1 boundary keys — each cell's partition
   is :func:`.assign.assign`'s, whatever the chunking);
2. vertex owners by an exchange between workers: each chunk sends each range of
   vertex ids, per vertex of its run cells, the partition of its smallest cell there;
   each range keeps the first chunk's (section 3: a vertex is owned by the partition
   owning the smallest-index cell containing it; the chunks hold increasing indices)
   and sends each chunk the owners of its vertices;
3. each chunk sends partition r every run cell with a vertex r owns (section 4's lemma
   as :func:`.slices.owner_halos` states it) with its vertices' scaled coordinates and
   owned flags; partition r's task assembles its Part — local numbering in increasing
   global vertex id, cells in increasing global cell index, as :meth:`.assign.Layout.part`
   does — cuts its cutting slice from the :class:`~.assign.CutSide` and runs
   (:func:`~.task.run_part`).

Every step is a Dask task whose inputs are other tasks' outputs: the data moves worker
to worker. The client sends per chunk the plan's run mask over its rows (1 bit per
cell), the box and the k − 1 boundary keys (16 bytes each) — O(k) per partition.
"""
from __future__ import annotations

import time
import uuid

import numpy as np

from predicates import compiled
from predicates.registration.partition.assign import CutSide, Part, cut_slice
from predicates.registration.partition.run_arrays import DeferredRun
from predicates.registration.partition.slices import _grouped
from predicates.registration.partition.split_keys import (
    answer, chunk_run, first_hull, partition_of, select_boundaries, with_codes)
from predicates.registration.partition.task import run_part
from predicates.registration.plan.scaling import times_pow2
from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxgrid import colmax, colmin

__all__ = ["on_workers", "run_hull", "settled_side", "split_on_workers", "warm_side"]


def on_workers(plan) -> bool:
    """Does the plan's simulation mesh have its cells on the workers
    (:class:`.remote.CellsOnWorkers`, from :func:`.remote.validate_remote`)?"""
    return bool(getattr(plan.sim, "held", ())) and plan.sim_vertex_ids is not None


def _parts(run, boundaries: list) -> np.ndarray:
    return partition_of(run.codes, run.rows, boundaries)


def _firsts(run, parts: np.ndarray, bounds: np.ndarray) -> tuple:
    """Per range of vertex ids ``bounds``: the chunk's vertices there (ascending), for
    each the partition of its smallest run cell here (and the chunk's CPU seconds so
    far: the critical path's, :func:`assemble`)."""
    c = time.thread_time()
    part = parts[run.first_row]
    cut = np.searchsorted(run.vids, bounds)
    cpu = run.cpu + time.thread_time() - c
    return tuple((run.vids[a:b], part[a:b], cpu) for a, b in zip(cut[:-1], cut[1:]))


def _owners(*pieces) -> tuple:
    """A range's owners (``pieces``: the chunks' :func:`_firsts` here, in the chunks'
    order): each vertex's partition is that of its smallest run cell — the chunks come
    in increasing cell index, so it is the first chunk holding the vertex that says it
    (np.unique's first occurrence). Per chunk, the owners of its vertices here (and the
    CPU seconds of the longest path to here)."""
    c = time.thread_time()
    vids = np.concatenate([p[0] for p in pieces])
    part = np.concatenate([p[1] for p in pieces])
    ids, at = np.unique(vids, return_index=True)
    owner = part[at]
    got = [owner[np.searchsorted(ids, p[0])] for p in pieces]
    path = max(p[2] for p in pieces) + time.thread_time() - c
    return tuple((g, path) for g in got)


#: up to this many partitions :func:`_destinations` tests each partition's owners
#: directly (k passes over the cells) instead of sorting (cell, owner) keys
DIRECT_K = 8


def _destinations(owners: np.ndarray, k: int):
    """(cell positions, starts): partition r's cells — those with a vertex it owns
    (``owners``: per cell, its vertices' owners) — are ``ids[starts[r]:starts[r+1]]``,
    ascending. For a few partitions (k ≤ :data:`DIRECT_K`) a pass per partition over
    the owners' columns; else most cells have one owner for all their vertices: those
    are grouped by a sort of one key each, only the others by every (cell, owner)
    pair. Both give the same ids."""
    m = len(owners)
    if k <= DIRECT_K:  # (W4, k = 2: ~2 ms a partition against a 13 ms sort)
        ids = []
        for r in range(k):
            has = np.zeros(m, dtype=bool)
            for column in owners.T:
                has |= column == r
            ids.append(np.flatnonzero(has))
        starts = np.cumsum([0] + [len(i) for i in ids], dtype=np.int64)
        return np.concatenate(ids + [np.zeros(0, np.int64)]).astype(np.int64, copy=False), starts
    same = np.all(owners == owners[:, :1], axis=1)
    one = np.flatnonzero(same)
    other = np.flatnonzero(~same)
    keys = [owners[one, 0] * max(m, 1) + one,
            (owners[other] * max(m, 1) + other[:, None]).ravel()]
    return _grouped(np.concatenate(keys), k, max(m, 1))


def _route(run, parts: np.ndarray, k: int, *owners) -> tuple:
    """What the chunk sends each of the k partitions: (global cell indices, cells in
    rows of the vertices sent (int32 when they fit: :func:`assemble` renumbers them by
    a search per vertex, not per cell corner), those vertices' global ids (ascending),
    their scaled coordinates, owned by the partition, the count of the chunk's cells
    the partition owns, the CPU seconds of the longest path to here)."""
    c = time.thread_time()
    owner = np.concatenate([o[0] for o in owners] + [np.zeros(0, np.int64)]
                           ).astype(np.int64)
    halo, starts = _destinations(owner[run.at], k)
    owned = np.bincount(parts, minlength=k)
    out = []
    for r in range(k):
        sel = halo[starts[r]:starts[r + 1]]
        at = run.at[sel]
        used = np.zeros(len(run.vids), dtype=bool)
        used[at.ravel()] = True
        # each vertex's row among those sent: the count of sent vertices before it
        row = np.cumsum(used, dtype=np.int32 if len(run.vids) < 2 ** 31 else np.int64)
        out.append([run.rows[sel], np.take(row, at) - 1, run.vids[used], run.coords[used],
                    owner[used] == r, int(owned[r])])
    path = max((o[1] for o in owners), default=run.cpu) + time.thread_time() - c
    return tuple(tuple(o) + (path,) for o in out)


def assemble(r: int, *routes) -> Part | None:
    """Partition r's :class:`~.assign.Part` from every chunk's route (in the chunks'
    order: cell indices ascending), its cutting slice left to the task; None when it
    holds no cell."""
    if sum(len(g[1]) for g in routes) == 0:
        return None
    ids = np.concatenate([g[2] for g in routes])
    vids, first = np.unique(ids, return_index=True)  # shared vertices: the same values
    coords = np.concatenate([g[3] for g in routes])[first]
    own = np.concatenate([g[4] for g in routes])[first]
    # each route's vertices found among the part's (a search per vertex), then its
    # cells' rows mapped by a gather: the local ids a search per cell corner gave
    kind = np.int32 if len(vids) < 2 ** 31 else np.int64
    local = np.concatenate([np.take(np.searchsorted(vids, g[2]).astype(kind, copy=False),
                                    g[1]) for g in routes])
    gid = vids.astype(np.int32) if vids[-1] < 2 ** 31 else vids
    d = coords.shape[1]
    return Part(r, coords, local, gid, own, np.zeros((0, d), coords.dtype),
                np.zeros((0, d + 1), np.int32), np.zeros(0, np.int32),
                sum(g[5] for g in routes), cut_pending=True)


def _assembled_run(r: int, args: tuple, side: CutSide, *routes):
    """Partition r's task: its Part assembled (:func:`assemble`), its cutting slice cut,
    the serial levels (:func:`~.task.run_part`); None when it holds no cell or no
    cutting cell is within reach (it owns no pair)."""
    c = time.thread_time()
    part = assemble(r, *routes)
    if part is None:
        return None
    bytes_in = part.nbytes
    part = cut_slice(part, side, Blocks(accelerate=args[-1] and compiled.available()))
    if len(part.cut_cells) == 0:
        return None
    cpu = time.thread_time() - c
    pairs, stats = run_part(part, *args)
    # cpu_split_path: the chunks' and ranges' steps before this task, on its longest path
    stats.update(bytes_in=bytes_in, cpu_slice_s=cpu, cpu_s=stats["cpu_s"] + cpu,
                 cpu_split_path=max(g[6] for g in routes))
    return pairs, stats


def split_on_workers(plan, k: int, pad: float, args: tuple, client, scheduler,
                     timings: dict, timeout: float | None = None) -> list:
    """Partition tasks for the plan's run cells held by the workers (module docstring):
    futures on a ``client``, else delayed objects for the local ``scheduler``; each
    gives (owned pairs, statistics) or None. ``timings["split"]``: the selection's
    rounds, the bytes the client put in the graph. ``timeout`` (a Client only): seconds
    from here for the selection's rounds; past it their tasks are cancelled and
    TimeoutError is raised."""
    import dask

    d = dask.delayed
    cells, pieces, points = plan.sim.held
    offsets = np.concatenate([[0], np.cumsum(cells.chunks[0])]).astype(np.int64)
    ms = plan.scale.masks[0]
    bits = [np.packbits(ms[a:b]) for a, b in zip(offsets[:-1], offsets[1:])]
    sources = pieces if pieces is not None else list(cells.to_delayed().ravel())
    if points is not None and client is None:  # one key for every task, not a copy each
        points = d(points, name=f"fperr-points-{uuid.uuid4().hex}")
    runs = [d(chunk_run, pure=False)(s, points, b, int(o), plan.scale.e, plan.dtype,
                                     pieces is not None)
            for s, b, o in zip(sources, bits, offsets)]
    hull = run_hull(plan.sim_vertex_ids)  # the points here: no round for the box
    if hull is None:
        runs = _persist(runs, client, scheduler)
    # the cutting side, sent once to each worker; its wide boxes computed there by a
    # task of its own while the worker waits for the selection's rounds (warm_side)
    side = CutSide(plan.P_cut, plan.cut_cells, pad)
    timings["cut_side_bytes"] = side.nbytes
    if client is not None:
        side = client.scatter(side, hash=False, broadcast=True)
        warm = warm_side(client, side, plan.accelerate)
    else:  # local schedulers: the first task computes them (one object, one process)
        side, warm = d(side, name=f"fperr-cut-side-{uuid.uuid4().hex}"), []
    deadline = None if timeout is None else time.monotonic() + timeout

    def results(objs):
        return _compute(objs, client, scheduler, deadline, runs + warm)

    if hull is None:
        hulls = results([d(first_hull)(r) for r in runs])
        boxes = [h[0] for h in hulls if h[1]]
        m = sum(h[1] for h in hulls)
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
    else:
        lo, hi, m = hull
    runs = _persist([d(with_codes)(r, lo, hi) for r in runs], client, scheduler)
    n_bits, rounds = (63 if plan.dim == 3 else 62), [0]

    def ask(queries):
        rounds[0] += 1
        return results([d(answer)(r, n_bits, queries) for r in runs])

    boundaries = select_boundaries(ask, m, k, n_bits)
    C = len(runs)
    n = len(plan.sim.points)
    bounds = np.array([n * j // C for j in range(C + 1)], dtype=np.int64)
    parts = [d(_parts)(r, boundaries) for r in runs]
    firsts = [d(_firsts, nout=C)(r, p, bounds) for r, p in zip(runs, parts)]
    owners = [d(_owners, nout=C)(*[f[j] for f in firsts]) for j in range(C)]
    routes = [d(_route, nout=k)(r, p, k, *[o[i] for o in owners])
              for i, (r, p) in enumerate(zip(runs, parts))]
    tasks = [d(_assembled_run, pure=False)(r, args, side, *[g[r] for g in routes])
             for r in range(k)]
    timings["split"] = {"where": "workers", "rounds": rounds[0], "chunks": C,
                        "hull": "workers" if hull is None else "client",
                        "sent_bytes": sum(b.nbytes for b in bits) + 16 * (k - 1)
                        + lo.nbytes + hi.nbytes + bounds.nbytes, "side_boxes": warm}
    return client.compute(tasks) if client is not None else tasks


def run_hull(deferred) -> tuple | None:
    """(lo, hi, m): the box of the run cells' first vertices scaled by 2^-e (float64,
    one value per axis) and the run cell count, from the plan's :class:`~.run_arrays.
    DeferredRun` (the run cells and every point on the client) — the values the chunks'
    :func:`~.split_keys.first_hull` give, combined: ``times_pow2`` is element-wise and
    exact here (the plan checked every point's scaling), so min and max commute with it
    and with the float64 conversion (equal values; a signed zero may come out as the
    other, which gives the same Morton codes). A gather of one vertex per run cell on
    the client instead of a round of tasks (benchmarks/README.md "The 2-worker W4
    client, fifth pass"); compiled (``deferred.fast``): the min and max read in place,
    then scaled ("… sixth pass"). None without a DeferredRun (pieces: their points are on the
    workers) or run cells."""
    if not isinstance(deferred, DeferredRun) or len(deferred.run) == 0:
        return None
    points = deferred.points
    if deferred.fast and points.ndim == 2 and points.dtype.kind == "f":
        # min and max before the scaling: it is non-decreasing (and exact here), so it
        # commutes with them — two values scaled instead of m (the same values), read
        # in place (predicates.compiled.runhull; sixth pass)
        from predicates.compiled.runhull import first_vertex_hull

        lo, hi = np.empty(points.shape[1], points.dtype), np.empty(points.shape[1], points.dtype)
        first_vertex_hull(points, deferred.run, lo, hi)
        lo, hi = (times_pow2(x, -deferred.e).astype(np.float64) for x in (lo, hi))
        return lo, hi, len(deferred.run)
    first = times_pow2(np.take(points, deferred.run[:, 0], axis=0), -deferred.e)
    first = first.astype(np.float64, copy=False)
    return colmin(first), colmax(first), len(deferred.run)


def _side_boxes(side: CutSide, accelerate: bool) -> float:
    """The cutting side's wide boxes computed on this worker's copy of ``side`` (kept
    with it: :meth:`~.assign.CutSide.boxes`); the thread CPU seconds they took."""
    c = time.thread_time()
    side.boxes(Blocks(accelerate=accelerate and compiled.available()))
    return time.thread_time() - c


def warm_side(client, side, accelerate: bool) -> list:
    """A task per worker computing the scattered ``side``'s wide boxes there
    (:func:`_side_boxes`; docs/partitioned.md 5b): they depend only on the cutting mesh,
    so each worker computes them once while it waits for the split's rounds instead of
    in its first partition task, on the critical path. A worker left without them (it
    joined later, or Dask replaced its copy of the side: seen once in eight fresh
    clusters where another task had read the side there first, never in 24 without)
    computes them in its task as before: the same boxes.
    The futures, to be settled by :func:`settled_side`."""
    return [client.submit(_side_boxes, side, accelerate, workers=[w],
                          allow_other_workers=False, key=f"fperr-side-{uuid.uuid4().hex}")
            for w in client.scheduler_info().get("workers", {})]


def settled_side(timings: dict) -> None:
    """``timings["split"]["side_boxes"]``: the :func:`warm_side` tasks' CPU seconds
    (those that ran); the others are cancelled (a task pinned to a worker that left
    would wait for it). After a failed run the futures are dropped with ``timings``."""
    split = timings.get("split") or {}
    warm = split.get("side_boxes") or []
    if warm:
        warm[0].client.cancel([f for f in warm if f.status != "finished"])
        split["side_boxes"] = [f.result() for f in warm if f.status == "finished"]


def _persist(objs: list, client, scheduler) -> list:
    """``objs`` computed and kept where they are (on a Client: futures on the workers)."""
    import dask

    if client is not None:
        return client.persist(objs)
    return list(dask.persist(*objs, scheduler=scheduler))


def _compute(objs: list, client, scheduler, deadline: float | None = None,
             held: list = ()) -> list:
    """The (small) results of ``objs``, on the client; on a Client with a ``deadline``
    (``time.monotonic()``) not reached, else their tasks and the persisted ``held``
    are cancelled and TimeoutError is raised."""
    import dask

    if client is None or deadline is None:
        return list(dask.compute(*objs, scheduler=client or scheduler))
    from distributed import wait

    futures = client.compute(objs)
    try:
        wait(futures, timeout=max(deadline - time.monotonic(), 0.0))
    except TimeoutError:
        client.cancel([*futures, *held])
        raise
    return client.gather(futures)
