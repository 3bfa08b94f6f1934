"""The broad phase's dense top grid joined in one compiled pass
(:func:`predicates.registration.spatial.broadphase.box_pairs`' pairs, a ascending):
the b boxes bucketed by cell (a counting sort), then per a box the b boxes of its
cells, each pair kept in the cell of the lower corner of the two ranges' overlap and
when it passes :mod:`.boxtest`'s exact test.

An a box equal to the previous one (all its bounds: a structured mesh's cells often
share a box, e.g. the six Kuhn tetrahedra of a cube, consecutive in rank order) has the
same cells, proposals and tests, so the previous box's pairs are repeated with its id
— the same pairs in the same order, without the proposals (docs/design.md, "Compiled
candidate chain"; benchmarks/README.md, "Part 2, tenth pass").
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .boxtest import _near
from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["covered_cells", "grid_join"]


@njit(**INLINE_OPTIONS)
def _cell_key(i0, r, off, G):
    """Linear key (axis 0 fastest, as broadphase._linear) of cell i0[r] + off."""
    key = 0
    for ax in range(i0.shape[1] - 1, -1, -1):
        key = key * G[ax] + i0[r, ax] + off[ax]
    return key


@njit(**INLINE_OPTIONS)
def _next(off, ext):
    """Advance the odometer ``off`` over the cell range extents ``ext``; False: done."""
    for ax in range(off.shape[0]):
        off[ax] += 1
        if off[ax] < ext[ax]:
            return True
        off[ax] = 0
    return False


@njit(**INLINE_OPTIONS)
def _prefix_sum(start):
    """The counts of the first pass turned into each cell's first offset (in place)."""
    for k in range(1, start.shape[0]):
        start[k] += start[k - 1]


@njit(**INLINE_OPTIONS)
def _unshift(start):
    """Placing advanced every cell's offset to the next cell's: shift them back."""
    for k in range(start.shape[0] - 1, 0, -1):
        start[k] = start[k - 1]
    start[0] = 0


@njit(**JIT_OPTIONS)
def _bucket_b(ib0, ib1, G, start, ids, first):
    """Counting sort of the b boxes into the dense grid's cells: ``start`` (cells + 1)
    their CSR offsets, ``ids`` the boxes of each cell in ascending order, ``first``
    per entry the axes on which the cell is its box's first (bit ax)."""
    d = ib0.shape[1]
    off = np.zeros(d, dtype=np.int64)
    ext = np.empty(d, dtype=np.int64)
    for fill in range(2):  # 0: count, 1: place
        for b in range(ib0.shape[0]):
            for ax in range(d):
                ext[ax] = ib1[b, ax] - ib0[b, ax] + 1
                off[ax] = 0
            while True:
                key = _cell_key(ib0, b, off, G)
                if fill:
                    bits = 0
                    for ax in range(d):
                        if off[ax] == 0:
                            bits |= 1 << ax
                    ids[start[key]] = b
                    first[start[key]] = bits
                    start[key] += 1
                else:
                    start[key + 1] += 1
                if not _next(off, ext):
                    break
        if not fill:
            _prefix_sum(start)
    _unshift(start)


@njit(**INLINE_OPTIONS)
def _same_box(lo_a, hi_a, a, p):
    """Boxes a and p equal on every bound (== : a NaN bound is never equal, −0.0 and
    0.0 are, which no subtraction-and-comparison of the test tells apart)."""
    for ax in range(lo_a.shape[0]):
        if lo_a[ax, a] != lo_a[ax, p] or hi_a[ax, a] != hi_a[ax, p]:
            return False
    return True


@njit(**INLINE_OPTIONS)
def _entries(e_lo, e_hi, bits, full, ids, first, pad, lo_a, hi_a, lo_b, hi_b, a, box,
             unrolled, three, count, out_a, out_b):
    """The pairs of a box ``a`` (``box``: its bounds l0, u0, l1, u1, l2, u2) with the
    entries [e_lo, e_hi) of one cell (``bits``: the axes on which the cell is a's first)
    whose lower overlap corner it is and that pass the test; returns the new count."""
    l0, u0, l1, u1, l2, u2 = box
    for e in range(np.uint64(e_lo), np.uint64(e_hi)):
        if (bits | first[e]) != full:
            continue
        b = np.uint64(ids[e])
        if unrolled:  # _near's subtractions and comparisons, in its order
            near = (lo_b[0, b] - u0 <= pad and l0 - hi_b[0, b] <= pad
                    and lo_b[1, b] - u1 <= pad and l1 - hi_b[1, b] <= pad and (
                        not three or (lo_b[2, b] - u2 <= pad
                                      and l2 - hi_b[2, b] <= pad)))
        else:
            near = _near(pad, lo_a, hi_a, lo_b, hi_b, a, b)
        if near:
            if count < out_a.shape[0]:
                out_a[np.uint64(count)] = a
                out_b[np.uint64(count)] = b
            count += 1
    return count


