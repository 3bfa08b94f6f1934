"""Sorting integer ids the way the split needs it, fast in numpy (docs/split.md,
"Implementation"): the same orders as ``np.sort`` / ``np.argsort(kind="stable")``, with
cheaper passes.

* Rows of 2–4 ids (an edge, a face, a cell) are sorted by a sorting network of
  column-wise ``minimum`` / ``maximum`` instead of ``np.sort(axis=1)``, which pays a call
  per row; the stable argsort of a row sorts ``id·w + position`` (distinct in a row).
* A stable lexicographic order of many rows packs (column values, current position) into
  one int64 per row and sorts those with ``np.sort`` (no argsort: the position rides in
  the low bits, so the packed keys are distinct and the order is stable), one pass per
  group of columns, least significant first (LSD radix).
* The first occurrence of each distinct key (``np.unique(..., return_index=True)``)
  likewise by one ``np.sort`` of (key, position).

Integers only: every comparison is exact, so each result equals its numpy reference
whatever the order of the passes.
"""
from __future__ import annotations

import numpy as np

__all__ = ["sort_rows", "argsort_rows", "lexsort_rows", "unique_first"]

#: Compare-exchange networks (column pairs) sorting rows of w = 2, 3, 4 values.
NETWORKS = {1: (), 2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 1)),
            4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2))}


def _bits(x: int) -> int:
    """Bits needed for the values 0..x."""
    return max(int(x).bit_length(), 1)


def sort_rows(x: np.ndarray) -> np.ndarray:
    """``np.sort(x, axis=-1)`` for integer arrays whose last axis has 1–4 entries, by a
    sorting network on the columns (any other width: ``np.sort``)."""
    x = np.asarray(x)
    w = x.shape[-1]
    if w not in NETWORKS or x.dtype.kind not in "iu":
        return np.sort(x, axis=-1)
    cols = [x[..., j].copy() for j in range(w)]
    for i, j in NETWORKS[w]:
        lo = np.minimum(cols[i], cols[j])
        np.maximum(cols[i], cols[j], out=cols[j])
        cols[i] = lo
    return np.stack(cols, axis=-1)


def argsort_rows(x: np.ndarray) -> np.ndarray:
    """``np.argsort(x, axis=1, kind="stable")`` for (k, w) arrays of non-negative ids,
    w ≤ 4: the network sorts ``id·w + position``, distinct within a row, so ties keep
    their positions."""
    x = np.asarray(x)
    k, w = x.shape
    if w not in NETWORKS or x.dtype.kind not in "iu" or (k and (
            int(x.min()) < 0 or _bits(int(x.max())) + _bits(w) > 62)):
        return np.argsort(x, axis=1, kind="stable")
    return sort_rows(x.astype(np.int64) * w + np.arange(w)) % w


def lexsort_rows(rows: np.ndarray, n: int) -> np.ndarray:
    """The stable order of the rows of ``rows`` (k, w), ids in 0..n−1, by their columns
    from the first: ``np.lexsort`` of the columns reversed (ties by position), i.e. the
    stable argsort of :func:`~.rules.row_keys`. LSD radix: each pass sorts one packed
    int64 of (the values of a group of columns, the row's current rank) with
    ``np.sort``; rows too wide for one int64 per column fall back to ``np.lexsort``."""
    rows = np.asarray(rows, dtype=np.int64)
    k, w = rows.shape
    order = np.arange(k, dtype=np.int64)
    if k <= 1 or w == 0:
        return order
    b_id, b_pos = _bits(max(n - 1, 0)), _bits(k - 1)
    per_pass = (63 - b_pos) // b_id
    if per_pass < 1:
        return np.lexsort(rows.T[::-1])
    mask, rank = (1 << b_pos) - 1, np.arange(k, dtype=np.int64)
    for hi in range(w, 0, -per_pass):  # the least significant columns first
        key = np.zeros(k, dtype=np.int64)
        for c in range(max(hi - per_pass, 0), hi):
            key <<= b_id
            # a contiguous column and np.take: a 2D fancy gather is ~10x slower
            key |= np.take(np.ascontiguousarray(rows[:, c]), order)
        key <<= b_pos
        key |= rank  # the row's current rank: the packed keys are distinct, stable
        key.sort()
        order = np.take(order, key & mask)
    return order


def unique_first(key: np.ndarray) -> np.ndarray:
    """``np.unique(key, return_index=True)[1]`` for non-negative int64 keys: the first
    position of each distinct key, by increasing key. One ``np.sort`` of (key,
    position) packed in an int64 when they fit, else ``np.unique``."""
    key = np.asarray(key, dtype=np.int64)
    k = len(key)
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    b_pos = _bits(k - 1)
    if int(key.min()) < 0 or _bits(int(key.max())) + b_pos > 63:
        return np.unique(key, return_index=True)[1]
    packed = (key << b_pos) | np.arange(k, dtype=np.int64)
    packed.sort()
    val = packed >> b_pos
    new = np.ones(k, dtype=bool)
    np.not_equal(val[1:], val[:-1], out=new[1:])
    return packed[new] & ((1 << b_pos) - 1)
