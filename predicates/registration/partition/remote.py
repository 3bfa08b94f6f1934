"""The plan's per-cell passes on the workers, on the cells they hold (docs/partitioned.md,
section 6): a simulation mesh whose cells are a ``dask.array`` (chunks of rows) in a
partitioned run never materialises on the client.

The plan needs every simulation cell only for reductions and flags (section 2, "the
lean plan"): validation (the first bad cell of each check, the vertices used), the
boxes' :class:`~predicates.registration.plan.cellboxes.BoxSummary` (hull, largest and
smallest edge, the edges' exponent histogram) and the first
round of the cells that can meet (:func:`~predicates.registration.plan.lean.flag_pass`).
Each is a task per chunk on the workers; the client combines the chunks' results —
exact reductions (min, max, integer sums), so the plan is the serial one
bit for bit whatever the chunking — and keeps only the cells that can meet (their
vertex ids and boxes: what the later rounds, the report and the split use). The client
holds the points (not those of pieces read by the workers: :mod:`.points`, every box
then computed on the workers), one byte per cell (the masks) and those cells.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.plan.edges import edge_from, edge_shift
from predicates.registration.plan.inputs import (
    MeshInput, MeshTypeError, _array, _points, cell_error)
from predicates.registration.partition.swept import (
    check_chunk as _check, check_swept, chunk_flags, covered, cut_flags_from, narrow_ids)
from predicates.registration.partition.points import RemotePoints
from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import boxes_of

__all__ = ["RemoteCells", "is_remote", "validate_pair_remote", "validate_remote"]

_LOCAL = ("threads", "processes", "synchronous", "sync", "single-threaded")


def is_remote(cells, scheduler) -> bool:
    """Are ``cells`` a dask array the plan can leave on the workers of ``scheduler``
    (a ``dask.distributed.Client`` or a local Dask scheduler's name)?"""
    if not (hasattr(cells, "to_delayed") and hasattr(cells, "chunks")
            and getattr(cells, "ndim", 0) == 2):
        return False
    if isinstance(scheduler, str):
        return scheduler in _LOCAL
    return "Client" in type(scheduler).__name__ and hasattr(scheduler, "scatter")


def _flags(chunk, points, origin, h, G, table, accelerate: bool = False):
    """A chunk's first-round flags (:func:`~.swept.chunk_flags`, its round of its own:
    the speculative grid was not the round's, or the check did not flag)."""
    from predicates import compiled

    blocks = Blocks(accelerate=accelerate and compiled.available())
    return chunk_flags(CellBoxes(points, np.asarray(chunk), blocks), origin, h, G, table)


def _used(n_points: int, bits: list) -> np.ndarray:
    """The vertices any chunk uses (bool): the chunks' packed bits ORed, unpacked once
    (a chunk that failed a check sent none: it adds nothing)."""
    bits = [b for b in bits if len(b)]
    if not bits:
        return np.zeros(n_points, dtype=bool)
    return np.unpackbits(np.bitwise_or.reduce(bits), count=n_points).view(bool)


def _row_boxes(chunk, points, rows: np.ndarray):
    """The boxes (lo, hi) of a chunk's ``rows`` (chunk-local, ascending)."""
    return boxes_of(points, np.asarray(chunk)[rows])


def _near_scan(chunk, points, grid, centres: bool):
    """A chunk's refinement scan against ``grid`` (local ids): the near cells and the
    wide ones (:func:`~predicates.registration.plan.refine_scan.near_pieces`), or the
    cells whose centres may lie in its boxes (``centres``)."""
    from predicates.registration.plan import refine_scan

    cb = CellBoxes(points, np.asarray(chunk))
    if centres:
        return refine_scan.centre_ids(grid, cb.lo, cb.hi)
    pieces, big = refine_scan.near_pieces(grid, cb.lo, cb.hi)
    cat = [np.concatenate(x) if x else np.zeros(0, dtype=np.int64) for x in (pieces, big)]
    return cat


def _on_piece(f, own, dtype, *args):
    """``f``'s per-chunk pass on a piece read by a worker (:mod:`.pieces`), with the
    piece's own points (cast to the plan's ``dtype`` as the client casts every point:
    the same values) and cells in its own numbering for the boxes; what ``f`` returns
    in vertex ids (validation's used vertices, the flagged cells) is in global ids, and
    validation runs on the global cells (the serial checks and messages)."""
    points, local, cells = own
    with np.errstate(all="ignore"):  # as validate_remote: unused rows are never read
        pts = points.astype(dtype, copy=False)
    if f is _check or f is check_swept:  # validated in global ids, boxes in its own
        return f(cells, pts, *args, local=local)
    if f is _flags:
        count, got = _flags(local, pts, *args)
        if got is None:
            return count, None
        ids, cover, ext, _, edge, _ = got
        # the flagged cells' boxes here, from the piece's points: the client has none
        flagged = np.take(cells, ids, axis=0)
        flagged = narrow_ids(flagged, int(flagged.max()) + 1 if flagged.size else 0)
        return count, (ids, cover, ext, flagged, edge,
                       boxes_of(pts, np.take(local, ids, axis=0)))
    return f(local, pts, *args)  # _near_scan: row ids only; _row_boxes: boxes


def _own_pieces(cells):
    """The pieces read by the workers behind the dask array ``cells`` (:mod:`.pieces`)
    when each chunk is one, else None (not one per chunk: the points are sent)."""
    pieces = getattr(cells, "fperr_pieces", None)
    return pieces if pieces is not None and len(pieces) == len(cells.chunks[0]) else None


def _cpu_timed(f, *args):
    """``(f(*args), the thread CPU seconds it took)`` (on a worker)."""
    import time

    c = time.thread_time()
    out = f(*args)
    return out, time.thread_time() - c


@dataclass
class CellsOnWorkers(MeshInput):
    """The validated simulation mesh with its cells on the workers: ``held`` is
    (the cells kept there (a persisted dask array on a Client), each chunk's piece or
    None, every point in the working dtype there (None for pieces: their own)) — what
    the split on the workers reads (:mod:`.split_remote`)."""

    held: tuple = ()


class RemoteCells(CellBoxes):
    """A :class:`~predicates.registration.plan.cellboxes.CellBoxes` whose cells stay on
    the workers: ``summary`` and ``flag_pass`` are tasks per chunk; rows outside the
    kept cells (rare: a coarse cutting mesh's refinement) are fetched."""

    def __init__(self, points: np.ndarray, cells, scheduler, blocks: Blocks = SERIAL):
        import dask

        self.dask, self.scheduler = dask, scheduler
        self.client = None if isinstance(scheduler, str) else scheduler
        # pieces read by the workers: each chunk's own points and cells (pieces.py)
        self.pieces = _own_pieces(cells)
        cells = cells.rechunk({1: -1})
        if self.client is not None:
            cells = self.client.persist(cells)  # computed once, kept on the workers
        self.cells_da = cells
        self.parts = list(cells.to_delayed().ravel())
        self.offsets = np.concatenate([[0], np.cumsum(cells.chunks[0])]).astype(np.int64)
        self.points, self.blocks = points, blocks
        self.n, self.d = int(cells.shape[0]), points.shape[1]
        self.cols = None  # boxes here come from boxes_of on the kept or fetched rows
        # the points on the workers too (points.py): every box is computed there
        self.far = isinstance(points, RemotePoints) and self.pieces is not None
        # every point to every worker, unless each chunk is a piece with its own
        self._pts = None if self.pieces is not None else self._share(points)
        self._summary, self._kept, self._kept_cells = None, None, None
        self.first_grid = self._first = None  # the check's sweep's flags (swept.py)
        self._edges = None  # (the flag pass's kept ids, its chunks' edge summaries)
        self.occupied = None  # the grid cells the flagged cells cover (swept.covered)
        self.points_finite = False  # every point shared was found finite (check)
        self._flagged = (None, None)  # flag_pass' mask and its rows
        import threading

        self._local = threading.local()
        self.stats = {"tasks": 0, "bytes_back": 0,
                      "points_sent": "pieces" if self.pieces is not None else "broadcast"}

    def handles(self) -> tuple:
        """(the cells as kept, the pieces or None, the points as shared or None)."""
        return self.cells_da, self.pieces, self._pts

    def _share(self, x):
        """``x`` for the tasks: on a distributed Client scattered once to every worker."""
        if self.client is None:
            return x
        return self.client.scatter(x, broadcast=True, hash=False)

    def _map(self, f, *args) -> list:
        """``f(chunk, points, *args)`` per chunk, on the workers; the results in order.
        ``stats["worker_cpu"]`` gets, per pass, the largest chunk's thread CPU seconds
        (the pass's share of the run's critical path when the chunks run side by side)."""
        d = self.dask.delayed
        if self.pieces is not None:  # each piece's own points, where it was read
            tasks = [d(_cpu_timed, pure=False)(_on_piece, f, own, self.points.dtype, *args)
                     for own in self.pieces]
        else:
            tasks = [d(_cpu_timed, pure=False)(f, p, self._pts, *args) for p in self.parts]
        out = self.dask.compute(*tasks, scheduler=self.scheduler)
        self.stats["tasks"] += len(tasks)
        self.stats.setdefault("worker_cpu", []).append(
            (f.__name__.strip("_"), max(o[1] for o in out)))
        return [o[0] for o in out]

    def check(self, n_points: int, grid=None):
        """Validation and summary: (first bad cell per check (global rows, None where
        none), the vertices used (bool; None when the points on the workers are
        checked there, :mod:`.points`)). ``grid``: a speculative first-round grid
        (:mod:`~predicates.registration.plan.first_round`) whose flags the same tasks
        compute where they can (:mod:`.swept`; on pieces read by the workers too, since
        2026-11-28: their flagged cells' boxes come back from the sweep)."""
        if grid is None:
            got = self._map(_check, n_points, not self.far, self.blocks.accelerate)
        else:
            both = self._map(check_swept, n_points, not self.far, self.blocks.accelerate,
                             (grid.origin, grid.h, grid.G, self._share(grid.table)))
            got, flags = [b[0] for b in both], [b[1] for b in both]
            if all(f is not None for f in flags):
                self.first_grid, self._first = grid, flags
                # the sweep ran on every chunk: only over finite points (swept.py), the
                # broadcast ones unless each chunk is a piece with its own
                self.points_finite = self.pieces is None
        bad = [min((int(o) + b[t] for o, (b, _, _) in zip(self.offsets, got)
                    if b[t] is not None), default=None) for t in range(3)]
        used = None if self.far else _used(n_points, [g[1] for g in got])
        if all(b is None for b in bad):
            out = got[0][2]
            for _, _, s in got[1:]:
                out = out.merge(s)
            self._summary = out
        return bad, used

    def summary(self):
        return self._summary

    def flag_pass(self, origin, h, G, table):
        """:func:`~predicates.registration.plan.lean.flag_pass` per chunk on the workers;
        the flagged cells (vertex ids, boxes) are kept here."""
        grid, got = self.first_grid, self._first
        self.first_grid = self._first = None  # asked once: used, or not the round's grid
        self.stats["first_round"] = "check's sweep"
        if grid is None or table is not grid.table:
            self.stats["first_round"] = "a round of its own"
            got = self._map(_flags, origin, h, G,
                            None if table is None else self._share(table),
                            self.blocks.accelerate)
        count = sum(g[0] for g in got)
        if table is None:
            return count, None
        near = np.zeros(self.n, dtype=bool)
        ids = np.concatenate([o + g[1][0] for o, g in zip(self.offsets, got)])
        near[ids] = True
        near.flags.writeable = False  # the plan's mask: _is_kept knows it by identity
        self._flagged = (near, ids)
        cells = np.concatenate([g[1][3] for g in got])
        self.stats["bytes_back"] += sum(
            sum(a.nbytes for a in (g[1][0], g[1][3], *(g[1][5] or ()),
                                   *(g[1][1] if isinstance(g[1][1], tuple) else (g[1][1],))))
            for g in got)
        if all(g[1][5] is not None for g in got):  # computed where the pieces are
            lo = np.concatenate([g[1][5][0] for g in got])
            hi = np.concatenate([g[1][5][1] for g in got])
        else:
            lo, hi = boxes_of(self.points, cells, self.blocks)
        self._kept, self._kept_cells = (ids, lo, hi), cells
        self._edges = (ids, [g[1][4] for g in got if g[1][4] is not None])
        # the cutting flags' input: the chunks' ranges, or the grid cells they cover
        # (first_round.near_fixed then asks cut_flags: the ranges are None)
        i0, i1, self.occupied = covered([g[1][1] for g in got], G, self.blocks)
        return count, (near, i0, i1, max(g[1][2] for g in got))

    def cut_flags(self, ib0, ib1, G) -> np.ndarray:
        """The first round's cutting flags from the grid cells the chunks' flagged
        cells cover (:attr:`occupied`, set by :meth:`flag_pass` when the chunks sent
        them: :func:`~.swept.cut_flags_from`, the values of ``lean.cut_flags``)."""
        return cut_flags_from(self.occupied, ib0, ib1, G, self.blocks)

    def near_pieces(self, grid):
        """The refinement's near scan (its ``near_pieces``) per chunk on the workers."""
        got = self._map(_near_scan, self._share(grid), False)
        return ([o + g[0] for o, g in zip(self.offsets, got)],
                [o + g[1] for o, g in zip(self.offsets, got) if len(g[1])])

    def centre_ids(self, grid) -> np.ndarray:
        """The refinement's centre scan (its ``centre_ids``) per chunk on the workers."""
        got = self._map(_near_scan, self._share(grid), True)
        return np.concatenate([o + g for o, g in zip(self.offsets, got)])

    def shortest_edge(self, sel):
        """``(shortest edge of the cells sel,)`` (None inside if none) combined from the
        flag pass's per-chunk summaries when ``sel`` is its flagged cells and every
        chunk scaled by the global shift (then the serial value exactly: a minimum of
        the same squares); None when it cannot (the caller computes it)."""
        self.stats["report_edge"] = "client"
        if self._edges is None or not self._is_kept(sel, self._edges[0]):
            return None
        parts = self._edges[1]
        shift = edge_shift(max(p[0] for p in parts)) if parts else 0
        if any(p[1] != shift for p in parts):  # another scaling: not provably the same
            return None
        self.stats["report_edge"] = "workers"
        return (edge_from(min(p[2] for p in parts), shift) if parts else None,)

    def _is_kept(self, sel, kept: np.ndarray) -> bool:
        """Does ``sel`` (a mask or ascending ids) select exactly the rows ``kept``? At
        once for :meth:`flag_pass`' own mask and rows (read-only: unchanged since)."""
        if sel is self._flagged[0] and kept is self._flagged[1]:
            return True
        sel = np.asarray(sel)
        if sel.dtype == bool:
            return int(np.count_nonzero(sel)) == len(kept) and bool(sel[kept].all())
        return np.array_equal(sel, kept)

    def _fetch(self, ids: np.ndarray) -> np.ndarray:
        """The vertex ids of the rows ``ids`` (ascending) from the workers."""
        if len(ids) == 0:
            return np.zeros((0, self.cells_da.shape[1]), dtype=self.cells_da.dtype)
        return np.asarray(self.cells_da[ids].compute(scheduler=self.scheduler))

    def cells_of(self, sel) -> np.ndarray:
        if self._kept is not None and self._is_kept(sel, self._kept[0]):
            return self._kept_cells  # the run's cells: no search, no gather
        ids = np.flatnonzero(sel) if np.asarray(sel).dtype == bool else np.asarray(sel)
        if self._kept is not None:
            kept = self._kept[0]
            pos = np.searchsorted(kept, ids)
            if len(ids) == 0 or (pos.max() < len(kept) and np.array_equal(kept[pos], ids)):
                return self._kept_cells[pos]
        return self._fetch(ids)

    def rows(self, sel):
        if self._kept is not None and self._is_kept(sel, self._kept[0]):
            return self._kept[1], self._kept[2]
        ids = np.flatnonzero(sel) if np.asarray(sel).dtype == bool else np.asarray(sel)
        if self._kept is not None:
            kept, lo, hi = self._kept
            pos = np.searchsorted(kept, ids)
            if len(ids) == 0 or (pos.max() < len(kept) and np.array_equal(kept[pos], ids)):
                return lo[pos], hi[pos]
        cells = self._fetch(ids)
        lo, hi = self._boxes(ids, cells)
        self._kept, self._kept_cells = (ids, lo, hi), cells
        return lo, hi

    def _boxes(self, ids: np.ndarray, cells: np.ndarray | None = None):
        """The boxes of the rows ``ids`` (ascending): from the points here, or, when
        the points are on the workers, computed there per chunk (the same values:
        min and max are exact)."""
        if not self.far:
            return boxes_of(self.points, self._fetch(ids) if cells is None else cells,
                            self.blocks)
        cut = np.searchsorted(ids, self.offsets)
        d = self.dask.delayed
        tasks = [d(_cpu_timed, pure=False)(_on_piece, _row_boxes, own, self.points.dtype,
                                           ids[cut[i]:cut[i + 1]] - self.offsets[i])
                 for i, own in enumerate(self.pieces) if cut[i + 1] > cut[i]]
        got = [o[0] for o in self.dask.compute(*tasks, scheduler=self.scheduler)]
        self.stats["tasks"] += len(tasks)
        if not got:
            return np.zeros((0, self.d)), np.zeros((0, self.d))
        return np.concatenate([g[0] for g in got]), np.concatenate([g[1] for g in got])

    def block(self, a: int, b: int):
        last = getattr(self._local, "last", None)
        if last is not None and last[0] == a and last[1] == b:
            return last[2], last[3]
        lo, hi = self._boxes(np.arange(a, b))
        self._local.last = (a, b, lo, hi)
        return lo, hi


def validate_remote(points, cells, dim: int, dtype, scheduler, blocks: Blocks = SERIAL,
                    first_round=None):
    """The simulation mesh validated with its cells on the workers: (MeshInput whose
    ``cells`` is the dask array, its :class:`RemoteCells`); the same checks, order and
    messages as :func:`~predicates.registration.plan.inputs.validate_mesh`.
    ``first_round(n_sim)``: the speculative first-round grid, flagged in the check."""
    far = isinstance(points, RemotePoints) and _own_pieces(cells) is not None
    # points on the workers without their pieces' cells: gathered here, as given
    arr = points if far else _array(points, "simulation")
    name, k = "simulation cells", dim + 1
    what = {2: "triangles", 3: "tetrahedra"}[dim]
    if cells.dtype.kind not in "iu":
        raise MeshTypeError(f"{name} must be integer vertex indices, got dtype "
                            f"{cells.dtype}")
    if cells.shape[1] != k:
        raise ValueError(f"{name} must have shape (M, {k}) ({what} of a {dim}D "
                         f"simulation mesh), got {cells.shape}")
    if cells.shape[0] == 0:
        raise ValueError("the simulation mesh is empty (0 cells)")
    if far:  # checked on the workers (points.py), in ``dtype`` there
        work = RemotePoints(arr.ranges, arr.bounds, arr.shape[1], arr.scheduler, dtype)
    else:
        with np.errstate(all="ignore"):  # unused rows are never read by a box
            work = arr.astype(dtype, copy=False)
    remote = RemoteCells(work, cells, scheduler, blocks)
    grid = None if first_round is None else first_round(int(cells.shape[0]))
    bad, used = remote.check(len(arr), grid)
    for t in range(3):
        if bad[t] is not None:
            row = remote._fetch(np.array([bad[t]]))[0].tolist()
            raise cell_error("simulation", t, bad[t], row, len(arr))
    if far:
        pts, rounded = arr.checked("simulation", dtype)
    else:
        # (the points the workers found finite: ``work`` is ``arr`` when in dtype)
        pts, rounded = _points(arr, used, "simulation", dtype,
                               finite=remote.points_finite and arr.dtype == dtype)
    remote.points = pts  # the same boxes as from ``work`` (the used rows are equal)
    return CellsOnWorkers(pts, cells, "simulation", rounded, remote.handles()), remote


def validate_pair_remote(sp, sc, cp, cc, dtype, scheduler, blocks: Blocks = SERIAL):
    """``validate_pair`` with the simulation cells ``sc`` on the workers: (dim, the
    simulation's MeshInput, the cutting mesh's, the simulation's :class:`RemoteCells`)."""
    from predicates.registration.plan.inputs import validate_mesh

    from functools import partial

    from predicates.registration.plan import first_round

    dim = sp.shape[1] if isinstance(sp, RemotePoints) else _array(sp, "simulation").shape[1]
    cut = error = grid_for = None
    try:  # first: its boxes fix the first round's grid (its error after the simulation's)
        cut = validate_mesh(cp, cc, "cutting", dim, dtype, allow_empty=True, blocks=blocks)
        make = first_round.from_cut(partial(boxes_of, blocks=blocks), blocks)
        grid_for = (lambda n: make(cut, n))  # noqa: E731
    except Exception as e:
        error = e
    sim, remote = validate_remote(sp, sc, dim, dtype, scheduler, blocks, grid_for)
    if error is not None:
        raise error
    return dim, sim, cut, remote