@njit(**JIT_OPTIONS)
def _grid_join(ia0, ia1, G, start, ids, first, pad, lo_a, hi_a, lo_b, hi_b, limit,
               out_a, out_b):
    """Every pair (a, b) sharing a cell whose lower overlap corner max(ia0[a], ib0[b]) is
    that cell (so once) and passing the box test, a ascending; written when ``out_a``
    is long enough. The cell lies in both ranges, so it is that corner when on every
    axis it is a's first or b's first (``first``: b's, per entry): no read of b's
    range. An a box equal to the previous one repeats its pairs (module docstring).
    In 3D the cells are walked by three written-out loops (axis 0 fastest, as the
    odometer). Returns (pairs, proposals), or (-1, proposals) past ``limit`` proposals
    (the caller falls back to broadphase.box_pairs)."""
    d = ia0.shape[1]
    full = (1 << d) - 1
    off = np.zeros(d, dtype=np.int64)
    ext = np.empty(d, dtype=np.int64)
    count = proposals = 0
    prev_lo = prev_hi = prev_props = 0  # the previous a box's pairs [prev_lo, prev_hi)
    three, unrolled = d == 3, d == 2 or d == 3
    g0, g1 = G[0], G[min(1, d - 1)]
    for a in range(ia0.shape[0]):
        if a > 0 and _same_box(lo_a, hi_a, a, a - 1):  # the same cells and tests
            proposals += prev_props
            if proposals > limit:
                return -1, proposals
            for k in range(prev_lo, prev_hi):
                if count < out_a.shape[0]:  # k < count: written when count is
                    out_a[np.uint64(count)] = a  # unsigned: no wraparound test
                    out_b[np.uint64(count)] = out_b[np.uint64(k)]
                count += 1
            prev_lo, prev_hi = prev_hi, count
            continue
        prev_lo, prev_props = count, proposals
        # a's box held, the test written out (d = 2, 3; W4 ~15 % faster than _near)
        box = (lo_a[0, a], hi_a[0, a], lo_a[1 if unrolled else 0, a],
               hi_a[1 if unrolled else 0, a], lo_a[2 if three else 0, a],
               hi_a[2 if three else 0, a])
        if three:  # (an odometer over arrays: ~3x the walk's time, s23-w1)
            c0, c1, c2 = np.int64(ia0[a, 0]), np.int64(ia0[a, 1]), np.int64(ia0[a, 2])
            for z in range(np.int64(ia1[a, 2]) - c2 + 1):
                for y in range(np.int64(ia1[a, 1]) - c1 + 1):
                    base = ((c2 + z) * g1 + c1 + y) * g0 + c0
                    yz = (1 << 1 if y == 0 else 0) | (1 << 2 if z == 0 else 0)
                    for x in range(np.int64(ia1[a, 0]) - c0 + 1):
                        key = np.uint64(base + x)
                        proposals += start[key + np.uint64(1)] - start[key]
                        if proposals > limit:
                            return -1, proposals
                        count = _entries(start[key], start[key + np.uint64(1)],
                                         yz | (1 if x == 0 else 0), full, ids, first, pad,
                                         lo_a, hi_a, lo_b, hi_b, a, box, unrolled, three,
                                         count, out_a, out_b)
        else:
            for ax in range(d):
                ext[ax] = ia1[a, ax] - ia0[a, ax] + 1
                off[ax] = 0
            while True:
                key = _cell_key(ia0, a, off, G)
                proposals += start[key + 1] - start[key]
                if proposals > limit:
                    return -1, proposals
                bits = 0
                for ax in range(d):
                    if off[ax] == 0:
                        bits |= 1 << ax
                count = _entries(start[key], start[key + 1], bits, full, ids, first, pad,
                                 lo_a, hi_a, lo_b, hi_b, a, box, unrolled, three, count,
                                 out_a, out_b)
                if not _next(off, ext):
                    break
        prev_hi, prev_props = count, proposals - prev_props
    return count, proposals


