"""The broad phase's exact box test, compiled, fused with the expansion of cells into
the faces they own (:mod:`predicates.registration.levels.facepairs`).

The test is :func:`predicates.registration.spatial.broadphase.pair_test`'s, per axis
``F[lo_b − hi_a] ≤ pad`` and ``F[lo_a − hi_b] ≤ pad`` in binary64: one subtraction and one
comparison, so the compiled loop keeps exactly the same pairs (a NaN fails both ways),
and in the same order (cells in order, then their faces' columns, as ``_owned``
enumerates them and the numpy test's compaction keeps them) — except stage 1
(:func:`predicates.compiled.stage1.owned_levels`), which lists a cell's pairs face by
face. No temporary the size of the proposals: only the kept pairs are written.
"""
from __future__ import annotations

import weakref

import numpy as np
from numba import njit

from .buffers import buffer
from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["boxes", "join", "owned_lists", "owned_lists_of", "owned_pairs", "pair_test",
           "renumbered"]


@njit(**INLINE_OPTIONS)
def _near(pad, lo_a, hi_a, lo_b, hi_b, a, b):
    for ax in range(lo_a.shape[0]):
        if not lo_b[ax, b] - hi_a[ax, a] <= pad:
            return False
        if not lo_a[ax, a] - hi_b[ax, b] <= pad:
            return False
    return True


@njit(**JIT_OPTIONS)
def _fill_boxes(P, R, lo, hi):
    """lo, hi (d, m) of the simplices R (m, k) over the points P (N, d): boxes_of's
    minimum/maximum fold per axis (a NaN propagates; each coordinate converted to
    binary64 exactly), the vertex ids read as unsigned (no wraparound test a gather)."""
    for m in range(R.shape[0]):
        for ax in range(P.shape[1]):
            a = np.float64(P[np.uint64(R[m, 0]), ax])
            b = a
            for v in range(1, R.shape[1]):
                x = np.float64(P[np.uint64(R[m, v]), ax])
                a = a if (a < x) | (a != a) else x  # np.minimum's choice (cells.py)
                b = b if (b > x) | (b != b) else x
            lo[ax, m], hi[ax, m] = a, b


def boxes(points: np.ndarray, rows: np.ndarray) -> tuple:
    """:func:`predicates.registration.spatial.boxes.boxes_of` (lo, hi as (n, d) views of
    (d, n) arrays), the same values, in one compiled call on whole contiguous arrays:
    the block-by-block kernel gets strided views of its outputs (numba's generic layout,
    W1's 71 k cells 2.0 -> 0.7 ms; benchmarks/README.md, "Part 2, fourteenth pass")."""
    rows = np.ascontiguousarray(rows)
    lo, hi = np.empty((points.shape[1], len(rows))), np.empty((points.shape[1], len(rows)))
    if len(rows):
        _fill_boxes(np.ascontiguousarray(points), rows, lo, hi)
    return lo.T, hi.T


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


_OWNED: dict = {}  # id(owned table) -> (weak reference to it, start, faces)


def owned_lists(tab: np.ndarray) -> tuple:
    """The owned table ``tab`` (cells × faces, −1: not owned) as lists: (start, faces),
    cell c's owned faces ``faces[start[c]:start[c + 1]]`` in the table's column order
    (the kernels then visit only owned faces: on the vertex levels most slots of the
    table are −1). Kept while the table lives (FacePairs keeps its tables)."""
    hit = _OWNED.get(id(tab))
    if hit is not None and hit[0]() is tab:
        return hit[1], hit[2]
    keep = tab >= 0
    start = np.zeros(len(tab) + 1, dtype=np.int64)
    np.cumsum(keep.sum(axis=1), out=start[1:])
    faces = np.ascontiguousarray(tab[keep], dtype=np.int64)  # row-major: column order
    _OWNED[id(tab)] = (weakref.ref(tab), start, faces)
    weakref.finalize(tab, _OWNED.pop, id(tab), None)
    return start, faces


