"""The simulation cells' boxes without storing them (docs/partitioned.md, section 2,
"the lean plan"): the plan needs every cell's box only for reductions (the hull, the
largest and least box edges, their exponents' histogram for the refinement's scan)
and for per-cell flags, so :class:`CellBoxes` recomputes the boxes block by block from
the points and cells (:func:`~predicates.registration.spatial.boxes.fill_boxes`: exact,
min and max round nothing) instead of holding two (n, d) binary64 arrays — 48 bytes per
tetrahedron, more than the cells themselves. Boxes of a subset of the cells (the cells
that can meet, a few per cent of a large mesh) are gathered once and kept.

``CellBoxes.lo`` / ``.hi`` behave as the (n, d) arrays where the refinement reads them
(row slices, index arrays, masks, ``[:, axis]``, ``len``, ``shape``; anything else
materialises the array), so every consumer sees the same numbers as before.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from predicates.registration.plan.refine_scan import stats_from
from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import boxes_of, fill_boxes

__all__ = ["BoxSummary", "CellBoxes"]


@dataclass
class BoxSummary:
    """Reductions of the boxes of n cells, each exact (min, max, counts), so those of
    parts combine into those of the whole in any order (:meth:`merge`): the hull
    ``lo_min``, ``hi_max`` (d,), the largest and least box edges ``ext_max``,
    ``ext_min`` (not rounded) and their exponents' histogram ``hist``. (No mean extent:
    the first round's grid is the cutting mesh's, docs/resolution.md.)"""

    n: int
    lo_min: np.ndarray
    hi_max: np.ndarray
    ext_max: float
    ext_min: float = np.inf
    hist: np.ndarray | None = None  # biased exponents of the extents (None: not finite)
    first: tuple | None = None  # (grid, flags) of the sweep that made it (first_round.py)

    def merge(self, other: "BoxSummary") -> "BoxSummary":
        if other.n == 0:
            return self
        if self.n == 0:
            return other
        hist = None if self.hist is None or other.hist is None else self.hist + other.hist
        return BoxSummary(self.n + other.n, np.minimum(self.lo_min, other.lo_min),
                          np.maximum(self.hi_max, other.hi_max),
                          max(self.ext_max, other.ext_max),
                          min(self.ext_min, other.ext_min), hist)

    def scan_stats(self):
        """The refinement scan's statistics of these boxes
        (:func:`~.refine_scan.stats_from`), or None when an extent is not finite (the
        scan then reads the boxes and refuses them itself)."""
        if self.hist is None or not np.isfinite(self.ext_max):
            return None
        mag = max(0.0, float(np.max(-self.lo_min)), float(np.max(self.hi_max)))
        return stats_from(self.n, float(self.ext_min), float(self.ext_max), mag, self.hist)


def summarize(lo: np.ndarray, hi: np.ndarray) -> BoxSummary:
    """:class:`BoxSummary` of the boxes ``lo``, ``hi`` (n, d)."""
    return summarized(lo, hi)[0]


def summarized(lo: np.ndarray, hi: np.ndarray) -> tuple:
    """(:func:`summarize`'s summary, the boxes' largest edges: ``box_extent``'s values,
    −0.0 made +0.0)."""
    d = lo.shape[1]
    if len(lo) == 0:
        return BoxSummary(0, np.full(d, np.inf), np.full(d, -np.inf), 0.0), np.zeros(0)
    ext = [hi[:, ax] - lo[:, ax] for ax in range(d)]
    e = np.maximum(ext[0], ext[1])  # box_extent's values from the extents already made
    for x in ext[2:]:
        np.maximum(e, x, out=e)
    e += 0.0  # -0.0 to +0.0, as the refinement's scan counts exponents
    e_min, e_max = float(e.min()), float(e.max())
    hist = np.bincount(e.view(np.int64) >> 52, minlength=2048) \
        if np.isfinite(e_max) and e_min >= 0 else None
    return BoxSummary(len(lo), np.array([lo[:, ax].min() for ax in range(d)]),
                      np.array([hi[:, ax].max() for ax in range(d)]), e_max, e_min,
                      hist), e


class CellBoxes:
    """The boxes of ``cells`` over ``points``, computed when asked: :meth:`block` (rows
    [a, b)), :meth:`rows` (a mask or ids; the last subset is kept), :meth:`summary`
    (one pass, cached); ``lo``, ``hi``: array-like views (module docstring)."""

    summarized = staticmethod(summarized)  # (for quiet.swept_summary's blocks)

    def __init__(self, points: np.ndarray, cells: np.ndarray, blocks: Blocks = SERIAL,
                 summary: BoxSummary | None = None, checked: bool = False):
        self.points, self.cells, self.blocks = points, cells, blocks
        self.checked = checked  # every id validated in range (the plan's cells)
        self.n, self.d = len(cells), points.shape[1]
        self.cols = None  # the points by axis in binary64, made by the numpy blocks
        self._summary = summary  # (validation's, when it made it: checked_summary)
        self._tetrahedra = None  # tetrahedra over finite points (compiled summary)
        self._points_c = None  # the points C-contiguous, when a compiled pass asks
        self._kept = None  # (ids, lo, hi) of the last subset gathered
        self._kept_cells = None  # (ids, cells) of the first round's flagged cells
        self._kept_mask = None  # the mask whose rows the kept ones are (keep(mask=))
        self._cells_sel = None  # (selection, its cells) of the last cells_of
        self._local = threading.local()  # the last block computed, per thread
        # the first round's grid and flags when the summary's sweep made them
        # (checked_summary with a grid; first_round.py): (result, kept rows)
        self.first_grid, self._first = getattr(summary, "first", None) or (None, None)
        #: a first-round grid whose flags the numpy summary's pass computes too
        #: (:func:`~.quiet.swept_summary`), set before :meth:`summary` is asked
        self.sweep_grid = None
        if summary is not None:
            summary.first = None  # held here only: not for as long as the summary

    # lo and hi are made when asked, not stored: a stored view referring back to its
    # owner made a reference cycle that kept the boxes until a full collection
    @property
    def lo(self) -> _Side:
        """The boxes' lower corners as an (n, d) array-like."""
        return _Side(self, 0)

    @property
    def hi(self) -> _Side:
        """The boxes' upper corners as an (n, d) array-like."""
        return _Side(self, 1)

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, side: int):
        """``boxes[0]``, ``boxes[1]``: lo and hi, as a (lo, hi) pair is indexed."""
        return (self.lo, self.hi)[side]

    def __iter__(self):
        return iter((self.lo, self.hi))

    def block(self, a: int, b: int):
        """(lo, hi) (b − a, d) of rows [a, b) (the last block is reused)."""
        last = getattr(self._local, "last", None)
        if last is not None and last[0] == a and last[1] == b:
            return last[2], last[3]
        lo, hi = np.empty((self.d, b - a)), np.empty((self.d, b - a))
        if self.blocks.accelerate:  # the same boxes, compiled: points and rows as given
            from predicates.compiled.cells import fill_boxes as kernel

            kernel(self._given(), self.cells[a:b], lo, hi)
        else:
            fill_boxes(self.columns(), np.ascontiguousarray(self.cells[a:b].T), lo, hi,
                       self.checked)
        self._local.last = (a, b, lo.T, hi.T)
        return lo.T, hi.T

    def columns(self) -> np.ndarray:
        """The points by axis in binary64 (d, N), made once (the numpy blocks read them)."""
        if self.cols is None:  # (a race of two threads makes two equal copies)
            self.cols = np.ascontiguousarray(self.points.T, dtype=np.float64)
        return self.cols

    def _given(self) -> np.ndarray:
        """The points as given, C-contiguous (the compiled kernels read them)."""
        if self._points_c is None:
            self._points_c = np.ascontiguousarray(self.points)
        return self._points_c

    def rows(self, sel):
        """(lo, hi) of the rows ``sel`` (a boolean mask of n or ascending ids), in
        ascending order; from the kept subset when it holds them, else gathered (and
        kept)."""
        if self._kept is not None and sel is self._kept_mask:
            return self._kept[1:]  # the kept rows' own mask: no look-up
        ids = np.flatnonzero(sel) if np.asarray(sel).dtype == bool else np.asarray(sel)
        if self._kept is not None:
            kept, lo, hi = self._kept
            if kept is None:  # kept by mask (keep): its rows found now, once
                kept = np.flatnonzero(self._kept_mask)
                self._kept = (kept, lo, hi)
            if len(ids) == len(kept) and np.array_equal(kept, ids):
                return lo, hi  # the kept rows themselves (no copies)
            pos = np.searchsorted(kept, ids)
            if len(ids) == 0 or (pos.max() < len(kept) and np.array_equal(kept[pos], ids)):
                return lo[pos], hi[pos]
        if len(ids) == self.n:
            lo, hi = boxes_of(self.points, self.cells, self.blocks)
        else:
            lo, hi = boxes_of(self.points, self.cells[ids], self.blocks)
        self._kept, self._kept_mask = (ids, lo, hi), None
        return lo, hi

    def keep(self, ids: np.ndarray | None, lo: np.ndarray, hi: np.ndarray,
             cells: np.ndarray | None = None, mask: np.ndarray | None = None) -> None:
        """Keep the boxes ``lo``, ``hi`` of the rows ``ids`` (ascending), computed by a
        pass that had them (the first round's flagged cells), and their ``cells``:
        :meth:`rows` and :meth:`cells_of` of them, or of a subset, then gather
        nothing from every cell. ``mask``: the boolean mask whose rows ``ids`` are,
        recognised as that object later without a look-up (the plan's masks are never
        written once made); ``ids`` None: the rows of ``mask``, found only if another
        selection is asked for (``np.flatnonzero`` of a mask of every cell: ~5 ms on
        W4, and the plan asks with the mask itself)."""
        self._kept, self._kept_mask = (ids, lo, hi), mask
        self._kept_cells = None if cells is None else (ids, cells, mask)

    def cells_of(self, sel) -> np.ndarray:
        """The cells (vertex ids) of the rows ``sel`` (a mask or ascending ids); the
        last selection's are kept (the report and the plan ask for the run's cells with
        the same mask: one gather over every cell, not two)."""
        last = self._cells_sel
        if last is not None and last[0] is sel:
            return last[1]
        out = self._kept_rows(sel)
        out = self.cells[sel] if out is None else out
        self._cells_sel = (sel, out)
        return out

    def _kept_rows(self, sel):
        """The kept cells (:meth:`keep`) of the rows ``sel`` when they hold them all,
        else None."""
        if self._kept_cells is None:
            return None
        kept, cells, mask = self._kept_cells
        if sel is mask and mask is not None:  # (the same array object, never written)
            return cells
        if kept is None:  # kept by mask: its rows found now, once
            kept = np.flatnonzero(mask)
            self._kept_cells = (kept, cells, mask)
        ids = np.flatnonzero(sel) if np.asarray(sel).dtype == bool else np.asarray(sel)
        if len(ids) == len(kept) and np.array_equal(kept, ids):
            return cells
        pos = np.searchsorted(kept, ids)
        if len(ids) and pos.max() < len(kept) and np.array_equal(kept[pos], ids):
            return cells[pos]
        return None

    def flag_pass(self, origin, h, G, table):
        """:func:`~.lean.flag_pass` over these cells (the first round of the cells that
        can meet); at the grid the summary's sweep flagged at, its result (no pass)."""
        from predicates.registration.plan.lean import flag_pass

        grid, first = self.first_grid, self._first
        self.first_grid = self._first = None  # asked once: used, or not the round's grid
        if grid is not None and table is grid.table:
            result, kept = first
            self.keep(None, *kept, mask=result[1][0])
            return result
        return flag_pass(self, origin, h, G, table)

    def summary(self) -> BoxSummary:
        """The boxes' :class:`BoxSummary`, one pass in blocks (spans on the pool)."""
        if self._summary is None and self.sweep_grid is not None \
                and not self.blocks.accelerate and self.n:
            from predicates.registration.plan.quiet import swept_summary

            self._summary, self._first = swept_summary(self, self.sweep_grid)
            self.first_grid = self.sweep_grid
        if self._summary is None:
            def span(a: int, b: int) -> BoxSummary:
                if self.blocks.accelerate:
                    return self._compiled_summary(a, b)
                out = summarize(*self.block(a, a))  # empty
                for s, t in self.blocks.each(a, b):
                    out = out.merge(summarize(*self.block(s, t)))
                return out

            parts = self.blocks.map(span, self.n) if self.n else [summarize(
                np.zeros((0, self.d)), np.zeros((0, self.d)))]
            out = parts[0]
            for p in parts[1:]:
                out = out.merge(p)
            self._summary = out
        return self._summary

    def checked_summary(self, used: np.ndarray, grid=None) -> BoxSummary | None:
        """Validation's cell check and :meth:`summary` in one pass (tetrahedra over
        finite points, compiled: :func:`predicates.compiled.tetsums.
        checked_summary_tetrahedra`), marking ``used`` (one bool per point): the
        summary (kept), or None at a row with an id outside [0, len(used)) or a
        repeated id — the cells are then checked as before, which names it. ``grid``:
        a :class:`~.first_round.FixedGrid` whose first-round flags the same sweep
        computes (``swept_tetrahedra``), kept in the summary's ``first``."""
        swept = None
        if grid is not None:
            from predicates.registration.plan.first_round import SweptFlags

            swept = SweptFlags(grid, self.cells.dtype, self.n, len(used))

        def span(a: int, b: int):
            rows = None if swept is None else swept.span(a, b)
            return self._compiled_summary(a, b, used, rows), rows

        parts = self.blocks.map(span, self.n)
        if any(p is None for p, _ in parts):
            return None
        out = parts[0][0]
        for p, _ in parts[1:]:
            out = out.merge(p)
        if swept is not None:
            out.first = (grid, swept.result([r for _, r in parts]))
        self._summary = out
        return out

    def _compiled_summary(self, a: int, b: int, used: np.ndarray | None = None,
                          flags=None) -> BoxSummary | None:
        """The :class:`BoxSummary` of rows [a, b) in one compiled loop per block
        (:func:`predicates.compiled.cellsums.summary_block`: the boxes in registers, the
        values of :func:`summarize`). ``used``: with validation's check
        (:meth:`checked_summary`; None at a row that fails it); ``flags``: a span's
        first-round output (``first_round._SpanRows``), the flags written by the same
        loop (:func:`~predicates.compiled.tetsums.swept_tetrahedra`)."""
        from predicates.compiled.tetsums import checked_summary_tetrahedra, swept_tetrahedra

        d, P = self.d, self._given()
        kernel = self._summary_kernel() if used is None else (
            lambda P, rows, *rest: checked_summary_tetrahedra(P, rows, used, *rest))
        if flags is not None:  # (used is given: the plan's checked sweep)
            def kernel(P, rows, *rest):
                got = swept_tetrahedra(P, rows, used, *rest, flags.args(s, t))
                flags.add(got[3], got[4])
                return got[:3]
        lo_min, hi_max = np.full(d, np.inf), np.full(d, -np.inf)
        hist, e_min, e_max = np.zeros(2048, dtype=np.int64), np.inf, -np.inf
        for s, t in self.blocks.each(a, b):
            got = kernel(P, self.cells[s:t], lo_min, hi_max, hist)
            if used is not None and got[0] < t - s:  # a row validation refuses
                return None
            low, top = got[-2:]
            e_min, e_max = min(e_min, low), max(e_max, top)
        ok = bool(np.isfinite(e_max)) and e_min >= 0
        return BoxSummary(b - a, lo_min, hi_max, float(e_max), float(e_min),
                          hist if ok else None)

    def _summary_kernel(self):
        """The compiled summary of a block: tetrahedra over finite points take
        :func:`predicates.compiled.tetsums.summary_tetrahedra` (the same values, about
        half the time), any other cells or points
        :func:`predicates.compiled.cellsums.summary_block`."""
        from predicates.compiled.cellsums import summary_block
        from predicates.compiled.tetsums import all_finite, summary_tetrahedra

        if self._tetrahedra is None:  # (a race of two spans computes it twice: the same)
            self._tetrahedra = (self.d == 3 and self.cells.shape[1] == 4
                                and bool(all_finite(self._given())))
        return summary_tetrahedra if self._tetrahedra else summary_block

    def column(self, side: int, ax: int) -> np.ndarray:
        """Axis ``ax`` of lo (side 0) or hi (side 1) for every cell (n floats)."""
        out = np.empty(self.n)

        def fill(a: int, b: int) -> None:
            out[a:b] = self.block(a, b)[side][:, ax]

        self.blocks.rows(fill, self.n)
        return out

    def array(self, side: int) -> np.ndarray:
        """lo (side 0) or hi (side 1) of every cell, materialised."""
        return self.rows(np.arange(self.n))[side]


