"""Broad phase of the registration (section 1 of the paper): every pair of boxes within
a distance ``pad`` of each other, in sub-quadratic time (uniform grid hashing,
vectorised with numpy).

The test a pair must pass is, per axis, ``F[lo_b − hi_a] ≤ pad`` and
``F[lo_a − hi_b] ≤ pad`` (``pad`` a binary64 number). Rounding to nearest is monotone,
so every pair whose *exact* gap is ≤ pad passes: no pair the narrow phase could
register is lost, whatever the coordinates' magnitude. The grid only proposes pairs:

* cell size h ≈ the larger mean box extent (at least 2^-20 of the span, so cell
  coordinates fit 21 bits per axis), doubled while boxes would cover too many cells;
* the b boxes are enlarged by ``pad`` (rounded outwards with ``nextafter``), both sets
  are binned, and the pairs sharing a cell are enumerated by a sort-merge join;
* a pair is emitted only in the cell holding the lower corner of the two (enlarged)
  boxes' overlap — the cell max(i0_a, i0_b) per axis, the cell index being monotone —
  so it is produced exactly once without a global ``unique``.

Work and memory are O((n_a + n_b)·cells per box + pairs), processed in chunks of at most
``chunk`` proposed pairs.
"""
from __future__ import annotations

import numpy as np

__all__ = ["box_pairs", "box_pairs_bruteforce", "near_flags"]

_BITS = 20  # at most 2^20 + 1 cells per axis: linear keys fit in int64


def box_pairs_bruteforce(lo_a, hi_a, lo_b, hi_b, pad):
    """Reference: all pairs by the same test, O(n_a·n_b) (for tests only)."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    ok = np.all((lo_b[None] - hi_a[:, None] <= pad) & (lo_a[:, None] - hi_b[None] <= pad),
                axis=2)
    ia, ib = np.nonzero(ok)
    return ia, ib


def _cell_index(x, origin, h, G):
    with np.errstate(all="ignore"):
        i = np.floor((x - origin) / h)
    return np.clip(i, 0, G - 1).astype(np.int64)


def _linear(idx, G):
    key = idx[:, -1].copy()
    for ax in range(idx.shape[1] - 2, -1, -1):
        key *= G[ax]
        key += idx[:, ax]
    return key


def _entries(i0, i1, G, sort=True):
    """(box id, linear cell key) for every cell each box covers, sorted by key."""
    c = i1 - i0 + 1
    per = np.prod(c, axis=1)
    box = np.repeat(np.arange(len(c)), per)
    start = np.cumsum(per) - per
    t = np.arange(box.size, dtype=np.int64) - np.repeat(start, per)
    idx = np.empty((box.size, c.shape[1]), dtype=np.int64)
    for ax in range(c.shape[1]):
        cb = c[box, ax]
        idx[:, ax] = i0[box, ax] + t % cb
        t //= cb
    key = _linear(idx, G)
    if not sort:
        return box, key
    order = np.argsort(key, kind="stable")
    return box[order], key[order]


def _runs(sorted_keys):
    """Unique keys of a sorted array with the start and length of each run."""
    if sorted_keys.size == 0:
        e = np.zeros(0, dtype=np.int64)
        return e, e, e
    brk = np.flatnonzero(np.diff(sorted_keys)) + 1
    start = np.concatenate([[0], brk])
    count = np.diff(np.concatenate([start, [sorted_keys.size]]))
    return sorted_keys[start], start, count


def _grid(lo_a, hi_a, lo_b, hi_b, pad):
    """The grid: b boxes enlarged by pad (outwards), cell size, per-box cell ranges."""
    na, nb = len(lo_a), len(lo_b)
    pad = float(pad)
    if not pad >= 0:
        raise ValueError(f"pad must be a non-negative number, got {pad!r}")
    with np.errstate(over="ignore"):
        lo_bx = np.nextafter(lo_b - pad, -np.inf)
        hi_bx = np.nextafter(hi_b + pad, np.inf)
    origin = np.minimum(lo_a.min(axis=0), lo_bx.min(axis=0))
    top = np.maximum(hi_a.max(axis=0), hi_bx.max(axis=0))
    with np.errstate(over="ignore"):
        span = float((top - origin).max())
    if not np.isfinite(span):
        raise ValueError("coordinates too large for the broad phase (their range "
                         "overflows the floating-point format)")
    h = max(float((hi_a - lo_a).mean(axis=0).max()), float((hi_bx - lo_bx).mean(axis=0).max()))
    if h <= 0:
        h = span / max(1.0, (na + nb) ** (1 / lo_a.shape[1]))
    h = max(h, span * 2.0 ** -_BITS, np.finfo(np.float64).tiny)
    budget = 16 * (na + nb) + (1 << 20)
    while True:
        G = (np.floor((top - origin) / h).astype(np.int64) + 1).clip(1, (1 << _BITS) + 1)
        ia0, ia1 = _cell_index(lo_a, origin, h, G), _cell_index(hi_a, origin, h, G)
        ib0, ib1 = _cell_index(lo_bx, origin, h, G), _cell_index(hi_bx, origin, h, G)
        total = (np.prod(ia1 - ia0 + 1, axis=1).sum() + np.prod(ib1 - ib0 + 1, axis=1).sum())
        if total <= budget or np.all(G == 1):
            break
        h *= 2
    return G, ia0, ia1, ib0, ib1


def near_flags(lo_a, hi_a, lo_b, hi_b, pad: float):
    """(near_a, near_b): boolean masks, a superset of the boxes that have a partner
    within ``pad`` (same test as :func:`box_pairs`): a box is flagged when it shares a
    grid cell with a box of the other set. Cheaper than enumerating the pairs."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    near_a, near_b = np.zeros(len(lo_a), dtype=bool), np.zeros(len(lo_b), dtype=bool)
    if len(lo_a) == 0 or len(lo_b) == 0:
        return near_a, near_b
    G, ia0, ia1, ib0, ib1 = _grid(lo_a, hi_a, lo_b, hi_b, pad)
    box_a, key_a = _entries(ia0, ia1, G, sort=False)
    box_b, key_b = _entries(ib0, ib1, G, sort=False)
    if np.prod(G.astype(float)) <= 2.0 ** 26:
        occ_a = np.zeros(int(np.prod(G)), dtype=bool)
        occ_b = np.zeros(int(np.prod(G)), dtype=bool)
        occ_a[key_a] = True
        occ_b[key_b] = True
        hit_a, hit_b = occ_b[key_a], occ_a[key_b]
    else:
        hit_a = np.isin(key_a, key_b)
        hit_b = np.isin(key_b, key_a)
    near_a[box_a[hit_a]] = True
    near_b[box_b[hit_b]] = True
    return near_a, near_b


