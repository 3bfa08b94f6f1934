"""The report's pair estimate's dense count compiled without its grid indices in
memory (:func:`predicates.registration.plan.paircount.compiled_count`): each padded
box's cell range computed where it is used — the covered cells' total for the
budget test and the ±1 at its corners of the coverage's difference array in one
pass (:func:`pad_corners`; :func:`pad_total`, the total alone) — instead of four
(n, d) index arrays, their int64 copies and a pass over each
(:func:`predicates.compiled.cellsums.pad_index`, ``gridsums.coverage``). The ranges
are ``pad_index``'s (the same expression in the same order), the counts integers:
the same estimate.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .corners import corners2, corners3

__all__ = ["pad_corners", "pad_total"]


@njit(**INLINE_OPTIONS)
def _cells(lo, hi, r, ax, h, origin, g):
    """Box r's first and last cell on ``ax``: floor((lo − h − o)/g), floor((hi + h −
    o)/g), as :func:`~predicates.compiled.cellsums.pad_index` rounds them."""
    a = np.floor((lo[r, ax] - h - origin[ax]) / g)
    b = np.floor((hi[r, ax] + h - origin[ax]) / g)
    return a, b


@njit(**JIT_OPTIONS)
def pad_total(lo, hi, h, origin, g):
    """:func:`~predicates.compiled.cellsums.pad_index`'s total (Σ over the boxes of
    Π_axes (i1 − i0 + 1), a float sum in row order) without writing the indices."""
    total = 0.0
    for r in range(lo.shape[0]):
        c = 1.0
        for ax in range(lo.shape[1]):
            a, b = _cells(lo, hi, r, ax, h, origin, g)
            c = (b - a + 1) if ax == 0 else c * (b - a + 1)
        total += c
    return total


@njit(**INLINE_OPTIONS)
def _keys(lo, hi, r, ax, h, origin, g, stride):
    """Box r's cell count on ``ax`` (a float, as :func:`pad_total` multiplies them) and
    its range's key terms i0·stride, (i1 + 1)·stride (:func:`_cells`' floats as
    integers), unsigned: origin is the padded boxes' least lo − h, so a ≥ 0 (every
    rounding monotone) — no wraparound test an add (benchmarks/README.md s19-wplan)."""
    a, b = _cells(lo, hi, r, ax, h, origin, g)
    s = np.uint64(stride[ax])
    return b - a + 1, np.uint64(a) * s, (np.uint64(b) + np.uint64(1)) * s


@njit(**JIT_OPTIONS)
def pad_corners(lo, hi, h, origin, g, stride, diff, flip):
    """``add_corners(i0, i1, stride, diff, flip)`` of the padded boxes' cell ranges
    (int64 of :func:`_cells`' integral floats, astype's conversion) for d = 2 and 3:
    ±1 at the 2^d corners {i0, i1 + 1} of each range (integer adds: exact in any
    order; 3D: :func:`_pad_corners3`); returns :func:`pad_total` of the same ranges
    (each range computed once: the divisions bound both passes)."""
    v = -1 if flip else 1
    d = lo.shape[1]
    if d == 3:
        return _pad_corners3(lo, hi, h, origin, g, stride, diff, v)
    total = 0.0
    for r in range(lo.shape[0]):
        c, x0, x1 = _keys(lo, hi, r, 0, h, origin, g, stride)
        n, y0, y1 = _keys(lo, hi, r, 1, h, origin, g, stride)
        c = c * n
        corners2(diff, x0, x1, y0, y1, v)  # (d = 2 here)
        total += c
    return total


@njit(**INLINE_OPTIONS)
def _pad_corners3(lo, hi, h, origin, g, stride, diff, v):
    """:func:`pad_corners` in 3D, a run of consecutive boxes with the same range (the
    neighbouring cells of a structured mesh) added once, ±run at its 8 corners: the
    same integers, ~1/3 less time on W1's report (benchmarks/README.md, "s17-plan")."""
    total = 0.0
    p0 = p1 = q0 = q1 = w0 = w1 = np.uint64(0)  # (a first box with these keys: run 1)
    run = 0
    for r in range(lo.shape[0]):
        c, x0, x1 = _keys(lo, hi, r, 0, h, origin, g, stride)
        n, y0, y1 = _keys(lo, hi, r, 1, h, origin, g, stride)
        c = c * n
        n, z0, z1 = _keys(lo, hi, r, 2, h, origin, g, stride)
        c = c * n
        total += c
        if x0 == p0 and x1 == p1 and y0 == q0 and y1 == q1 and z0 == w0 and z1 == w1:
            run += 1
            continue
        if run:
            corners3(diff, p0, p1, q0, q1, w0, w1, v * run)
        p0, p1, q0, q1, w0, w1, run = x0, x1, y0, y1, z0, z1, 1
    if run:
        corners3(diff, p0, p1, q0, q1, w0, w1, v * run)
    return total
