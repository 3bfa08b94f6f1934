"""How many partitions a run makes and how many run at once (docs/partitioned.md 2,
5: "auto", the memory guard's share)."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["CELLS_PER_PART", "count_partitions", "slots"]

#: "auto" makes at least one partition per this many simulation cells
CELLS_PER_PART = 1_000_000


def slots(client, scheduler) -> int:
    """Partitions that can run at once: the cluster's worker threads, one for the
    synchronous scheduler, the CPUs for the other local schedulers."""
    if client is not None:
        return max(1, sum(w["nthreads"] for w in client.scheduler_info()["workers"].values()))
    return 1 if scheduler == "synchronous" else os.cpu_count() or 1


def count_partitions(partitions, client, n_cells: int) -> int:
    """The number of partitions a run makes: ``partitions`` checked, or "auto" (one per
    worker slot and at least one per CELLS_PER_PART cells), never more than the cells."""
    if isinstance(partitions, str) and partitions == "auto" or partitions is None:
        workers = slots(client, "threads")
        return max(1, min(n_cells, max(workers, -(-n_cells // CELLS_PER_PART))))
    if isinstance(partitions, (bool, np.bool_)) or not isinstance(partitions, (int, np.integer)):
        raise TypeError(f"partitions must be a positive int or 'auto', got {partitions!r}")
    if partitions < 1:
        raise ValueError(f"partitions must be at least 1, got {partitions}")
    return int(max(1, min(partitions, n_cells)))
