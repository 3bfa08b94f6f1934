"""The first round of the cells that can meet, at a grid the cutting mesh fixes
(docs/resolution.md, "The first round"; docs/partitioned.md section 2).

Round one of :func:`~.resolution.consistent_scale` flags every simulation cell that can
be within the pad σ+(L_0) of a cutting cell. Any superset of those cells is sound
(:mod:`.resolution`'s argument), so the test may run on any grid. Its grid here depends
only on the cutting boxes, the simulation cell count and the pad:

* cell size h: the power of two at or below the largest of the cutting boxes' larger
  per-axis mean extent (exactly rounded, so independent of the cells' order and of
  how they are split), 2^-BITS of the cutting hull's largest side and the least normal
  number, doubled until the grid has at most n_sim/8 + 2^18 cells (the summed-area
  table stays cache-sized). A power of two makes (x − o)/h exact as (x − o)·(1/h):
  the sweep computes a box's cells with a multiplication, the values of the division;
* margin: max(h·2^-6, pad): the cutting boxes enlarged by it (rounded outwards);
* origin and extent: the enlarged cutting boxes' hull widened by 2h a side, so that a
  simulation coordinate outside is clipped into an empty border cell.

A simulation cell is flagged when its clipped cell range holds a cell an enlarged
cutting box covers (the summed-area table: 2^d look-ups); a cutting cell when its range
holds a cell a flagged simulation cell covers. A pair within the margin shares a point,
whose cell (floor((x − o)/h) clipped: non-decreasing in x) lies in both ranges.

Because the grid is known before the simulation cells are read, the flags can be
computed in the same sweep as validation and the boxes' summary
(:meth:`~.cellboxes.CellBoxes.checked_summary`; numpy: the summary's pass,
:func:`~.quiet.swept_summary`): :func:`speculative` makes the grid with
the margin h·2^-6 before the sweep; it is the round's grid when the pad then comes out
≤ that margin and the cutting boxes are the ones it was made from (no refinement).
Otherwise the flags are a pass of their own at :func:`fixed_grid`'s grid — the same
definition, so the same flags either way, on every path (numpy, compiled, workers).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxes import box_extent
from predicates.registration.spatial.boxgrid import (
    BITS, cell_index, cells_per_axis, colmax, colmin, enlarge, mean_extent)

__all__ = ["FixedGrid", "MARGIN", "fixed_grid", "near_fixed", "speculative"]

#: the margin's share of the cell size when the pad is smaller (the speculative grid's)
MARGIN = 2.0 ** -6


@dataclass(eq=False)
class FixedGrid:
    """A first-round grid (module docstring): cell size ``h``, ``origin`` and cells
    per axis ``G`` (d,), the ``margin`` the cutting boxes ``lo_b``, ``hi_b`` were
    enlarged by, their cell ranges ``ib0``, ``ib1`` and the summed-area ``table`` of
    the cells they cover; ``n_sim``: the simulation cell count it was made for."""

    lo_b: np.ndarray
    hi_b: np.ndarray
    n_sim: int
    h: float
    margin: float
    origin: np.ndarray
    G: np.ndarray
    ib0: np.ndarray
    ib1: np.ndarray
    table: np.ndarray

    def holds(self, lo_b, hi_b, n_sim: int, pad: float) -> bool:
        """Is this the grid :func:`fixed_grid` makes for these arguments (the same
        cutting box arrays, cell count, and a pad within the margin)?"""
        return (lo_b is self.lo_b and hi_b is self.hi_b and n_sim == self.n_sim
                and pad <= self.margin and self.margin == max(self._h0 * MARGIN, pad))

    _h0: float = 0.0  # the cell size before doubling (the margin's base)


def _base_size(lo_b, hi_b, blocks: Blocks) -> tuple[float, np.ndarray, np.ndarray]:
    """(h_0, hull lo, hull hi) of the cutting boxes: h_0 the larger per-axis mean
    extent, at least 2^-BITS of the hull's largest side and the least normal number."""
    lo, hi = colmin(lo_b), colmax(hi_b)
    with np.errstate(over="ignore"):
        span = float((hi - lo).max())
    if not np.isfinite(span):
        raise ValueError("coordinates too large for the broad phase (their range "
                         "overflows the floating-point format)")
    h = max(mean_extent(lo_b, hi_b, blocks=blocks), span * 2.0 ** -BITS,
            np.finfo(np.float64).tiny)
    return math.ldexp(1.0, math.frexp(h)[1] - 1), lo, hi  # h's binade: 2^k ≤ h < 2^(k+1)


