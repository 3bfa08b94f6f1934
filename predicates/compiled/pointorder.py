"""The lexicographic order of points by coordinates (x first, ties by position), compiled:
the rank space's vertex order of :class:`predicates.registration.levels.complex.Side`
(section 1 of the paper: every primitive's vertices ordered by coordinates).

``np.lexsort(P.T[::-1])`` sorts once per coordinate, each a stable (merge) sort of every
point; on points in general position (a cutting surface's) that is ~8x numpy's
vectorized quicksort of the first coordinate. Here: that quicksort, then each run of
points sharing x put in order by the rest of the row, then by position (one pass, by
insertion).
Both order by numpy's comparison (a NaN after every number, NaNs equal, −0.0 equal to
0.0) with ties by position, so the permutation is the same. Points sharing a first
coordinate by the many (a structured grid's: the insertions' work would be quadratic)
go to np.lexsort, whose merges are fast there (benchmarks/README.md, "W1 toward 10x the floor (s18-w1)").
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["lex_point_order"]

#: the insertion's work bound: Σ (runs of equal first coordinates)² ≤ _WORK · points
#: (more: np.lexsort)
_WORK = 16


@njit(**INLINE_OPTIONS)
def _same(a, b):
    return a == b or (a != a and b != b)  # NaNs equal, as numpy's sort sees them


@njit(**INLINE_OPTIONS)
def _less(X, col, i, j):
    """Row i before row j on columns col…, then by position (numpy's order per column:
    NaN last)."""
    for ax in range(col, X.shape[1]):
        a, b = X[i, ax], X[j, ax]
        if a < b or (b != b and a == a):
            return True
        if b < a or (a != a and b == b):
            return False
    return i < j


@njit(**INLINE_OPTIONS)
def _run_end(X, order, col, lo):
    """The end of the run from ``lo`` of rows equal on columns < col."""
    hi = lo + 1
    while hi < order.shape[0]:
        for ax in range(col):
            if not _same(X[order[hi], ax], X[order[lo], ax]):
                return hi
        hi += 1
    return hi


@njit(**JIT_OPTIONS)
def _finish(X, order):
    """``order`` sorted by column 0 (ties in any order): each run of rows equal on
    column 0 put in order by columns 1…, then by position, by insertion — one pass:
    that order is total, so the runs equal on more columns need no pass of their own
    (W1's cutting points: 0.31 -> 0.20 ms; benchmarks/README.md, "W1's broad phase,
    complexes and stage 1"). Returns False (``order`` unchanged) when the runs of
    column 0 are long (_WORK)."""
    lo = work = 0
    while lo < order.shape[0]:
        hi = _run_end(X, order, 1, lo)
        work += (hi - lo) * (hi - lo)
        lo = hi
    if work > _WORK * order.shape[0]:
        return False
    lo = 0
    while lo < order.shape[0]:
        hi = _run_end(X, order, 1, lo)
        for u in range(lo + 1, hi):  # insertion on the rest (then by position)
            x = order[u]
            v = u
            while v > lo and _less(X, 1, x, order[v - 1]):
                order[v] = order[v - 1]
                v -= 1
            order[v] = x
        lo = hi
    return True


def lex_point_order(X: np.ndarray) -> np.ndarray:
    """``np.lexsort(X.T[::-1])`` of the points X (n, d) — lexicographic, x first, ties
    by position — (module docstring): the same permutation (int64)."""
    X = np.ascontiguousarray(X)
    if len(X) < 2 or X.shape[1] == 0:
        return np.arange(len(X), dtype=np.int64)
    step = max(1, len(X) // 1024)  # a sample's repeated x: a grid's (skip the quicksort)
    if len(np.unique(X[::step, 0])) * 4 < len(X[::step]):
        return np.lexsort(X.T[::-1])
    order = np.argsort(X[:, 0]).astype(np.int64, copy=False)  # numpy's: NaN last
    return order if _finish(X, order) else np.lexsort(X.T[::-1])