@njit(**JIT_OPTIONS)
def _bucket_b3(ib0, ib1, G, start, ids, first):
    """:func:`_bucket_b` in 3D, the cells walked by three written-out loops (axis 0
    fastest, as the odometer): the same offsets, entries and bits (W1's 70 k entries
    ~2.3 -> ~0.7 ms; benchmarks/README.md, "s23-w1")."""
    g0, g1 = G[0], G[1]
    for fill in range(2):  # 0: count, 1: place
        for b in range(ib0.shape[0]):
            c0, c1, c2 = np.int64(ib0[b, 0]), np.int64(ib0[b, 1]), np.int64(ib0[b, 2])
            for z in range(np.int64(ib1[b, 2]) - c2 + 1):
                for y in range(np.int64(ib1[b, 1]) - c1 + 1):
                    base = ((c2 + z) * g1 + c1 + y) * g0 + c0
                    yz = np.uint8((2 if y == 0 else 0) | (4 if z == 0 else 0))
                    for x in range(np.int64(ib1[b, 0]) - c0 + 1):
                        key = np.uint64(base + x)  # unsigned: no wraparound tests
                        if fill:
                            at = np.uint64(start[key])
                            ids[at] = b
                            first[at] = yz | np.uint8(1 if x == 0 else 0)
                            start[key] = at + np.uint64(1)
                        else:
                            start[key + np.uint64(1)] += 1
        if not fill:
            _prefix_sum(start)
    _unshift(start)


def grid_join(ranges: tuple, G: np.ndarray, pad: float, cols: tuple, limit: int):
    """:func:`predicates.registration.spatial.broadphase.box_pairs`' pairs on its dense
    top grid, compiled, without sorting: the b boxes bucketed by cell (counting sort),
    then per a box its cells' b boxes, each pair kept in the cell of the lower corner
    of the two ranges' overlap and when it passes the exact test. ``ranges`` = (ia0,
    ia1, ib0, ib1) (b enlarged by pad), ``cols`` = (lo_a, hi_a, lo_b, hi_b) as (d, n)
    columns. Returns (ia, ib), a ascending, or None past ``limit`` proposals."""
    ia0, ia1, ib0, ib1 = ranges
    G = np.asarray(G, dtype=np.int64)
    # the entries: covered_cells' exact sum (numpy's product along rows of 3: ~10x)
    n_entries = covered_cells(ib0, ib1)
    # int32 offsets and ids when they fit: the bucketing scatters into them and the
    # join reads them at random, so half the bytes keep more of them in cache (W1's
    # 55 k cells and 70 k entries: 1 MB -> 0.5 MB; benchmarks/README.md, "W1's cell
    # broad phase and stage 1")
    small = np.int32 if n_entries < 2 ** 31 else np.int64
    start = np.zeros(int(np.prod(G)) + 1, dtype=small)
    ids = np.empty(n_entries, dtype=small)
    first = np.empty(n_entries, dtype=np.uint8)
    (_bucket_b3 if ib0.shape[1] == 3 else _bucket_b)(ib0, ib1, G, start, ids, first)
    guess = max(1 << 16, 8 * (len(ia0) + len(ib0)))  # pairs: a few per box, typically
    while True:
        # fresh arrays returned as views, not a reused buffer copied out: the pages
        # past the pairs written are never touched (W4: 4.5 M pairs, 72 MB not copied)
        out_a, out_b = (np.empty(guess, np.int32 if len(x) < 2 ** 31 else np.int64)
                        for x in (ia0, ib0))  # int32 when they fit: half the memory
        n, _ = _grid_join(ia0, ia1, G, start, ids, first, float(pad), *cols, limit, out_a,
                          out_b)
        if n < 0:
            return None
        if n <= guess:
            return out_a[:n], out_b[:n]
        guess = n


_SATURATED = 1 << 62


@njit(**JIT_OPTIONS)
def _covered(i0, i1):
    total = 0
    three = i0.shape[1] == 3
    for r in range(i0.shape[0]):
        if three:  # written out: no inner trip count (W1's two sides 0.31 -> 0.18 ms)
            n = ((np.int64(i1[r, 0]) - np.int64(i0[r, 0]) + 1)
                 * (np.int64(i1[r, 1]) - np.int64(i0[r, 1]) + 1)
                 * (np.int64(i1[r, 2]) - np.int64(i0[r, 2]) + 1))
        else:
            n = 1
            for ax in range(i0.shape[1]):
                n *= np.int64(i1[r, ax]) - np.int64(i0[r, ax]) + 1
        total = min(total + n, _SATURATED)  # a box covers < 2^61 cells (BITS = 20)
    return total


def covered_cells(i0: np.ndarray, i1: np.ndarray) -> int:
    """Σ over the boxes of the cells each covers (their inclusive cell ranges i0, i1):
    :func:`predicates.registration.spatial.boxgrid.covered`'s integers in one pass, no
    per-block temporaries (int64 sums: exact, the same total; held at 2^62 past it,
    far above any cell budget, where the block sums would wrap)."""
    return int(_covered(i0, i1)) if len(i0) else 0