def fixed_grid(lo_b, hi_b, n_sim: int, pad: float, blocks: Blocks) -> FixedGrid:
    """The first round's grid (module docstring) for the cutting boxes ``lo_b``,
    ``hi_b`` (binary64 (n, d), n ≥ 1), ``n_sim`` simulation cells and the pad."""
    from predicates.registration.plan.lean import _occupied

    h0, lo, hi = _base_size(lo_b, hi_b, blocks)
    margin = max(h0 * MARGIN, float(pad))
    # compiled: the enlarged boxes' ranges in one pass, no enlarged boxes in memory
    fused = blocks.accelerate and lo_b.ndim == 2 and lo_b.dtype == hi_b.dtype == np.float64
    # the enlarged boxes' hull is the hull enlarged: enlarge is non-decreasing in each
    # value (x ∓ pad rounded, then nextafter), so it commutes with min and max — the
    # same values without a pass over the enlarged boxes
    lo, hi = (x[0] for x in enlarge(lo[None], hi[None], margin))
    budget, h = n_sim // 8 + (1 << 18), h0
    while True:
        with np.errstate(over="ignore"):
            origin, top = lo - 2 * h, hi + 2 * h
            G = cells_per_axis(top - origin, h)
        if not (np.all(np.isfinite(origin)) and np.all(np.isfinite(top))):
            raise ValueError("coordinates too large for the broad phase (their range "
                             "overflows the floating-point format)")
        if int(np.prod(G + 1)) <= budget or np.all(G == 1):
            break
        h *= 2
    if fused:  # (compiled/cutgrid.py: enlarge's then cell_index's roundings, in order)
        from predicates.compiled.cutgrid import enlarged_ranges

        ib0, ib1 = np.empty(lo_b.shape, np.int32), np.empty(lo_b.shape, np.int32)
        enlarged_ranges(lo_b, hi_b, margin, np.asarray(origin, dtype=np.float64), float(h),
                        np.asarray(G, dtype=np.int64), ib0, ib1)
    else:
        lo_bx, hi_bx = enlarge(lo_b, hi_b, margin, blocks.accelerate)
        ib0, ib1 = (cell_index(x, origin, h, G, blocks) for x in (lo_bx, hi_bx))
    table = _occupied(ib0, ib1, G, blocks)
    return FixedGrid(lo_b, hi_b, n_sim, h, margin, origin, G, ib0, ib1, table, _h0=h0)


def speculative(lo_b, hi_b, n_sim: int, blocks: Blocks) -> FixedGrid | None:
    """:func:`fixed_grid` with the smallest margin (h_0·2^-6): the round's grid when
    the pad comes out within it (module docstring); None when 1/h is not a normal
    number (the sweep's multiplication would not be the division)."""
    grid = fixed_grid(lo_b, hi_b, n_sim, 0.0, blocks)
    inv = 1.0 / grid.h
    return grid if np.isfinite(inv) and inv >= np.finfo(np.float64).tiny else None


def near_fixed(boxes, lo_b: np.ndarray, hi_b: np.ndarray, pad: float):
    """(near_a, near_b, ext_a): the first round's flags (module docstring) of the
    simulation cells ``boxes`` (a :class:`~.cellboxes.CellBoxes`, its remote form, or
    (lo, hi) arrays) and the cutting boxes, and the largest box edge of the flagged
    simulation cells (not rounded; 0.0 if none). A grid the sweep already flagged at
    (``boxes.first_grid``) is used when it is this one: no pass over the cells."""
    from predicates.registration.plan.lean import cut_flags

    lean = hasattr(boxes, "flag_pass")
    na, nb = len(boxes) if lean else len(boxes[0]), len(lo_b)
    if na == 0 or nb == 0:
        return np.zeros(na, dtype=bool), np.zeros(nb, dtype=bool), 0.0
    lo_b, hi_b = np.asarray(lo_b, dtype=np.float64), np.asarray(hi_b, dtype=np.float64)
    blocks = boxes.blocks if lean else Blocks(accelerate=False)
    grid = getattr(boxes, "first_grid", None)
    if grid is None or not grid.holds(lo_b, hi_b, na, pad):
        grid = fixed_grid(lo_b, hi_b, na, pad, blocks)
    if lean:
        _, (near_a, i0f, i1f, ext) = boxes.flag_pass(grid.origin, grid.h, grid.G,
                                                     grid.table)
    else:
        near_a, i0f, i1f, ext = _array_flags(boxes, grid, blocks)
    if i0f is None:  # cells on the workers: the grid cells their ranges cover (the same
        # occupancy cut_flags builds from them, partition/swept.covered)
        return near_a, boxes.cut_flags(grid.ib0, grid.ib1, grid.G), ext
    return near_a, cut_flags(i0f, i1f, grid.ib0, grid.ib1, grid.G, blocks), ext


def _array_flags(boxes, grid: FixedGrid, blocks: Blocks):
    """The simulation side's flags of (lo, hi) arrays at ``grid``, as
    :func:`~.lean.flag_pass` gives them: (flags, the flagged rows' ranges, their
    largest box edge)."""
    from predicates.registration.spatial.gridsums import covered_in

    lo, hi = (np.asarray(x, dtype=np.float64) for x in boxes)
    i0, i1 = (cell_index(x, grid.origin, grid.h, grid.G, blocks) for x in (lo, hi))
    near = covered_in(grid.table, i0, i1, grid.G)
    ext = float(box_extent(lo[near], hi[near]).max()) if near.any() else 0.0
    return near, i0[near], i1[near], ext


