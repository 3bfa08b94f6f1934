"""The global plan's heavy per-cell numpy work on a client thread pool (partitioned runs
only, issue 13; docs/partitioned.md). Section 4.1 of the paper needs L over the cells
that can meet: the plan (:func:`predicates.registration.pipeline._plan`) computes it on
the client over all cells, before any partition can start, so in a partitioned run it is
the serial part of the critical path.

Everything here gives *bit-identical* values to the serial functions it replaces: the
work is split by cells, and each cell's value (its box: per-cell min/max; its flag: a
look-up in the same grid) does not depend on the other cells of its chunk. The only
global quantities — the broad-phase grid (a mean summed in sorted order) and the
occupancy of the cutting side — are computed once, serially, exactly as in
:func:`~predicates.registration.broadphase.near_flags`; chunk occupancies are combined
by ``|`` (a cell is covered iff a chunk covers it: exact). numpy releases the GIL in
``take``/``minimum``/``bincount``/``cumsum`` on large arrays, so the chunks overlap.
"""
from __future__ import annotations

from concurrent.futures import Executor

import numpy as np

from . import boxes as boxes_mod, broadphase
from .broadphase import _any_in, _dense, _grid, _occupancy

__all__ = ["MIN_CHUNK", "Work", "boxes", "near_flags", "threads_for"]

#: below this many cells per chunk the thread hand-off costs more than it saves
MIN_CHUNK = 32_768


def _bounds(n: int, parts: int) -> list[tuple[int, int]]:
    """``parts`` contiguous ranges covering [0, n), each at least MIN_CHUNK long."""
    parts = max(1, min(parts, n // MIN_CHUNK))
    cut = [n * i // parts for i in range(parts + 1)]
    return list(zip(cut[:-1], cut[1:]))


def boxes(points: np.ndarray, cells: np.ndarray, pool: Executor, parts: int):
    """:func:`~predicates.registration.broadphase.boxes_of` (the cells' (lo, hi)
    boxes, the same column-major layout and bit-identical values) in ``parts`` chunks
    of cells on ``pool``."""
    n = cells.shape[0]
    ranges = _bounds(n, parts)
    if len(ranges) == 1:
        return broadphase.boxes_of(points, cells)
    d = points.shape[1]
    cols = np.ascontiguousarray(points.T, dtype=np.float64)
    lo, hi = np.empty((d, n)), np.empty((d, n))

    def chunk(a: int, b: int) -> None:
        boxes_mod.fill_boxes(cols, np.ascontiguousarray(cells[a:b].T), lo[:, a:b], hi[:, a:b])

    for f in [pool.submit(chunk, a, b) for a, b in ranges]:
        f.result()
    return lo.T, hi.T


def near_flags(lo_a, hi_a, lo_b, hi_b, pad: float, *, pool: Executor, parts: int):
    """:func:`~predicates.registration.broadphase.near_flags` with the a side (the
    simulation cells, the many) in ``parts`` chunks on ``pool``: the same grid (computed
    once), a's occupancy as the ``|`` of its chunks' occupancies, a's flags chunk by
    chunk. Identical flags; falls back to the serial function off the dense grid."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    ranges = _bounds(len(lo_a), parts)
    if len(lo_a) == 0 or len(lo_b) == 0 or len(ranges) == 1:
        return broadphase.near_flags(lo_a, hi_a, lo_b, hi_b, pad)
    _, _, _, G, _, ia0, ia1, ib0, ib1 = _grid(lo_a, hi_a, lo_b, hi_b, pad)
    if not _dense(G + 1, len(lo_a) + len(lo_b)):
        return broadphase.near_flags(lo_a, hi_a, lo_b, hi_b, pad)
    occ_b = pool.submit(_occupancy, ib0, ib1, G)
    occ_a = [pool.submit(_occupancy, ia0[a:b], ia1[a:b], G) for a, b in ranges]
    occ_b = occ_b.result()
    near_a = [pool.submit(_any_in, occ_b, ia0[a:b], ia1[a:b], G) for a, b in ranges]
    occ = occ_a[0].result()
    for f in occ_a[1:]:
        occ |= f.result()
    near_b = _any_in(occ, ib0, ib1, G)
    return np.concatenate([f.result() for f in near_a]), near_b


class _Done:
    """A finished call, shaped like a Future (the serial plan runs each call at once)."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


class Work:
    """How the plan runs its per-cell work: ``boxes`` (as ``cell_boxes``), ``flags`` (as
    ``near_flags``) and ``submit(f, *a)`` (a Future-like). ``Work()`` is the serial
    plan, single-threaded, calls in program order; ``Work(pool, parts)`` the threaded
    one (identical values)."""

    def __init__(self, pool: Executor | None = None, parts: int = 1):
        from functools import partial

        self.pool, self.parts = pool, parts
        if pool is None:
            self.boxes, self.flags = broadphase.boxes_of, broadphase.near_flags
        else:
            self.boxes = partial(boxes, pool=pool, parts=parts)
            self.flags = partial(near_flags, pool=pool, parts=parts)

    def submit(self, f, *args):
        return _Done(f(*args)) if self.pool is None else self.pool.submit(f, *args)


def threads_for(scheduler) -> int:
    """Threads of the client's plan in a partitioned run: the run's workers (a
    ``dask.distributed.Client``: its worker threads; ``"synchronous"``: 1; otherwise the
    CPUs), at most this machine's CPUs (the plan runs here)."""
    import os

    cpus = os.cpu_count() or 1
    if isinstance(scheduler, str):
        return 1 if scheduler == "synchronous" else cpus
    info = getattr(scheduler, "scheduler_info", None)
    if info is None:
        return cpus
    workers = sum(w.get("nthreads", 1) for w in info()["workers"].values())
    return max(1, min(cpus, workers))
