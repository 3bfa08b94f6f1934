"""The split's Morton box on a partitioned run's client (benchmarks/README.md "The
2-worker W4 client, sixth pass"): :func:`first_vertex_hull`, the per-axis min and max
of the run cells' first vertices
(:func:`predicates.registration.partition.split_remote.run_hull`) read in place —
numpy gathers an (m, d) copy first, then reduces it column by column (W4's 465 k run
cells: ~24 → ~3.5 ms). No arithmetic, comparisons only: the values are numpy's min and
max (the tests compare them).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS

__all__ = ["first_vertex_hull"]


@njit(**JIT_OPTIONS)
def first_vertex_hull(points, run, lo, hi):
    """``lo``, ``hi`` (d,) of points' dtype: the min and max per axis of
    ``points[run[:, 0]]`` (``run`` (m, k), m ≥ 1, ids validated in range; the points
    finite: the plan checked their scaling, so no NaN needs numpy's propagation)."""
    d = points.shape[1]
    first = np.uint64(run[0, 0])
    for ax in range(d):
        lo[ax] = points[first, ax]
        hi[ax] = points[first, ax]
    for m in range(1, run.shape[0]):
        i = np.uint64(run[m, 0])
        for ax in range(d):
            x = points[i, ax]
            if x < lo[ax]:
                lo[ax] = x
            if x > hi[ax]:
                hi[ax] = x

