"""The broad phase's top grid (section 1 of the paper, :mod:`.broadphase`): its cell size
(the larger mean box extent, an exactly rounded mean so that it does not depend on the
order of the boxes or on how they are split), origin, number of cells per axis (doubled cell size while the boxes
would cover too many cells), and every box's inclusive range of cells. The passes over
the many boxes (the simulation cells) run in blocks (:mod:`.blocks`): the same values
for any block size and on a thread pool."""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.exactsum import ExactSum

__all__ = ["BITS", "any_corner", "cell_index", "cells_per_axis", "colmax", "colmin", "covered",
           "enlarge", "expand",
           "extent_sums", "fit", "grid", "mean_extent", "ncells", "rowwise"]

BITS = 20  # at most 2^20 + 1 cells per axis: linear keys fit in int64


def cells_per_axis(span: np.ndarray, h: float) -> np.ndarray:
    """(d,) int64 cells per axis of a grid of cell size ``h`` over an extent ``span``:
    ⌊span/h⌋ + 1, clipped to [1, 2^BITS + 1] (linear keys fit in int64)."""
    return (np.floor(span / h).astype(np.int64) + 1).clip(1, (1 << BITS) + 1)


def cell_index(x, origin, h, G, blocks: Blocks = SERIAL):
    """Cell of each coordinate, clipped to the grid (int32: G ≤ 2^20 + 1 per axis);
    block by block (the float temporaries stay cache-sized)."""
    out = np.empty(x.shape, dtype=np.int32)
    if blocks.accelerate and x.ndim == 2:  # the same indices, compiled (GIL-free)
        from predicates.compiled.cells import cell_index as kernel

        o, G_ = np.asarray(origin, dtype=np.float64), np.asarray(G, dtype=np.int64)
        blocks.rows(lambda a, b: kernel(x[a:b], o, float(h), G_, out[a:b]), len(x))
        return out

    def index(a: int, b: int) -> None:
        with np.errstate(all="ignore"):
            i = np.floor((x[a:b] - origin) / h)
        np.clip(i, 0, G - 1, out=i)
        out[a:b] = i

    blocks.rows(index, len(x))
    return out


def enlarge(lo_b, hi_b, pad, accelerate: bool = False):
    """The boxes enlarged by ``pad``, rounded outwards (``nextafter``): they contain
    every point within pad of the exact boxes. ``accelerate``: binary64 (n, d) boxes
    in one compiled pass (:func:`predicates.compiled.cellsums.widened`: the same
    values; numpy's nextafter costs ~20 ns a value)."""
    pad = float(pad)
    if not pad >= 0:
        raise ValueError(f"pad must be a non-negative number, got {pad!r}")
    if accelerate and lo_b.ndim == 2 and lo_b.dtype == hi_b.dtype == np.float64:
        from predicates.compiled.cellsums import widened

        # the boxes as laid out (boxes_of's are column-major): no C-ordered copies
        out = np.empty_like(lo_b), np.empty_like(hi_b)
        widened(lo_b, hi_b, np.array([pad]), 0.0, *out)
        return out
    with np.errstate(over="ignore"):
        return np.nextafter(lo_b - pad, -np.inf), np.nextafter(hi_b + pad, np.inf)


def ncells(i0, i1):
    """Cells covered by each box (int64), axis by axis."""
    n = i1[:, 0].astype(np.int64) - i0[:, 0] + 1
    for ax in range(1, i0.shape[1]):
        n *= i1[:, ax].astype(np.int64) - i0[:, ax] + 1
    return n


def colmin(x):
    """x.min(axis=0), column by column (several times faster on (n, 3) arrays)."""
    return np.array([x[:, ax].min() for ax in range(x.shape[1])])


def colmax(x):
    return np.array([x[:, ax].max() for ax in range(x.shape[1])])


def expand(starts: np.ndarray, counts: np.ndarray):
    """For ranges [starts[i], starts[i] + counts[i]): (owner i, index) of every member, in
    order (the CSR gather of rows of lengths ``counts``)."""
    owner = np.repeat(np.arange(len(counts)), counts)
    first = np.cumsum(counts) - counts
    return owner, starts[owner] + np.arange(int(counts.sum())) - first[owner]


def rowwise(ufunc, x):
    """``ufunc.reduce(x, axis=1)`` column by column from the left (``np.minimum``,
    ``np.multiply``, ...): the same values, several times faster on (n, 3) arrays."""
    out = x[:, 0].copy()
    for ax in range(1, x.shape[1]):
        ufunc(out, x[:, ax], out=out)
    return out



