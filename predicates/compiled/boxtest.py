"""The broad phase's exact box test, compiled, fused with the expansion of cells into
the faces they own (:mod:`predicates.registration.levels.facepairs`).

The test is :func:`predicates.registration.spatial.broadphase.pair_test`'s, per axis
``F[lo_b − hi_a] ≤ pad`` and ``F[lo_a − hi_b] ≤ pad`` in binary64: one subtraction and one
comparison, so the compiled loop keeps exactly the same pairs (a NaN fails both ways),
and in the same order (cells in order, then their faces' columns, as ``_owned``
enumerates them and the numpy test's compaction keeps them). No temporary the size of
the proposals: only the kept pairs are written.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .buffers import buffer
from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["owned_pairs", "pair_test"]


@njit(**INLINE_OPTIONS)
def _near(pad, lo_a, hi_a, lo_b, hi_b, a, b):
    for ax in range(lo_a.shape[0]):
        if not lo_b[ax, b] - hi_a[ax, a] <= pad:
            return False
        if not lo_a[ax, a] - hi_b[ax, b] <= pad:
            return False
    return True


@njit(**JIT_OPTIONS)
def _pairs(pad, lo_a, hi_a, lo_b, hi_b, ia, ib, pos):
    count = 0
    for q in range(ia.shape[0]):
        if _near(pad, lo_a, hi_a, lo_b, hi_b, ia[q], ib[q]):
            pos[count] = q
            count += 1
    return count


@njit(**JIT_OPTIONS)
def _owned(tab, A, B, faces_of_a, pad, lo_a, hi_a, lo_b, hi_b, out_a, out_b):
    count = 0
    for q in range(A.shape[0]):
        for k in range(tab.shape[1]):
            if faces_of_a:  # a: every face of A[q]; b = B[q]
                a, b = tab[A[q], k], B[q]
                face = a
            else:  # a = A[q]; b: every face of B[q]
                a, b = A[q], tab[B[q], k]
                face = b
            if face >= 0 and _near(pad, lo_a, hi_a, lo_b, hi_b, a, b):
                out_a[count] = a
                out_b[count] = b
                count += 1
    return count


def pair_test(pad: float, lo_a, hi_a, lo_b, hi_b, ia: np.ndarray, ib: np.ndarray):
    """Positions of the pairs (ia, ib) passing the test; boxes as (d, n) columns
    (:func:`~predicates.registration.spatial.broadphase.pair_test`, compiled)."""
    pos = np.empty(len(ia), dtype=np.int64)
    n = _pairs(float(pad), lo_a, hi_a, lo_b, hi_b, ia, ib, pos)
    return pos[:n]


def owned_pairs(tab: np.ndarray, side: str, A: np.ndarray, B: np.ndarray, pad: float,
                boxes_a: tuple, boxes_b: tuple):
    """The pairs (a, b) passing the test at ``pad``, ``side`` "a": a every face
    ``tab[A[q]]`` owns (≥ 0) and b = B[q]; "b": a = A[q] and b every face of
    ``tab[B[q]]``. ``boxes_*``: (lo, hi) as (d, n) columns. Returns (a, b)."""
    n = len(A) * tab.shape[1]
    out_a, out_b = buffer("owned_a", n, np.int64), buffer("owned_b", n, np.int64)
    k = _owned(tab, A, B, side == "a", float(pad), *boxes_a, *boxes_b, out_a, out_b)
    return out_a[:k].copy(), out_b[:k].copy()


@njit(**JIT_OPTIONS)
def _join(sa, ca, sb, q_cell, ma, mb, full, gbox_a, gbox_b, pad, lo_a, hi_a, lo_b, hi_b,
          out_a, out_b):
    count = 0
    for k in range(sa.shape[0]):
        for ea in range(sa[k], sa[k] + ca[k]):
            for eb in range(sb[k], sb[k] + q_cell[k]):
                if full >= 0 and (ma[ea] | mb[eb]) != full:
                    continue
                a, b = gbox_a[ea], gbox_b[eb]
                if _near(pad, lo_a, hi_a, lo_b, hi_b, a, b):
                    out_a[count] = a
                    out_b[count] = b
                    count += 1
    return count


def join(sa, ca, sb, q_cell, masks, gbox_a, gbox_b, pad: float, cols: tuple):
    """:func:`predicates.registration.spatial.broadphase._join`'s pairs, compiled: for
    every shared cell k, entries sa[k] … of side a against q_cell[k] entries from sb[k]
    of side b, a before b, kept when their start masks make the cell the lower corner
    of the overlap (``masks`` = (ma, mb, full) or None) and the boxes pass the test;
    ``cols`` = (lo_a, hi_a, lo_b, hi_b) as (d, n) columns. Returns (ia, ib)."""
    n = int((ca.astype(np.int64) * q_cell).sum())  # the proposals (integers: exact)
    out_a, out_b = buffer("join_a", n, np.int64), buffer("join_b", n, np.int64)
    if masks is None:
        empty = np.zeros(1, dtype=np.uint8)
        ma, mb, full = empty, empty, -1
    else:
        ma, mb, full = masks
    k = _join(sa, ca, sb, q_cell, ma, mb, int(full), gbox_a, gbox_b, float(pad), *cols,
              out_a, out_b)
    return out_a[:k].copy(), out_b[:k].copy()
