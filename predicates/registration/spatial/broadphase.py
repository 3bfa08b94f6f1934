"""Broad phase of the registration (section 1 of the paper): every pair of boxes within
a distance ``pad`` of each other, in O(n log n + pairs) time and linear memory
(hierarchical grid hashing, vectorised with numpy).

The test a pair must pass is, per axis, ``F[lo_b − hi_a] ≤ pad`` and
``F[lo_a − hi_b] ≤ pad`` (``pad`` a binary64 number). Rounding to nearest is monotone,
so every pair whose *exact* gap is ≤ pad passes: no pair the narrow phase could
register is lost, whatever the coordinates' magnitude. The grid only proposes pairs:

* cell size h ≈ the larger mean box extent (at least 2^-20 of the span, so cell
  coordinates fit 21 bits per axis), doubled while boxes would cover too many cells;
* the b boxes are enlarged by ``pad`` (rounded outwards with ``nextafter``), both sets
  are binned (cell indices clipped to the grid, a monotone map: boxes that overlap get
  cell ranges that overlap), entries in cells the other set does not occupy are dropped,
  and the pairs sharing a cell are enumerated by a sort-merge join;
* a pair is emitted only in the cell holding the lower corner of the two (enlarged)
  boxes' overlap — the cell max(i0_a, i0_b) per axis, the cell index being monotone —
  so it is produced exactly once without a global ``unique``;
* a *crowded* cell (many more proposals than entries: tiny boxes clustered in a grid
  made coarse by large boxes elsewhere) is not enumerated: its boxes get a grid of their
  own over that cell, sized by *their* extents, recursively. Within it the same
  lower-corner rule makes each pair unique, and the parent keeps only the pairs whose
  lower corner falls in the crowded cell.

Work and memory are O((n_a + n_b)·cells per box + pairs), processed in chunks of at most
``chunk`` proposed pairs (a crowded cell that cannot be refined — boxes of similar size
all overlapping — is enumerated, also in chunks: there the pairs themselves are many).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import boxes_of
from predicates.registration.spatial.boxgrid import (
    BITS as _BITS, cell_index as _cell_index, colmax as _colmax, colmin as _colmin,
    enlarge as _enlarge, fit as _fit, grid as _grid, mean_extent as _mean_extent)
from predicates.registration.spatial.gridsums import any_in as _any_in, occupancy as _occupancy

__all__ = ["box_pairs", "box_pairs_bruteforce", "boxes_of", "near_flags", "tighten_flags"]

#: A cell is refined when its proposals exceed both of these (pairs; pairs per entry).
_CROWDED, _CROWD_RATIO = 1 << 12, 16
_MAX_DEPTH = 8
_DENSE = 1 << 26  # grids up to this many cells use dense occupancy arrays, when
_DENSE_PER_ENTRY = 8  # they have at most this many cells per box entry (or 2^16)
#: the compiled grid join's proposals per box before it defers to the refining join
_GRID_JOIN_PER_BOX = 64


def _dense(G, entries):
    cells = float(np.prod(G.astype(float)))
    return cells <= _DENSE and cells <= _DENSE_PER_ENTRY * entries + (1 << 16)


def box_pairs_bruteforce(lo_a, hi_a, lo_b, hi_b, pad):
    """Reference: all pairs by the same test, O(n_a·n_b) (for tests only)."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    ok = np.all((lo_b[None] - hi_a[:, None] <= pad) & (lo_a[:, None] - hi_b[None] <= pad),
                axis=2)
    ia, ib = np.nonzero(ok)
    return ia, ib


def _linear(idx, G):
    key = idx[:, -1].astype(np.int64)
    for ax in range(idx.shape[1] - 2, -1, -1):
        key *= G[ax]
        key += idx[:, ax]
    return key


def _entries(i0, i1, G):
    """(box id, linear cell key, start mask) for every cell each box covers (unsorted).
    Bit ``ax`` of the mask: the cell is the box's first on axis ``ax``; None when every
    box covers one cell. Expanded axis by axis, offset by offset, each pass touching only
    the boxes still that wide: O(entries) work, no division."""
    c = i1 - i0 + 1
    if len(c) == 0 or np.all(c == 1):  # the common case at a well-sized grid
        return np.arange(len(c)), _linear(i0, G), None
    box, idx = np.arange(len(c)), i0
    mask = np.full(len(c), (1 << len(G)) - 1, dtype=np.uint8)
    for ax in range(len(G)):
        rc = c[box, ax]
        sel = np.flatnonzero(rc > 1)
        parts, k = [(box, idx, mask)], 1
        while sel.size:
            moved = idx[sel]  # a copy (fancy indexing)
            moved[:, ax] += k
            parts.append((box[sel], moved, mask[sel] & np.uint8(~(1 << ax) & 0xFF)))
            k += 1
            sel = sel[rc[sel] > k]
        if len(parts) > 1:
            box, idx, mask = (np.concatenate(x) for x in zip(*parts))
    return box, _linear(idx, G), mask


