"""The lean plan's first round of the cells that can meet, fused and compiled
(:func:`predicates.registration.plan.lean.flag_pass`; GIL-free, block by block on the
plan's pool): per row its box, its cell range, the cells it covers and, with an
occupied cells' summed-area table, its flag — from the kernels of
:mod:`predicates.compiled.cells` (boxes, grid indices, corner sums), with their values.

* :func:`flag_block` — each row's box (:func:`~predicates.compiled.cells.fill_boxes`)
  and its range (:func:`~predicates.compiled.cells.cell_index`);
* :func:`flag_block_indexed` — the ranges from the points' grid cells
  (:func:`~predicates.compiled.cells.point_index`), the same values;
* :func:`pair_bits` — one bit per 2^d block of grid cells: is any occupied.

Tetrahedra in 3D take :mod:`predicates.compiled.flagpack` (one packed index a point).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .cells import _box_row, _corner_loop, _corner_sum, _index

__all__ = ["flag_block", "flag_block_indexed", "pair_bits"]


@njit(**JIT_OPTIONS)
def flag_block(points, rows, origin, h, G, stride, S, has_table, i0, i1, near):
    """One block of :func:`predicates.registration.plan.lean.flag_pass`, fused: each
    row's box (:func:`~.cells.fill_boxes`), its cell range (:func:`~.cells.cell_index`),
    the cells it covers (``ncells``, summed), and with a table ``S`` the flag ``near``
    (:func:`~.cells.look_corners`: the 2^d corners' keys from per-axis terms, as
    gridsums._corners), the flagged rows' cell ranges, in order, into the first rows of
    ``i0``, ``i1`` (no mask pass after) and their largest box edge (``box_extent``: per
    row max over the axes of hi − lo, exact). Returns (cells covered, largest edge of
    the flagged rows or 0.0, rows flagged)."""
    d = points.shape[1]
    lo = np.empty(d)
    hi = np.empty(d)
    low_term = np.empty(d, dtype=np.int64)
    up_term = np.empty(d, dtype=np.int64)
    covered = 0
    ext = 0.0
    nf = 0  # rows flagged so far: row m's range is written at row nf, kept if flagged
    for m in range(rows.shape[0]):
        cells = 1
        for ax in range(d):
            lo[ax], hi[ax] = _box_row(points, rows, m, ax)
            j0 = _index(lo[ax], origin[ax], h, G[ax] - 1)
            j1 = _index(hi[ax], origin[ax], h, G[ax] - 1)
            i0[nf, ax], i1[nf, ax] = j0, j1
            low_term[ax] = np.int64(j0) * stride[ax]
            up_term[ax] = (np.int64(j1) + 1) * stride[ax]
            cells *= np.int64(j1) - j0 + 1
        covered += cells
        if not has_table:
            continue
        count = _corner_sum(S, low_term, up_term) if d == 3 else \
            _corner_loop(S, low_term, up_term)
        near[m] = count > 0
        if count > 0:
            nf += 1
            e = hi[0] - lo[0]
            for ax in range(1, d):
                x = hi[ax] - lo[ax]
                e = e if (e > x) | (e != e) else x  # np.maximum(e, x)
            ext = e if e > ext else ext  # Python's max(ext, e): e only when larger
    return covered, ext, nf


@njit(**JIT_OPTIONS)
def pair_bits(S, G, stride, bits):
    """Per cell c of the (G + 1)-grid with c + 1 inside it on every axis: is any cell of
    the 2^d block [c, c + 1] occupied (its corner sum in the summed-area table ``S``
    > 0)? As bits of ``bits`` (uint8, little-endian bit order, key = the linear key of
    c). :func:`flag_block_indexed` decides a row whose range spans at most two cells
    per axis from one bit (a range inside the block: no occupied cell in the block,
    none in the range — the corner sum is a count of occupied cells)."""
    if G.shape[0] == 3:  # written out (W4's 1.8 M grid cells: 22.5 -> 15.6 ms)
        _pair_bits3(S, G, stride, bits)
        return
    d = G.shape[0]
    low = np.empty(d, dtype=np.int64)
    up = np.empty(d, dtype=np.int64)
    c = np.zeros(d, dtype=np.int64)  # the cell, axis 0 fastest (as the keys)
    total = 1
    for ax in range(d):
        total *= G[ax]
    for _ in range(total):  # every cell c ≤ G − 1: c + 1 ≤ G is on the (G + 1)-grid
        key = 0
        for ax in range(d):
            low[ax] = c[ax] * stride[ax]
            # the block's far corner c + 2, or G: the grid's last row holds no cell
            up[ax] = min(c[ax] + 2, G[ax]) * stride[ax]
            key += low[ax]
        count = _corner_sum(S, low, up) if d == 3 else _corner_loop(S, low, up)
        if count > 0:
            bits[key >> 3] |= np.uint8(1 << (key & 7))
        for ax in range(d):  # next cell
            c[ax] += 1
            if c[ax] < G[ax]:
                break
            c[ax] = 0


@njit(**INLINE_OPTIONS)
def _pair_bits3(S, G, stride, bits):
    """:func:`pair_bits` for d = 3: the cells in nested loops; along a row of x the
    corner sum (:func:`~.cells._corner_sum`'s eight terms) is T(x1) − T(x0) with T(x) the four
    terms at x, each T computed once a row (four loads a cell instead of eight; the
    same integers)."""
    s0, s1, s2 = stride[0], stride[1], stride[2]
    T = np.empty(G[0] + 1, dtype=np.int64)
    for z in range(G[2]):
        z0, z1 = z * s2, min(z + 2, G[2]) * s2
        for y in range(G[1]):
            y0, y1 = y * s1, min(y + 2, G[1]) * s1
            for x in range(G[0] + 1):
                u = x * s0
                T[x] = (np.int64(S[u + y1 + z1]) - np.int64(S[u + y0 + z1])
                        - np.int64(S[u + y1 + z0]) + np.int64(S[u + y0 + z0]))
            for x in range(G[0]):
                if T[min(x + 2, G[0])] - T[x] > 0:
                    key = x * s0 + y0 + z0
                    bits[key >> 3] |= np.uint8(1 << (key & 7))


@njit(**JIT_OPTIONS)
def flag_block_indexed(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi,
                       bits, fcells):
    """:func:`flag_block` from the vertices' grid cells ``index``
    (:func:`~.cells.point_index`) instead of each row's box: the same values, because
    the index ``clip(floor((x − o)/h), 0, G − 1)`` is a non-decreasing function of x
    (each rounding is monotone), so the index of the box's lo (the vertices' min) is the
    vertices' least index and that of hi their largest — no division per row, and the
    float box only for the flagged rows: their largest edge, and their boxes into the
    first rows of ``flo``, ``fhi`` (m, d) (kept for the later rounds and the report).
    ``bits`` (:func:`pair_bits`, or empty: not used) decides rows spanning at most two
    cells per axis without the table's 2^d scattered look-ups; the flagged rows' vertex
    ids into the first rows of ``fcells`` (m, k) (the run's cells, gathered here while
    the block is in cache). Returns as flag_block. Tetrahedra in 3D take
    :func:`predicates.compiled.flagpack.flag_tetrahedra_packed` instead (the plan's
    choice: the same values from one packed index a point)."""
    return _flag_rows(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi,
                      bits, fcells)


@njit(**INLINE_OPTIONS)
def _flagged(points, rows, m, nf, flo, fhi, fcells, ext):
    """A flagged row's boxes and vertex ids into row ``nf`` of ``flo``, ``fhi``,
    ``fcells`` and its largest edge (box_extent: np.maximum over the axes) into ``ext``
    (Python's max: only when larger)."""
    for v in range(rows.shape[1]):
        fcells[nf, v] = rows[m, v]
    e = 0.0
    for ax in range(points.shape[1]):
        a, b = _box_row(points, rows, m, ax)
        flo[nf, ax], fhi[nf, ax] = a, b
        x = b - a
        e = x if ax == 0 else (e if (e > x) | (e != e) else x)
    return e if e > ext else ext


@njit(**INLINE_OPTIONS)
def _flag_rows(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi, bits,
               fcells):
    """:func:`flag_block_indexed` on any d and k."""
    d = points.shape[1]
    k = rows.shape[1]
    low_term = np.empty(d, dtype=np.int64)
    up_term = np.empty(d, dtype=np.int64)
    covered = 0
    ext = 0.0
    nf = 0  # rows flagged so far: row m's range is written at row nf, kept if flagged
    use_bits = bits.shape[0] > 0
    for m in range(rows.shape[0]):
        cells = 1
        key = 0
        small = True  # at most two cells per axis
        for ax in range(d):
            j0 = index[rows[m, 0], ax]
            j1 = j0
            for v in range(1, k):
                j = index[rows[m, v], ax]
                j0 = j if j < j0 else j0
                j1 = j if j > j1 else j1
            i0[nf, ax], i1[nf, ax] = j0, j1
            low_term[ax] = np.int64(j0) * stride[ax]
            up_term[ax] = (np.int64(j1) + 1) * stride[ax]
            key += low_term[ax]
            small &= j1 - j0 <= 1
            cells *= np.int64(j1) - j0 + 1
        covered += cells
        if not has_table:
            continue
        if use_bits and small and (bits[key >> 3] >> (key & 7)) & 1 == 0:
            near[m] = False  # nothing occupied in the 2^d block holding the range
            continue
        count = _corner_sum(S, low_term, up_term) if d == 3 else \
            _corner_loop(S, low_term, up_term)
        near[m] = count > 0
        if count > 0:
            ext = _flagged(points, rows, m, nf, flo, fhi, fcells, ext)
            nf += 1
    return covered, ext, nf