@njit(**JIT_OPTIONS)
def _owned_lists_of(F, owner, start, faces, cols):
    """owner[g]: the last cell (in row order) holding face g; then each cell's faces
    it owns, in column order, and their columns when ``cols`` is not empty. Returns
    the number of faces written."""
    n, m = F.shape
    for r in range(n):
        for k in range(m):
            owner[np.uint64(F[r, k])] = r  # unsigned: no wraparound test a scatter
    count = 0
    for r in range(n):
        for k in range(m):
            if owner[np.uint64(F[r, k])] == r:
                faces[count] = F[r, k]
                if cols.shape[0]:
                    cols[count] = k
                count += 1
        start[r + 1] = count
    return count


def owned_lists_of(F: np.ndarray, n_faces: int, columns: bool = False) -> tuple:
    """``owned_lists(owned_table(F, n_faces))`` in two compiled passes over ``F``
    (n_cells, m; the face ids of each cell), without the table or its temporaries: the
    same owner (the last cell holding the face in row order, numpy's fancy assignment)
    and the same lists. Returns (start, faces, the most faces one cell owns), and
    ``columns``: each listed face's column in ``F`` (uint8, m ≤ 256; stage 1 folds a
    face's box from its cell's vertices, :mod:`.stage1`)."""
    F = np.ascontiguousarray(F)
    if columns and F.shape[1] > 256:
        raise ValueError(f"owned_lists_of lists the columns of at most 256, got {F.shape[1]}")
    owner = np.empty(n_faces, dtype=np.int64)
    start = np.zeros(len(F) + 1, dtype=np.int64)
    faces = np.empty(F.size, dtype=np.int64)  # pages past the count never touched
    cols = np.empty(F.size if columns else 0, dtype=np.uint8)
    n = _owned_lists_of(F, owner, start, faces, cols) if F.size else 0
    widest = int(np.diff(start).max()) if len(F) else 0
    return (start, faces[:n], widest) + ((cols[:n],) if columns else ())


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


@njit(**JIT_OPTIONS)
def _renumbered_ascending(ids, keep, out):
    """When ``ids`` ascend: keep[x] for every value x, out[q] the number of distinct
    values before ids[q] (its rank among the kept ones) — one pass, no table; returns
    False at the first descent (keep then partly written)."""
    count, prev = -1, -1  # ids ≥ 0
    for q in range(ids.shape[0]):
        x = ids[q]
        if x != prev:
            if x < prev:
                return False
            keep[np.uint64(x)] = True  # unsigned: no wraparound test a scatter
            count, prev = count + 1, x
        out[q] = count
    return True


@njit(**JIT_OPTIONS)
def _renumbered(ids, keep, new, out):
    """keep[x] for every x in ``ids``; then out[q] the position of ids[q]'s value among
    the kept ones (``new``: scratch of len(keep))."""
    for q in range(ids.shape[0]):
        keep[np.uint64(ids[q])] = True  # unsigned: no wraparound test a scatter
    count = 0
    for x in range(keep.shape[0]):
        new[x] = count
        count += keep[x]
    for q in range(ids.shape[0]):
        out[q] = new[np.uint64(ids[q])]


def renumbered(ids: np.ndarray, n: int) -> tuple:
    """(keep, out): the mask (n,) of the values in ``ids`` (< n) and a fresh array of
    their length and dtype holding each value's position among the kept ones —
    ``(keep, (np.cumsum(keep) - 1).take(ids))`` without its temporaries; ascending ids
    (the cell join's a side) in one pass with no table, and no copy after it (W1's
    421 k cell pairs: benchmarks/README.md, "W1's broad phase, complexes and stage
    1")."""
    keep, out = np.zeros(n, dtype=bool), np.empty_like(ids)
    if len(ids) and not _renumbered_ascending(ids, keep, out):
        keep[:] = False
        _renumbered(ids, keep, np.empty(n, dtype=ids.dtype), out)
    return keep, out