def _runs(sorted_keys):
    """Unique keys of a sorted array with the start and length of each run."""
    if sorted_keys.size == 0:
        e = np.zeros(0, dtype=np.int64)
        return e, e, e
    brk = np.flatnonzero(sorted_keys[1:] != sorted_keys[:-1]) + 1
    start = np.concatenate([[0], brk])
    count = np.diff(np.concatenate([start, [sorted_keys.size]]))
    return sorted_keys[start], start, count


def _occupied(keys, other, G):
    """Mask of ``keys`` that occur in ``other`` (dense bitmap when the grid is small)."""
    if _dense(G, len(keys) + len(other)):
        occ = np.zeros(int(np.prod(G)), dtype=bool)
        occ[other] = True
        return occ[keys]
    return np.isin(keys, other, kind="sort")


def near_flags(lo_a, hi_a, lo_b, hi_b, pad: float, *, sides: str = "ab",
               blocks: Blocks = SERIAL):
    """(near_a, near_b): boolean masks, a superset of the boxes that have a partner
    within ``pad`` (same test as :func:`box_pairs`): a box is flagged when it shares a
    grid cell with a box of the other set (b boxes enlarged by pad). Cheaper than
    enumerating the pairs: on a dense grid no box is expanded into its cells (each
    side's occupancy comes from a difference array, each box's test from a summed-area
    table of the other side's occupancy), so the cost is O(2^d·(n_a + n_b) + cells).
    ``sides``: "a" or "b" computes only that side's flags (the other is None) and
    skips the occupancy it would need — the same flags, a pass over the many boxes
    saved (e.g. refinement only asks which simulation cells are near). ``blocks``: how
    the passes over the a boxes run (:mod:`~predicates.registration.spatial.blocks`: block by
    block, on a pool in a partitioned run's plan); the flags are the same."""
    if sides not in ("ab", "a", "b"):
        raise ValueError(f"sides must be 'ab', 'a' or 'b', got {sides!r}")
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    near_a = np.zeros(len(lo_a), dtype=bool) if "a" in sides else None
    near_b = np.zeros(len(lo_b), dtype=bool) if "b" in sides else None
    if len(lo_a) == 0 or len(lo_b) == 0:
        return near_a, near_b
    _, _, _, G, _, ia0, ia1, ib0, ib1 = _grid(lo_a, hi_a, lo_b, hi_b, pad, blocks)
    if _dense(G + 1, len(lo_a) + len(lo_b)):
        if "a" in sides:
            near_a = _any_in(_occupancy(ib0, ib1, G), ia0, ia1, G, blocks)
        if "b" in sides:
            # a b box meets an a box only in a cell that a box's own test finds: the
            # flagged a boxes' occupancy gives the same b flags (all a boxes otherwise)
            a0, a1 = (ia0, ia1) if near_a is None else (ia0[near_a], ia1[near_a])
            near_b = _any_in(_occupancy(a0, a1, G, blocks), ib0, ib1, G)
        return near_a, near_b
    box_a, key_a, _ = _entries(ia0, ia1, G)
    box_b, key_b, _ = _entries(ib0, ib1, G)
    if "a" in sides:
        near_a[box_a[_occupied(key_a, key_b, G)]] = True
    if "b" in sides:
        near_b[box_b[_occupied(key_b, key_a, G)]] = True
    return near_a, near_b


