"""The first round's flag pass over every simulation cell, without the cells' boxes in
memory (docs/partitioned.md, section 2, "the lean plan"; the round and its grid:
:mod:`~predicates.registration.plan.first_round`): one pass that recomputes each
block's boxes (:class:`~.cellboxes.CellBoxes`) and flags a cell when its cell range
holds a cell covered by an enlarged cutting box (a summed-area table of the cutting
occupancy: 2^d look-ups), keeping the flagged cells' ranges, boxes, ids and largest box
edge; :func:`cut_flags` then flags a cutting cell when its range holds a cell covered
by a flagged simulation cell. Compiled, the points' grid cells are computed once and
tetrahedra read them packed (:mod:`predicates.compiled.flagpack`).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial import blocks as blocks_module
from predicates.registration.spatial.boxes import box_extent, fill_boxes
from predicates.registration.spatial.boxgrid import cell_index, ncells
from predicates.registration.plan.quiet import _gathered, _joined
from predicates.registration.spatial.gridsums import (
    _stride, any_in, coverage, covered_in, occupancy)

__all__ = ["cut_flags", "flag_pass", "looked_up"]


def cut_flags(i0f, i1f, ib0, ib1, G, blocks) -> np.ndarray:
    """The cutting cells' flags: is a cell of the range [ib0, ib1] covered by a
    flagged simulation cell's range [i0f, i1f] (the same integer counts as
    near_flags's occupancy)."""
    if blocks.accelerate and len(G) == 3:  # any_in's look-ups on _occupied's table
        return looked_up(_occupied(i0f, i1f, G, blocks), ib0, ib1, G, blocks)
    return any_in(occupancy(i0f, i1f, G, blocks), ib0, ib1, G, blocks)


def looked_up(S: np.ndarray, ib0, ib1, G, blocks) -> np.ndarray:
    """:func:`any_in`'s flags of the ranges [ib0, ib1], compiled: the corner look-ups on
    an occupied cells' summed-area table ``S`` (flat; 3D)."""
    from predicates.compiled.cells import look_corners

    near_b = np.empty(len(ib0), dtype=bool)
    blocks.rows(lambda a, b: look_corners(S, ib0[a:b], ib1[a:b], _stride(G), near_b[a:b]),
                len(ib0))
    return near_b


def flag_pass(boxes, origin, h, G, table):
    """One pass over the cells' blocks at cell size h: (cells covered, (flags, the
    flagged cells' cell ranges i0, i1, their largest box edge)); the second item is
    None when ``table`` (the cutting occupancy's summed-area table) is None — a sparse
    grid: only the count. With a table the count is 0 (nothing reads it; the compiled
    sweep's is 0 too, first_round.SweptFlags). ``boxes``: a
    :class:`~.cellboxes.CellBoxes`. The numpy pass takes the shortcut of :mod:`.quiet`
    when the points' cells are cheap to compute (:func:`_quiet_cells`)."""
    d = len(G)
    near = np.zeros(len(boxes), dtype=bool) if table is not None else None
    if boxes.blocks.accelerate:  # the same values, one compiled GIL-free loop per block
        span, indexed = _compiled_span(boxes, origin, h, G, table, near)
        chunks = [(p[0], p[2], p[1]) for p in boxes.blocks.map(span, len(boxes))]
        parts = [(c, [x[0] for x in ch], [x[1] for x in ch], e) for c, e, ch in chunks]
        if table is not None and indexed:  # the flagged rows' boxes and ids, kept
            k = boxes.cells.shape[1]
            kept = [_joined([x[2 + s] for _, _, ch in chunks for x in ch],
                            np.zeros((0, d))) for s in (0, 1)]
            cells = _joined([x[4] for _, _, ch in chunks for x in ch],
                            np.zeros((0, k), dtype=boxes.cells.dtype))
            boxes.keep(None, *kept, cells, mask=near)  # (near: not written after,
            # so its rows are these; their ids found only if asked for)
        return _gathered(parts, table, near, d)

    quiet = _quiet_cells(boxes, origin, h, G, table)
    if quiet is not None:  # the same flags, ranges and edge: most rows by the shortcut
        parts = boxes.blocks.map(
            lambda a, b: _quiet_span(boxes, quiet, table, G, near, a, b), len(boxes))
        _keep_flagged(boxes, parts, near, d)
        return _gathered(parts, table, near, d)

    def span(a: int, b: int):
        count, ext, r0, r1 = 0, 0.0, [], []
        for s, t in boxes.blocks.each(a, b):
            lo, hi = boxes.block(s, t)
            i0, i1 = cell_index(lo, origin, h, G), cell_index(hi, origin, h, G)
            if table is None:
                count += int(ncells(i0, i1).sum())
                continue
            f = covered_in(table, i0, i1, G)
            near[s:t] = f
            if f.any():
                r0.append(i0[f])
                r1.append(i1[f])
                ext = max(ext, float(box_extent(lo[f], hi[f]).max()))
        return count, r0, r1, ext

    return _gathered(boxes.blocks.map(span, len(boxes)), table, near, d)