class SweptFlags:
    """The first round's flags at ``grid`` written by the summary's sweep
    (:func:`predicates.compiled.tetsums.swept_tetrahedra`) over the tetrahedra of
    ``points`` (N, 3) (:meth:`~.cellboxes.CellBoxes.checked_summary`): the flags of
    all n cells, and per span its flagged rows' ranges, boxes and ids, compacted in
    order — what :func:`~.lean.flag_pass` gives at that grid."""

    def __init__(self, grid: FixedGrid, cells_dtype, n: int, n_points: int):
        from predicates.compiled.tetsums import quiet_cells
        from predicates.registration.spatial.gridsums import _stride

        self.grid, self.near = grid, np.zeros(n, dtype=bool)
        self.cells_dtype = np.dtype(cells_dtype)
        G = np.asarray(grid.G, dtype=np.int64)
        self.origin, self.top = np.asarray(grid.origin, dtype=np.float64), G - 1
        self.inv_h = 1.0 / grid.h  # exact: h is a power of two (fixed_grid)
        self.stride = _stride(grid.G)
        # the sweep's shortcut (docs/resolution.md, "The first round"): per grid cell
        # its quiet level, per point its cell's (255: not yet read, the kernel's)
        self.levels = np.empty(int(np.prod(G)), dtype=np.uint8)
        quiet_cells(grid.table, G, self.stride, self.levels)
        self.quiet = np.full(n_points, 255, dtype=np.uint8)
        self.bound = grid.h * 2.0 ** 46  # a point farther from the origin: level 0

    def span(self, a: int, b: int) -> "_SpanRows":
        """The output of the span of rows [a, b)."""
        return _SpanRows(self, a, b)

    def result(self, spans: list) -> tuple:
        """((0, (flags, flagged ranges i0, i1, their largest edge)), (boxes lo, hi and
        ids of the flagged rows)): :func:`~.lean.flag_pass`'s result and what it keeps."""
        from predicates.registration.plan.quiet import _joined

        for s in spans:
            s.close()
        chunks = [c for s in spans for c in s.chunks]
        part = [_joined([c[t] for c in chunks], empty) for t, empty in enumerate(
            (np.zeros((0, 3), np.int32), np.zeros((0, 3), np.int32), np.zeros((0, 3)),
             np.zeros((0, 3)), np.zeros((0, 4), self.cells_dtype)))]
        ext = max([s.ext for s in spans], default=0.0)
        return (0, (self.near, part[0], part[1], ext)), tuple(part[2:])


class _SpanRows:
    """One span's flagged rows: output arrays filled in order, a new one when full."""

    def __init__(self, owner: SweptFlags, a: int, b: int):
        self.owner, self.size, self.chunks, self.ext = owner, max(1, (b - a) // 4), [], 0.0
        self.out, self.filled = None, 0

    def args(self, u: int, w: int) -> tuple:
        """The kernel's ``grid`` tuple for rows [u, w)."""
        o = self.owner
        if self.out is None or self.filled + (w - u) > len(self.out[0]):
            self.close()
            m = max(w - u, self.size)
            self.out = (np.empty((m, 3), np.int32), np.empty((m, 3), np.int32),
                        np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 4), o.cells_dtype))
        rest = tuple(x[self.filled:] for x in self.out)
        return (o.origin, o.inv_h, o.top, o.stride, o.grid.table, o.levels,
                o.bound, o.quiet, o.near[u:w]) + rest

    def add(self, nf: int, ext: float) -> None:
        if nf:
            self.filled += nf
            self.ext = max(self.ext, ext)

    def close(self) -> None:
        if self.out is not None and self.filled:
            self.chunks.append(tuple(x[:self.filled] for x in self.out))
        self.out, self.filled = None, 0


def from_cut(boxes_of, blocks: Blocks):
    """``validate_pair``'s ``first_round``: (cutting mesh, n_sim) → the
    :func:`speculative` grid of its boxes (``boxes_of(points, cells)``), or None for
    an empty cutting mesh."""
    def grid(cut, n_sim: int) -> FixedGrid | None:
        if len(cut.cells) == 0:
            return None
        return speculative(*boxes_of(cut.points, cut.cells), n_sim, blocks)

    return grid


def cut_boxes(sim_box, cut, boxes_of) -> tuple:
    """The cutting boxes (lo, hi): those the sweep's grid was made from (the same
    arrays, which :meth:`FixedGrid.holds` recognises), else ``boxes_of`` them."""
    grid = getattr(sim_box, "first_grid", None)
    return (grid.lo_b, grid.hi_b) if grid is not None else boxes_of(cut.points, cut.cells)