def tighten_flags(lo_a, hi_a, lo_b, hi_b, pad: float, per_box: float = 4.0,
                  blocks: Blocks = SERIAL):
    """Like :func:`near_flags` (a superset of the boxes with a partner within ``pad``),
    on a grid sized by the boxes' *number* — about ``per_box`` cells per box over their
    bounding region — rather than by their extent: applied to the boxes near_flags kept,
    it drops most of those that only shared a coarse cell. Summed-area tables, no
    expansion: O(2^d·n + cells). Returns all-True flags when no such grid fits."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    n = len(lo_a) + len(lo_b)
    keep = np.ones(len(lo_a), dtype=bool), np.ones(len(lo_b), dtype=bool)
    if len(lo_a) == 0 or len(lo_b) == 0:
        return keep
    lo_bx, hi_bx = _enlarge(lo_b, hi_b, pad)
    origin = np.minimum(_colmin(lo_a), _colmin(lo_bx))
    ext = np.maximum(_colmax(hi_a), _colmax(hi_bx)) - origin
    live = ext > 0
    if not (np.all(np.isfinite(ext)) and live.any()):
        return keep
    h = float(np.prod(ext[live]) / (per_box * n)) ** (1 / live.sum())
    h = max(h, float(ext.max()) * 2.0 ** -_BITS, np.finfo(np.float64).tiny)
    G = (np.floor(ext / h).astype(np.int64) + 1).clip(1, (1 << _BITS) + 1)
    if not _dense(G + 1, 2 * n):
        return keep
    ia0, ia1 = (_cell_index(x, origin, h, G, blocks) for x in (lo_a, hi_a))
    ib0, ib1 = (_cell_index(x, origin, h, G, blocks) for x in (lo_bx, hi_bx))
    occ_a, occ_b = _occupancy(ia0, ia1, G, blocks), _occupancy(ib0, ib1, G, blocks)
    return _any_in(occ_b, ia0, ia1, G, blocks), _any_in(occ_a, ib0, ib1, G, blocks)


def box_pairs(lo_a, hi_a, lo_b, hi_b, pad: float, chunk: int = 1 << 22,
              accelerate: bool = False):
    """Yield (ia, ib) index arrays, together every pair of boxes a, b within ``pad``
    (see module docstring), each pair exactly once. Boxes are (n, d) arrays.
    ``accelerate``: compiled (:mod:`predicates.compiled.gridjoin`): on a dense grid one
    bucketing and join pass (the same pairs, a ascending, in one part), else the
    cells' joins below (the same pairs in the same order)."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    if len(lo_a) == 0 or len(lo_b) == 0:
        return
    pad = float(pad)
    blocks = Blocks(accelerate=accelerate) if accelerate else SERIAL
    lo_bx, hi_bx, origin, G, h, ia0, ia1, ib0, ib1 = _grid(lo_a, hi_a, lo_b, hi_b, pad, blocks)
    cols = tuple(np.ascontiguousarray(x.T) for x in (lo_a, hi_a, lo_b, hi_b))
    boxes_ = (lo_a, hi_a, lo_b, hi_b, lo_bx, hi_bx, pad, cols, accelerate)
    if accelerate and _dense(G + 1, len(lo_a) + len(lo_b)):
        from predicates.compiled.gridjoin import grid_join

        # the same pairs on the same grid (a ascending), bucketed and joined in one
        # compiled pass; None: a crowded grid, left to the refining join below
        got = grid_join((ia0, ia1, ib0, ib1), G, pad, cols,
                        _GRID_JOIN_PER_BOX * (len(lo_a) + len(lo_b)) + (1 << 22))
        if got is not None:
            if len(got[0]):
                yield got
            return
    ids_a, ids_b = np.arange(len(lo_a)), np.arange(len(lo_b))
    if _dense(G + 1, len(lo_a) + len(lo_b)):
        # boxes sharing no grid cell with the other side: dropped before any expansion
        # into cells (summed-area tables, O(2^d) per box), e.g. the many simulation
        # cells far from a few cutting edges
        ka = _any_in(_occupancy(ib0, ib1, G, blocks), ia0, ia1, G, blocks)
        kb = _any_in(_occupancy(ia0, ia1, G, blocks), ib0, ib1, G, blocks)
        ids_a, ids_b = ids_a[ka], ids_b[kb]
        ia0, ia1, ib0, ib1 = ia0[ka], ia1[ka], ib0[kb], ib1[kb]
    yield from _level(boxes_, ids_a, ids_b, origin, G, h, (ia0, ia1, ib0, ib1), chunk, 0)


