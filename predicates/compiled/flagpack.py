"""The first round's flags of tetrahedra from packed grid indices (the lean plan's
fused flag pass, :func:`predicates.registration.plan.lean.flag_pass`): each point's
three grid indices in one int64 (:func:`pack_index`, 21 bits an axis: every index is
at most 2^20, :data:`~predicates.registration.spatial.boxgrid.BITS`), so a cell's
ranges take four loads, one per vertex, instead of twelve
(:func:`flag_tetrahedra_packed`; the values of
:func:`predicates.compiled.flagpass.flag_block_indexed`, whose module holds the rest).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .cells import _index
from .cellsums import _side4

__all__ = ["flag_tetrahedra_packed", "pack_index"]

_MASK = (1 << 21) - 1  # one axis's field


@njit(**JIT_OPTIONS)
def pack_index(points, origin, h, G, out):
    """Each point's grid cell, :func:`~predicates.compiled.cells.point_index`'s three
    indices packed into ``out`` (N,) int64: axis 0 in bits 0–20, axis 1 in 21–41,
    axis 2 in 42–62."""
    for r in range(points.shape[0]):
        key = np.int64(0)
        for ax in range(3):
            i = _index(np.float64(points[r, ax]), origin[ax], h, G[ax] - 1)
            key |= np.int64(i) << (21 * ax)
        out[r] = key


@njit(**INLINE_OPTIONS)
def _range(packed, v0, v1, v2, v3, shift):
    """Least and largest index of four vertices on the axis at bit ``shift``."""
    a = (packed[v0] >> shift) & _MASK
    b = (packed[v1] >> shift) & _MASK
    c = (packed[v2] >> shift) & _MASK
    d = (packed[v3] >> shift) & _MASK
    lo = a if a < b else b
    hi = b if a < b else a
    lo2 = c if c < d else d
    hi2 = d if c < d else c
    return (lo if lo < lo2 else lo2), (hi if hi > hi2 else hi2)


@njit(**INLINE_OPTIONS)
def _box_into(points, v0, v1, v2, v3, flo, fhi, r, ext):
    """A flagged tetrahedron's box into row ``r`` of ``flo``, ``fhi`` (``fill_boxes``'
    values: :func:`~predicates.compiled.cellsums._side4`, the ids already read) and its
    largest edge into ``ext`` as :func:`~predicates.compiled.flagpass._flagged` does."""
    a0, b0 = _side4(points, v0, v1, v2, v3, 0)
    a1, b1 = _side4(points, v0, v1, v2, v3, 1)
    a2, b2 = _side4(points, v0, v1, v2, v3, 2)
    flo[r, 0], flo[r, 1], flo[r, 2] = a0, a1, a2
    fhi[r, 0], fhi[r, 1], fhi[r, 2] = b0, b1, b2
    e = b0 - a0
    x = b1 - a1
    e = e if (e > x) | (e != e) else x  # np.maximum over the axes, from axis 0
    x = b2 - a2
    e = e if (e > x) | (e != e) else x
    return e if e > ext else ext


@njit(**JIT_OPTIONS)
def flag_tetrahedra_packed(points, packed, rows, stride, S, has_table, i0, i1, near, flo,
                           fhi, bits, fcells):
    """:func:`~predicates.compiled.flagpass.flag_block_indexed` for tetrahedra in 3D from
    :func:`pack_index`'s ``packed`` indices: the same arguments otherwise, the same
    values and writes (flags, the flagged rows' ranges, boxes and ids compacted into
    the first rows, the cells covered, the flagged rows' largest box edge); returns
    (cells covered, largest edge or 0.0, rows flagged)."""
    s0, s1, s2 = stride[0], stride[1], stride[2]
    covered = 0
    ext = 0.0
    nf = 0
    use_bits = bits.shape[0] > 0
    for m in range(rows.shape[0]):
        v0, v1, v2, v3 = rows[m, 0], rows[m, 1], rows[m, 2], rows[m, 3]
        x0, x1 = _range(packed, v0, v1, v2, v3, 0)
        y0, y1 = _range(packed, v0, v1, v2, v3, 21)
        z0, z1 = _range(packed, v0, v1, v2, v3, 42)
        covered += (x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1)
        if not has_table:
            continue
        l0, l1, l2 = x0 * s0, y0 * s1, z0 * s2  # the corners' key terms, in registers
        key = l0 + l1 + l2
        small = (x1 - x0 <= 1) & (y1 - y0 <= 1) & (z1 - z0 <= 1)
        if use_bits and small and (bits[key >> 3] >> (key & 7)) & 1 == 0:
            near[m] = False  # nothing occupied in the 2^d block holding the range
            continue
        u0, u1, u2 = (x1 + 1) * s0, (y1 + 1) * s1, (z1 + 1) * s2
        count = (np.int64(S[u0 + u1 + u2]) - np.int64(S[l0 + u1 + u2])
                 - np.int64(S[u0 + l1 + u2]) - np.int64(S[u0 + u1 + l2])
                 + np.int64(S[l0 + l1 + u2]) + np.int64(S[l0 + u1 + l2])
                 + np.int64(S[u0 + l1 + l2]) - np.int64(S[l0 + l1 + l2]))  # _corner_sum
        near[m] = count > 0
        if count > 0:
            i0[nf, 0], i0[nf, 1], i0[nf, 2] = x0, y0, z0
            i1[nf, 0], i1[nf, 1], i1[nf, 2] = x1, y1, z1
            fcells[nf, 0], fcells[nf, 1], fcells[nf, 2], fcells[nf, 3] = v0, v1, v2, v3
            ext = _box_into(points, v0, v1, v2, v3, flo, fhi, nf, ext)
            nf += 1
    return covered, ext, nf