def _quiet_cells(boxes, origin, h, G, table):
    """The points' cells for :func:`_quiet_span` (:func:`~.quiet.point_cells`) when the
    pass has a table and the cells' vertex ids span at most as many points as the cells
    have vertices (a worker's chunk: only the points between its least and largest
    id), as (their :class:`~.quiet.PointCells`, the least id); else None."""
    from predicates.registration.plan.quiet import chunk_point_cells

    if table is None or boxes.cells.shape[1] < 2:
        return None
    return chunk_point_cells(boxes, origin, h, G, table, boxes.blocks)


def _quiet_span(boxes, quiet, table, G, near, a: int, b: int):
    """:func:`flag_pass`'s span over rows [a, b) with the shortcut (:mod:`.quiet`):
    the ranges from the points' cells, the look-ups only on the rows it leaves; the
    flagged rows' boxes (their largest edge), kept with their cells."""
    cells, low = quiet
    mode = "clip" if boxes.checked else "raise"
    cols = boxes.columns()
    r0, r1, ext, lo_k, hi_k, cells_k = [], [], 0.0, [], [], []
    for s, t in boxes.blocks.each(a, b):
        R = np.ascontiguousarray(boxes.cells[s:t].T)
        R = R - low if low else R  # (a new array: R may be the caller's cells)
        i0, i1, skip = cells.ranges(R, mode)
        rest = np.flatnonzero(~skip)
        if len(rest) == 0:
            continue
        hit = covered_in(table, i0[:, rest].T, i1[:, rest].T, G)
        if not hit.any():
            continue
        ids = rest[hit]
        near[s + ids] = True  # (near: zeros, each row written by its own span)
        r0.append(np.ascontiguousarray(i0[:, ids].T))
        r1.append(np.ascontiguousarray(i1[:, ids].T))
        flagged = boxes.cells[s + ids]
        lo, hi = np.empty((len(G), len(ids))), np.empty((len(G), len(ids)))
        fill_boxes(cols, np.ascontiguousarray(flagged.T), lo, hi, boxes.checked)
        lo, hi = lo.T, hi.T
        ext = max(ext, float(box_extent(lo, hi).max()))
        lo_k.append(lo)
        hi_k.append(hi)
        cells_k.append(flagged)
    return 0, r0, r1, ext, (lo_k, hi_k, cells_k)


def _keep_flagged(boxes, parts, near, d) -> None:
    """Keep the flagged rows' boxes and cells (:meth:`~.cellboxes.CellBoxes.keep`) that
    the spans of :func:`_quiet_span` computed: the plan's later ``rows(near)`` and
    ``cells_of(near)`` then gather nothing."""
    k = boxes.cells.shape[1]
    lo, hi = (_joined([x for p in parts for x in p[4][s]], np.zeros((0, d))) for s in (0, 1))
    cells = _joined([x for p in parts for x in p[4][2]],
                    np.zeros((0, k), dtype=boxes.cells.dtype))
    boxes.keep(None, lo, hi, cells, mask=near)