class _Side:
    """``CellBoxes.lo`` or ``.hi`` as an (n, d) array-like (module docstring)."""

    def __init__(self, owner: CellBoxes, side: int):
        self.owner, self.side = owner, side
        self.shape = (owner.n, owner.d)
        self.dtype = np.dtype(np.float64)
        self.ndim = 2

    def __len__(self) -> int:
        return self.owner.n

    def __getitem__(self, key):
        o = self.owner
        if isinstance(key, slice) and key.step in (None, 1):
            a, b, _ = key.indices(o.n)
            return o.block(a, max(a, b))[self.side]
        if isinstance(key, tuple) and len(key) == 2 and key[0] == slice(None) \
                and isinstance(key[1], (int, np.integer)):
            return o.column(self.side, int(key[1]))
        if isinstance(key, tuple) and len(key) == 2 and isinstance(key[0], slice):
            return self[key[0]][:, key[1]]
        if isinstance(key, np.ndarray) and key.ndim == 1 and \
                (key.dtype == bool or key.dtype.kind in "iu"):
            if key.dtype == bool or len(key) < 2 or bool(np.all(key[1:] > key[:-1])):
                return o.rows(key)[self.side]
            order = np.argsort(key, kind="stable")
            out = np.empty((len(key), o.d))
            out[order] = o.rows(key[order])[self.side]
            return out
        return o.array(self.side)[key]

    def __array__(self, dtype=None, copy=None):
        a = self.owner.array(self.side)
        return a if dtype is None else a.astype(dtype)
