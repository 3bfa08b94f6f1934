"""Sorted unique rows of vertex ids (the simplicial complexes' faces,
:func:`predicates.registration.levels.complex.unique_rows`), compiled: a stable
least-significant-column counting sort (radix n, the number of vertices: no comparison
sort) and one pass marking each row that differs from the previous. The unique rows
come out sorted lexicographically with the same inverse map as numpy's argsort of the
packed keys — one answer, whatever the sort — so the complexes are identical.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS

__all__ = ["unique_rows"]


@njit(**JIT_OPTIONS)
def _lex_order(rows, n):
    """Stable lexicographic order of the rows (ids < n), column by column from the last
    (each pass a stable counting sort, so earlier columns decide first)."""
    m, w = rows.shape
    order = np.arange(m)
    tmp = np.empty(m, dtype=np.int64)
    count = np.empty(n + 1, dtype=np.int64)
    for c in range(w - 1, -1, -1):
        count[:] = 0
        for i in range(m):
            count[rows[i, c] + 1] += 1
        for v in range(n):
            count[v + 1] += count[v]
        for i in range(m):
            r = order[i]
            v = rows[r, c]
            tmp[count[v]] = r
            count[v] += 1
        order, tmp = tmp, order
    return order


@njit(**JIT_OPTIONS)
def _mark(rows, order, first, inv):
    """Walk the sorted rows: ``first`` the first row of each distinct value, ``inv``
    each row's rank among the distinct values. Returns the number of distinct rows."""
    m, w = rows.shape
    nu = 0
    for i in range(m):
        r = order[i]
        new = i == 0
        if not new:
            p = order[i - 1]
            for c in range(w):
                if rows[r, c] != rows[p, c]:
                    new = True
                    break
        if new:
            first[nu] = r
            nu += 1
        inv[r] = nu - 1
    return nu


def unique_rows(rows: np.ndarray, n: int):
    """(unique rows sorted lexicographically, inverse map) of ``rows`` (ids < n), as
    :func:`predicates.registration.levels.complex.unique_rows` returns them."""
    rows = np.ascontiguousarray(rows)
    order = _lex_order(rows, n)
    first = np.empty(len(rows), dtype=np.int64)
    inv = np.empty(len(rows), dtype=np.int64)
    nu = _mark(rows, order, first, inv)
    return rows.take(first[:nu], axis=0), inv