def _level(bx, ids_a, ids_b, origin, G, h, ranges, chunk, depth):
    """The pairs among boxes ``ids_a`` × ``ids_b`` (global ids) on one grid: sort-merge
    join per cell, crowded cells refined (see module docstring)."""
    ia0, ia1, ib0, ib1 = ranges
    box_a, key_a, mask_a = _entries(ia0, ia1, G)
    box_b, key_b, mask_b = _entries(ib0, ib1, G)
    if _dense(G, len(key_a) + len(key_b)):  # drop entries alone in their cell, then sort
        ka, kb = _occupied(key_a, key_b, G), _occupied(key_b, key_a, G)
        oa = np.flatnonzero(ka)[np.argsort(key_a[ka])]
        ob = np.flatnonzero(kb)[np.argsort(key_b[kb])]
        cells, sa, ca = _runs(key_a[oa])
        _, sb, cb = _runs(key_b[ob])  # both sides occupy exactly the same cells now
    else:  # sparse grid: sort everything, join the sorted runs
        oa, ob = np.argsort(key_a), np.argsort(key_b)
        ua, sa, ca = _runs(key_a[oa])
        ub, sb, cb = _runs(key_b[ob])
        cells, ja, jb = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
        sa, ca, sb, cb = sa[ja], ca[ja], sb[jb], cb[jb]
    box_a, box_b = box_a[oa], box_b[ob]
    mask_a = None if mask_a is None else mask_a[oa]
    mask_b = None if mask_b is None else mask_b[ob]
    del oa, ob, key_a, key_b
    yield from _emit(bx, ids_a, ids_b, origin, G, h, chunk, depth,
                     (cells, sa, ca, sb, cb, box_a, box_b, mask_a, mask_b))


def _emit(bx, ids_a, ids_b, origin, G, h, chunk, depth, runs):
    """The pairs of the cells shared by both sides, from their sorted entries ``runs`` =
    (cells, sa, ca, sb, cb, box_a, box_b, mask_a, mask_b): entries sa[k] … sa[k] + ca[k]
    of box_a (local ids into ids_a) are in cells[k], likewise b; masks as in
    :func:`_entries`. Crowded cells are refined, the others joined in chunks."""
    cells, sa, ca, sb, cb, box_a, box_b, mask_a, mask_b = runs
    if cells.size == 0:
        return
    npairs = ca * cb
    crowded = ((npairs > _CROWDED) & (npairs > _CROWD_RATIO * (ca + cb))
               if depth < _MAX_DEPTH else np.zeros(cells.size, dtype=bool))
    for k in np.flatnonzero(crowded):
        sub_a = box_a[sa[k]: sa[k] + ca[k]]
        sub_b = box_b[sb[k]: sb[k] + cb[k]]
        corner = origin + _unlinear(cells[k], G) * h
        for pa, pb in _refine(bx, ids_a[sub_a], ids_b[sub_b], corner, h, chunk, depth):
            # keep the pairs whose lower corner (on this grid) is this cell
            ref = np.maximum(_cell_index(bx[0][pa], origin, h, G),
                             _cell_index(bx[4][pb], origin, h, G))
            keep = _linear(ref, G) == cells[k]
            if keep.any():
                yield pa[keep], pb[keep]
    if crowded.any():
        npairs = np.where(crowded, 0, npairs)
    masks = None if mask_a is None and mask_b is None else (
        _full_mask(mask_a, len(box_a), G), _full_mask(mask_b, len(box_b), G), (1 << len(G)) - 1)
    ends = np.cumsum(npairs)
    gbox_a, gbox_b = ids_a[box_a], ids_b[box_b]
    lo = 0
    while lo < cells.size:
        base = ends[lo - 1] if lo else 0
        hi = max(int(np.searchsorted(ends, base + chunk, side="right")), lo + 1)
        if ends[hi - 1] > base:
            yield from _join(sa[lo:hi], ca[lo:hi], sb[lo:hi], np.where(npairs[lo:hi] > 0,
                             cb[lo:hi], 0), masks, gbox_a, gbox_b, bx)
        lo = hi


def _full_mask(mask, n, G):
    return np.full(n, (1 << len(G)) - 1, dtype=np.uint8) if mask is None else mask


def _unlinear(key, G):
    idx = np.empty(len(G), dtype=np.int64)
    for ax in range(len(G)):
        idx[ax] = key % G[ax]
        key //= G[ax]
    return idx.astype(np.float64)


def _refine(bx, ga, gb, corner, h, chunk, depth):
    """A crowded cell [corner, corner + h]: a grid of its own, sized by the extents of
    the boxes in it (clipped to the cell); enumerated directly when that does not help."""
    lo_a, hi_a, lo_bx, hi_bx = bx[0][ga], bx[1][ga], bx[4][gb], bx[5][gb]
    hs = max(_mean_extent(lo_a, hi_a, h), _mean_extent(lo_bx, hi_bx, h))
    hs = max(hs, h * 2.0 ** -_BITS, np.finfo(np.float64).tiny)
    if 2 * hs > h:  # boxes as large as the cell: refining cannot separate them
        yield from _all_pairs(bx, ga, gb, chunk)
        return
    top = corner + h
    G, hs, *ranges = _fit(lo_a, hi_a, lo_bx, hi_bx, corner, top, hs,
                          16 * (len(ga) + len(gb)) + (1 << 16))
    if 2 * hs > h:
        yield from _all_pairs(bx, ga, gb, chunk)
        return
    yield from _level(bx, ga, gb, corner, G, hs, ranges, chunk, depth + 1)