def any_corner(mask: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(C,) bool: cells (C, k) with a corner where ``mask`` (a bool per vertex) is set.
    One gather (``take``: half fancy indexing's time); the k bools of a row read as one
    integer when k is 2 or 4, else :func:`rowwise`."""
    cells = np.asarray(cells)
    if len(cells) == 0:
        return np.zeros(0, dtype=bool)
    g = np.take(mask, cells)  # a contiguous (C, k) copy
    if g.shape[1] in (2, 4):
        return g.view(np.uint16 if g.shape[1] == 2 else np.uint32).ravel() != 0
    return rowwise(np.logical_or, g)

def mean_extent(lo, hi, cap=np.inf, blocks: Blocks = SERIAL):
    """The largest per-axis mean box extent (extents capped at ``cap``): a cell size.
    Each mean is the exact sum of the extents rounded once (:mod:`.exactsum`), so the
    grid, and with it every flag and pair, depends neither on the order of the boxes
    (e.g. of the cells in the file) nor on how they are split (blocks, threads,
    partitions: the sums of the parts combine exactly)."""
    if len(lo) == 0:
        return 0.0
    return max(s.mean() for s in extent_sums(lo, hi, cap, blocks))


def extent_sums(lo, hi, cap=np.inf, blocks: Blocks = SERIAL) -> list:
    """Per axis, the :class:`~.exactsum.ExactSum` of the boxes' extents capped at
    ``cap``, block by block (the spans' sums merged: exact)."""
    d = lo.shape[1]

    def span(a: int, b: int) -> list:
        sums = [ExactSum(blocks.accelerate) for _ in range(d)]
        for s, t in blocks.each(a, b):
            for ax in range(d):
                x = hi[s:t, ax] - lo[s:t, ax]
                # (capped at inf: the same values, NaN and −0.0 included; no second pass)
                sums[ax].add(x if cap == np.inf else np.minimum(x, cap, out=x))
        return sums

    parts = blocks.map(span, len(lo))
    for p in parts[1:]:
        for ax in range(d):
            parts[0][ax].merge(p[ax])
    return parts[0]


def fit(lo_a, hi_a, lo_bx, hi_bx, origin, top, h, budget, blocks: Blocks = SERIAL,
        b_side: Blocks = SERIAL):
    """Grid over [origin, top] with cell size h, doubled until the boxes cover at most
    ``budget`` cells: (G, h, ia0, ia1, ib0, ib1). ``blocks``, ``b_side``: how the passes
    over the a and the b boxes run (the same values either way)."""
    while True:
        G = cells_per_axis(top - origin, h)
        ia0, ia1 = (cell_index(x, origin, h, G, blocks) for x in (lo_a, hi_a))
        ib0, ib1 = (cell_index(x, origin, h, G, b_side) for x in (lo_bx, hi_bx))
        total = covered(ia0, ia1, blocks) + covered(ib0, ib1, b_side)
        if total <= budget or np.all(G == 1):
            return G, h, ia0, ia1, ib0, ib1
        h *= 2


def covered(i0, i1, blocks: Blocks = SERIAL) -> int:
    """Σ cells covered by the boxes (:func:`ncells`), block by block; compiled in one
    pass when ``blocks.accelerate`` (the same integers)."""
    if blocks.accelerate and blocks.pool is None and i0.ndim == 2:
        from predicates.compiled.gridjoin import covered_cells

        return covered_cells(i0, i1)

    def span(a: int, b: int) -> int:
        return sum(int(ncells(i0[lo:hi], i1[lo:hi]).sum()) for lo, hi in blocks.each(a, b))

    return sum(blocks.map(span, len(i0)))


def grid(lo_a, hi_a, lo_b, hi_b, pad, blocks: Blocks = SERIAL):
    """The top grid: b boxes enlarged by pad (outwards), cell size, per-box cell ranges:
    (lo_bx, hi_bx, origin, G, h, ia0, ia1, ib0, ib1). ``blocks``: how the passes over
    the a boxes (the many: the simulation cells) run; the same values either way."""
    na, nb = len(lo_a), len(lo_b)
    # the b side (few boxes) without a pool, but compiled when the a side is: the same
    # values (W1's 20 k cutting boxes: ~2 ms of numpy passes, benchmarks/README.md)
    b_side = Blocks(accelerate=blocks.accelerate) if blocks.accelerate else SERIAL
    lo_bx, hi_bx = enlarge(lo_b, hi_b, pad, accelerate=blocks.accelerate)
    origin = np.minimum(colmin(lo_a), colmin(lo_bx))
    top = np.maximum(colmax(hi_a), colmax(hi_bx))
    with np.errstate(over="ignore"):
        span = float((top - origin).max())
    if not np.isfinite(span):
        raise ValueError("coordinates too large for the broad phase (their range "
                         "overflows the floating-point format)")
    h = max(mean_extent(lo_a, hi_a, blocks=blocks), mean_extent(lo_bx, hi_bx, blocks=b_side))
    if h <= 0:
        h = span / max(1.0, (na + nb) ** (1 / lo_a.shape[1]))
    h = max(h, span * 2.0 ** -BITS, np.finfo(np.float64).tiny)
    G, h, *ranges = fit(lo_a, hi_a, lo_bx, hi_bx, origin, top, h, 16 * (na + nb) + (1 << 20),
                         blocks, b_side)
    return (lo_bx, hi_bx, origin, G, h, *ranges)
