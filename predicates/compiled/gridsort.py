"""The cell-level broad phase's sort of grid entries, compiled: a counting sort over a
dense grid (:func:`predicates.registration.spatial.broadphase._level`, its dense case).

The numpy path drops the entries alone in their cell (no entry of the other side there),
sorts the rest by cell key with a *stable* argsort and cuts the sorted keys into runs.
Here both sides are counted per cell, the shared cells enumerated in key order and each
kept entry placed at its cell's next slot in entry order — a stable counting sort:
the same permutation (keys ascending, ties by entry index), the same runs, in
O(entries + cells) without a comparison sort.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS

__all__ = ["shared_runs"]


@njit(**JIT_OPTIONS)
def _count(keys, counts):
    for e in range(keys.shape[0]):
        counts[keys[e]] += 1


@njit(**JIT_OPTIONS)
def _starts(count_a, count_b, cells, sa, ca, sb, cb):
    """The shared cells in key order with their runs' starts and lengths; each
    shared cell's counts become its next free slot, the others −1. Returns the number
    of shared cells."""
    k = 0
    pa = 0
    pb = 0
    for c in range(count_a.shape[0]):
        if count_a[c] > 0 and count_b[c] > 0:
            cells[k] = c
            sa[k], ca[k], sb[k], cb[k] = pa, count_a[c], pb, count_b[c]
            pa += count_a[c]
            pb += count_b[c]
            count_a[c], count_b[c] = sa[k], sb[k]
            k += 1
        else:
            count_a[c] = -1
            count_b[c] = -1
    return k


@njit(**JIT_OPTIONS)
def _place(keys, slot, order):
    """order[slot[key]++] = entry, for the entries whose cell is shared, in entry
    order (stable)."""
    for e in range(keys.shape[0]):
        c = keys[e]
        if slot[c] >= 0:
            order[slot[c]] = e
            slot[c] += 1


def shared_runs(key_a: np.ndarray, key_b: np.ndarray, ncells: int):
    """(oa, ob, (cells, sa, ca, sb, cb)): the entries of each side whose cell (a key
    < ``ncells``) holds an entry of the other side, as positions sorted by key then
    position (``np.flatnonzero(kept)[np.argsort(key[kept], kind="stable")]``), and the
    shared cells (ascending) with each side's run start and length in that order."""
    # counts never exceed the entries: int32 halves the grid's memory when they fit
    dt = np.int32 if max(len(key_a), len(key_b)) < 2 ** 31 else np.int64
    count_a, count_b = np.zeros(ncells, dtype=dt), np.zeros(ncells, dtype=dt)
    _count(key_a, count_a)
    _count(key_b, count_b)
    m = int(min(np.count_nonzero(count_a), np.count_nonzero(count_b)))
    cells, sa, ca, sb, cb = (np.empty(m, dtype=np.int64) for _ in range(5))
    k = _starts(count_a, count_b, cells, sa, ca, sb, cb)
    na = int(sa[k - 1] + ca[k - 1]) if k else 0
    nb = int(sb[k - 1] + cb[k - 1]) if k else 0
    oa, ob = np.empty(na, dtype=np.int64), np.empty(nb, dtype=np.int64)
    _place(key_a, count_a, oa)
    _place(key_b, count_b, ob)
    return oa, ob, (cells[:k], sa[:k], ca[:k], sb[:k], cb[:k])