def _compiled_span(boxes, origin, h, G, table, near):
    """(:func:`flag_pass`'s span, whether the flagged rows' boxes and ids are kept):
    each block one call of the fused kernel (:func:`predicates.compiled.flagpass.
    flag_block`), which writes the flagged rows' cell ranges (and boxes, ids)
    compacted straight into the span's output arrays (no copies). With at least as many
    cells as points, the points' grid cells are computed first, once (N·d divisions
    instead of 2·d per cell; ``flag_block_indexed``: the same values), for tetrahedra
    packed into one int64 a point (:mod:`predicates.compiled.flagpack`)."""
    from predicates.compiled.cells import point_index
    from predicates.compiled.flagpass import flag_block, flag_block_indexed, pair_bits
    from predicates.compiled.flagpack import flag_tetrahedra_packed, pack_index

    P = np.ascontiguousarray(boxes.points)
    o, G_ = np.asarray(origin, dtype=np.float64), np.asarray(G, dtype=np.int64)
    S = np.zeros(1, dtype=np.int32) if table is None else table
    stride = _stride(G)
    flags = np.zeros(1, dtype=bool) if near is None else near
    index, bits = None, np.zeros(0, dtype=np.uint8)
    packed = P.shape[1] == 3 and boxes.cells.shape[1] == 4  # tetrahedra: flagpack.py
    if len(boxes) >= len(P):  # (a worker's small chunk: per row, not all points)
        index = np.empty(len(P) if packed else P.shape, dtype=np.int64 if packed else np.int32)
        fill = pack_index if packed else point_index
        boxes.blocks.rows(lambda a, b: fill(P[a:b], o, float(h), G_, index[a:b]), len(P))
        if table is not None and len(boxes) >= len(table) // 8:  # a pass over the grid
            bits = np.zeros(len(table) // 8 + 1, dtype=np.uint8)
            pair_bits(S, G_, stride, bits)
    indexed = index is not None

    def block(s: int, t: int, i0, i1, flo, fhi, fcells):
        out = flags[s:t] if near is not None else flags
        if index is not None:
            kernel = flag_tetrahedra_packed if packed else flag_block_indexed
            return kernel(P, index, boxes.cells[s:t], stride, S, table is not None, i0, i1,
                          out, flo, fhi, bits, fcells)
        return flag_block(P, boxes.cells[s:t], o, float(h), G_, stride, S,
                          table is not None, i0, i1, out)

    def span(a: int, b: int):
        count, ext, chunks, out, filled = 0, 0.0, [], None, 0
        step = boxes.blocks.block or blocks_module.BLOCK
        for s, t in boxes.blocks.each(a, b):
            if out is None or filled + (t - s) > len(out[0]):  # (a chunk is full)
                if out is not None:
                    chunks.append(tuple(x[:filled] for x in out))
                out, filled = _outputs(max(t - s, (b - a) // 4 + step), indexed), 0
            n, e, nf = block(s, t, *(x[filled:] for x in out))
            count += int(n) if table is None else 0
            if nf:  # the kernel wrote the flagged rows compacted, from row ``filled``
                filled += nf
                ext = max(ext, float(e))
        if out is not None:
            chunks.append(tuple(x[:filled] for x in out))
        return count, chunks, ext

    def _outputs(rows: int, boxes_too: bool):
        """Arrays for ``rows`` flagged rows: ranges i0, i1; boxes lo, hi and ids when
        ``boxes_too``. Written in place by the kernel and returned as views: a serial
        pass copies nothing (a quarter of the span's rows first: untouched pages of
        np.empty cost no memory)."""
        k, m = boxes.cells.shape[1], rows if boxes_too else 0
        return (np.empty((rows, len(G)), np.int32), np.empty((rows, len(G)), np.int32),
                np.empty((m, len(G))), np.empty((m, len(G))),
                np.empty((m, k), dtype=boxes.cells.dtype))

    return span, indexed


def _occupied(i0, i1, G, blocks) -> np.ndarray:
    """``_table(occupancy(i0, i1, G, blocks))``: compiled in 3D from the coverage counts
    in one pass (:func:`predicates.compiled.cellsums.occupied_table`: the same
    integers)."""
    if not (blocks.accelerate and len(G) == 3):
        return _table(occupancy(i0, i1, G, blocks))
    from predicates.compiled.cellsums import occupied_table

    cover = coverage(i0, i1, G, blocks, np.int32 if len(i0) < 2 ** 31 - 1 else np.int64)
    S = np.empty(cover.shape, dtype=np.int32 if cover.size < 2 ** 31 else np.int64)
    occupied_table(cover, S)
    return S.ravel()


def _table(occ: np.ndarray) -> np.ndarray:
    """The summed-area table of ``occ`` over the (G + 1)-grid, raveled (as
    :func:`~predicates.registration.spatial.gridsums.any_in` builds it)."""
    S = np.zeros(occ.shape, dtype=np.int32 if occ.size < 2 ** 31 else np.int64)
    S[tuple(slice(1, None) for _ in range(occ.ndim))] = \
        occ[tuple(slice(None, -1) for _ in range(occ.ndim))]
    for ax in range(S.ndim):
        np.cumsum(S, axis=ax, out=S)
    return S.ravel()
