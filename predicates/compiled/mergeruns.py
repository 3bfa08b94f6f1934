"""The partitions' pairs' merge order as runs, compiled (benchmarks/README.md "The
2-worker W4 client, seventh pass"): :func:`merge_runs` is
:func:`predicates.registration.partition.assign.merge_runs`' loop — each step the
partition whose next key is the smallest (ties: the lower partition), its rows up to
the next key of any other partition by a binary search — over the keys concatenated,
with no Python work per run (W4: ~140 runs in each large kind, nine kinds a call).
Integer comparisons only: the same runs, the same refusals.
"""
from __future__ import annotations

from numba import njit

from .build import JIT_OPTIONS

__all__ = ["merge_runs"]


@njit(**JIT_OPTIONS)
def merge_runs(keys, starts, limit, runs):
    """``keys``: every partition's ascending keys concatenated, partition p's at
    [starts[p], starts[p + 1]); ``runs`` (limit, 3) int64 receives (partition, start,
    stop) per run, positions within the partition. Returns the run count, −1 when
    more than ``limit`` runs are needed, −2 when two partitions hold the same key
    (the merge reaches it as both partitions' next key)."""
    k = starts.shape[0] - 1
    heads = starts[:-1].copy()
    count = 0
    while True:
        p, q = -1, -1  # the live partitions with the smallest and the next (key, p)
        for r in range(k):
            if heads[r] == starts[r + 1]:
                continue
            if p < 0 or keys[heads[r]] < keys[heads[p]]:
                p, q = r, p
            elif q < 0 or keys[heads[r]] < keys[heads[q]]:
                q = r
        if p < 0:
            return count
        if count == limit:
            return -1
        end = starts[p + 1]
        if q < 0:
            stop = end
        else:  # the first of p's keys ≥ q's next key (binary search from p's head)
            target = keys[heads[q]]
            a, b = heads[p], end
            while a < b:
                mid = (a + b) // 2
                if keys[mid] < target:
                    a = mid + 1
                else:
                    b = mid
            stop = a
            if stop < end and keys[stop] == target:
                return -2
        runs[count, 0] = p
        runs[count, 1] = heads[p] - starts[p]
        runs[count, 2] = stop - starts[p]
        count += 1
        heads[p] = stop