def box_pairs(lo_a, hi_a, lo_b, hi_b, pad: float, chunk: int = 1 << 22):
    """Yield (ia, ib) index arrays, together every pair of boxes a, b within ``pad``
    (see module docstring), each pair exactly once. Boxes are (n, d) arrays."""
    lo_a, hi_a, lo_b, hi_b = (np.asarray(x, dtype=np.float64) for x in (lo_a, hi_a, lo_b, hi_b))
    if len(lo_a) == 0 or len(lo_b) == 0:
        return
    pad = float(pad)
    G, ia0, ia1, ib0, ib1 = _grid(lo_a, hi_a, lo_b, hi_b, pad)
    box_a, key_a = _entries(ia0, ia1, G)
    box_b, key_b = _entries(ib0, ib1, G)
    ua, sa, ca = _runs(key_a)
    ub, sb, cb = _runs(key_b)
    cells, ja, jb = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
    if cells.size == 0:
        return
    sa, ca, sb, cb = sa[ja], ca[ja], sb[jb], cb[jb]
    npairs = ca * cb
    ends = np.cumsum(npairs)
    lo = 0
    while lo < cells.size:
        base = ends[lo - 1] if lo else 0
        hi = int(np.searchsorted(ends, base + chunk, side="right"))
        hi = max(hi, lo + 1)
        yield from _join(cells[lo:hi], sa[lo:hi], ca[lo:hi], sb[lo:hi], cb[lo:hi],
                         box_a, box_b, lo_a, hi_a, lo_b, hi_b, ia0, ib0, G, pad)
        lo = hi


def _join(cells, sa, ca, sb, cb, box_a, box_b, lo_a, hi_a, lo_b, hi_b, i0a, i0b, G, pad):
    # one row per (cell, a-entry), repeated once per b-entry of that cell: no division
    row_cell = np.repeat(np.arange(cells.size), ca)
    row_a = np.arange(row_cell.size, dtype=np.int64) - np.repeat(np.cumsum(ca) - ca, ca) \
        + sa[row_cell]
    q = cb[row_cell]
    ia = np.repeat(box_a[row_a], q)
    off = np.arange(ia.size, dtype=np.int64) - np.repeat(np.cumsum(q) - q, q)
    ib = box_b[np.repeat(sb[row_cell], q) + off]
    cell_key = np.repeat(cells[row_cell], q)
    # report each pair once: in the cell of the lower corner of the boxes' overlap
    ref = np.maximum(i0a[ia], i0b[ib])
    keep = _linear(ref, G) == cell_key
    ia, ib = ia[keep], ib[keep]
    ok = np.all((lo_b[ib] - hi_a[ia] <= pad) & (lo_a[ia] - hi_b[ib] <= pad), axis=1)
    if ok.any():
        yield ia[ok], ib[ok]
