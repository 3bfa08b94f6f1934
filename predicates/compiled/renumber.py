"""A partitioned run's cells renumbered into the positions of their vertex ids among
the run's vertices (:func:`predicates.registration.plan.inputs.renumbered`), compiled:
``np.searchsorted(vertices, cells)``'s integers without a binary search over the whole
of ``vertices`` per id.

Why (benchmarks/README.md, "Plan passes, ninth pass"): on W4's client 1.9 M ids are
searched among 117 k vertices, ~75–95 ms of numpy's binary searches. Here the ids'
range [vertices[0], vertices[-1]] is cut into as many equal buckets as there are
vertices; one pass over ``vertices`` records where each bucket starts, and an id's
position is then searched only between its bucket's start and the next one's — a few
entries when the ids are spread evenly, never more than a binary search of the whole.
The table has one entry per run vertex: nothing per point of the mesh (the client
holds nothing per point, docs/partitioned.md 6). Integers only: the left insertion
point of every id, as numpy's.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS

__all__ = ["bucket_starts", "search_left", "searched"]


@njit(**JIT_OPTIONS)
def bucket_starts(vertices, width, starts):
    """``starts[b]`` = the first position p with vertices[p] ≥ vertices[0] + b·width
    (len(vertices) if none), for every bucket b of ``starts`` (ascending ``vertices``)."""
    base = vertices[0]
    p = 0
    n = vertices.shape[0]
    for b in range(starts.shape[0]):
        bound = base + b * width
        while p < n and vertices[p] < bound:
            p += 1
        starts[b] = p


@njit(**JIT_OPTIONS)
def search_left(vertices, width, starts, ids, out):
    """``out`` = np.searchsorted(vertices, ids) (left) for the ids (m, k): each id's
    position searched between its bucket's start and the next bucket's
    (:func:`bucket_starts`)."""
    base = vertices[0]
    n = vertices.shape[0]
    last = vertices[n - 1]
    for r in range(ids.shape[0]):
        for c in range(ids.shape[1]):
            x = ids[r, c]
            if x <= base:
                out[r, c] = 0
                continue
            if x > last:
                out[r, c] = n
                continue
            b = (x - base) // width
            lo = starts[b]  # vertices[lo − 1] < base + b·width ≤ x
            hi = starts[b + 1]  # vertices[hi] ≥ base + (b + 1)·width > x (or hi = n)
            while lo < hi:  # the first position in [lo, hi] holding a value ≥ x
                mid = (lo + hi) >> 1
                if vertices[mid] < x:
                    lo = mid + 1
                else:
                    hi = mid
            out[r, c] = lo


def searched(vertices: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """np.searchsorted(``vertices``, ``cells``) (module docstring), int32 below 2^31
    vertices as ``inputs.renumbered`` gives it: ``vertices`` ascending int64, not
    empty; ``cells`` (m, k) signed integers."""
    n = len(vertices)
    span = int(vertices[-1]) - int(vertices[0]) + 1
    width = max(1, -(-span // n))  # ceil: n buckets cover the range
    starts = np.empty(n + 1, dtype=np.int64)
    bucket_starts(vertices, width, starts)
    out = np.empty(cells.shape, dtype=np.int32 if n < 2 ** 31 else np.int64)
    search_left(vertices, width, starts, cells, out)
    return out