def _all_pairs(bx, ga, gb, chunk):
    """Every pair of ga × gb passing the exact test, in chunks of rows of ga."""
    step = max(1, chunk // max(1, len(gb)))
    for lo in range(0, len(ga), step):
        ia = np.repeat(ga[lo: lo + step], len(gb))
        ib = np.tile(gb, min(step, len(ga) - lo))
        yield from _exact(bx, ia, ib)


def _exact(bx, ia, ib):
    """The global pairs (ia, ib) passing the exact test (see :func:`_test`)."""
    lo_a, hi_a, lo_b, hi_b = bx[7]
    keep = _test(bx[6], lo_a, hi_a, lo_b, hi_b, ia, ib)
    if keep.size:
        yield ia[keep], ib[keep]


def _test(pad, lo_a, hi_a, lo_b, hi_b, ia, ib):
    """Positions of the pairs (ia, ib) passing F[lo_b − hi_a] ≤ pad and
    F[lo_a − hi_b] ≤ pad on every axis; boxes as (d, n) columns. Axis by axis, compacting
    the survivors."""
    pos = None
    for ax in range(len(lo_a)):  # take: faster than fancy indexing, same values
        ok = lo_b[ax].take(ib) - hi_a[ax].take(ia) <= pad
        ok &= lo_a[ax].take(ia) - hi_b[ax].take(ib) <= pad
        sel = np.flatnonzero(ok)
        ia, ib = ia.take(sel), ib.take(sel)
        pos = sel if pos is None else pos.take(sel)
    return pos


def _join(sa, ca, sb, q_cell, masks, gbox_a, gbox_b, bx):
    """All pairs of the cells given (entries sa[k] … sa[k] + ca[k] of side a against
    q_cell[k] entries from sb[k] of side b; q_cell = 0 for a crowded cell, handled by
    :func:`_refine`), each reported once: in the cell of the lower corner of the boxes'
    overlap, i.e. on every axis one of the two boxes starts in the cell. The boxes of
    these entries are gathered once, in entry order, so the pair test reads them almost
    sequentially."""
    if bx[8]:
        from predicates.compiled.boxtest import join

        ia, ib = join(sa, ca, sb, q_cell, masks, gbox_a, gbox_b, bx[6], bx[7])
        if len(ia):
            yield ia, ib
        return
    a0, a1 = sa[0], sa[-1] + ca[-1]
    b0, b1 = sb[0], sb[-1] + q_cell[-1]  # runs ascend with the cells on both sides
    row_cell = np.repeat(np.arange(len(ca)), ca)
    ea = np.arange(row_cell.size, dtype=np.int64) + np.repeat(sa - a0 - (np.cumsum(ca) - ca), ca)
    q = q_cell[row_cell]
    ea = np.repeat(ea, q)
    eb = np.arange(ea.size, dtype=np.int64) + np.repeat(sb[row_cell] - b0 - (np.cumsum(q) - q), q)
    if masks is not None:  # (take and flatnonzero: faster than fancy and bool indexing)
        ma, mb, full = masks
        m = ma[a0:a1].take(ea)
        m |= mb[b0:b1].take(eb)
        sel = np.flatnonzero(m == full)
        ea, eb = ea.take(sel), eb.take(sel)
    ga, gb = gbox_a[a0:a1], gbox_b[b0:b1]
    cols = [x.take(g, axis=1) for x, g in zip(bx[7], (ga, ga, gb, gb))]
    keep = _test(bx[6], *cols, ea, eb)
    if keep.size:
        yield ga[ea[keep]], gb[eb[keep]]


# -- the grid, for other modules (refine.py's size hashes) --------------------------------
cell_index = _cell_index  # cell of each coordinate, clipped to the grid
linear_key = _linear      # linear key of a cell index (d,) in a grid of shape G
runs = _runs              # unique keys of a sorted array, start and length of each run
pair_test = _test         # positions of the pairs passing box_pairs' exact test


def cell_entries(i0: np.ndarray, i1: np.ndarray, G: np.ndarray, sort: bool = True):
    """(box id, linear cell key) for every grid cell each box's range i0..i1 covers;
    sorted by key, then box id (``sort=False``: in no particular order)."""
    box, key, _ = _entries(i0, i1, G)
    if not sort:
        return box, key
    order = np.lexsort((box, key))
    return box[order], key[order]
