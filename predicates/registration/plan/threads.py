"""The global plan's per-cell work on a client thread pool (partitioned runs only, issue
13; docs/partitioned.md). Section 4.1 of the paper needs L over the cells that can meet:
the plan (:func:`predicates.registration.pipeline._plan`) computes it on the client over
all cells, before any partition can start, so in a partitioned run it is the serial
part of the critical path.

The plan's passes over the cells (boxes, grid indices, occupancy, look-ups) run block by
block (:mod:`~predicates.registration.spatial.blocks`) in every run; here the blocks of one span
per thread run concurrently, and independent steps of the plan (the resolution report's
parts) run side by side. Every value is *bit-identical* to the serial plan's: a cell's
box or flag does not depend on the other cells of its block, and the values combined
over spans (occupancy counts, minima, maxima) are exact.
"""
from __future__ import annotations

from concurrent.futures import Executor
from functools import partial

from predicates.registration.spatial import broadphase
from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import boxes_of

__all__ = ["Work", "threads_for"]


class Work:
    """How the plan runs its per-cell work: ``boxes`` (as ``boxes_of``), ``flags`` (as
    ``near_flags``), ``blocks`` (a :class:`~predicates.registration.spatial.blocks.Blocks`) and
    ``submit(f, *a)`` (a Future-like). ``Work()`` is the serial plan, single-threaded,
    calls in program order; ``Work(pool, threads)`` the threaded one (identical values)."""

    def __init__(self, pool: Executor | None = None, threads: int = 1,
                 accelerate: bool | None = False):
        self.pool, self.threads = pool, threads
        self.use_compiled(bool(accelerate))
        self.accelerate = accelerate  # None: decided once the cells are counted

    def use_compiled(self, accelerate: bool) -> None:
        """Run the per-cell passes compiled (``accelerate``) or on numpy: same values."""
        self.accelerate = accelerate
        self.blocks = (SERIAL if self.pool is None and not accelerate
                       else Blocks(self.pool, self.threads, accelerate=accelerate))
        self.boxes = partial(boxes_of, blocks=self.blocks)
        self.flags = partial(broadphase.near_flags, blocks=self.blocks)

    def submit(self, f, *args):
        return self.blocks.submit(f, *args)


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
