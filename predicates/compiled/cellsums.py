"""The plan's first pass over every simulation cell, compiled and GIL-free
(``nogil=True``; docs/partitioned.md section 2, "the lean plan"): validation's cell
checks with the used-vertex mask (:func:`check_cells`), and the boxes' summary
(:func:`summary_block`: hull, extrema and exponent histogram of each block, the boxes
computed in registers, no (d, m) temporaries), with
:func:`narrow_sums`, :class:`~predicates.registration.spatial.exactsum.ExactSum`'s
narrow path on an array; and the exact power-of-two scaling of the points with its
checks in one pass (:func:`scale_exact`); the report's pair-estimate grid without
(n, d) temporaries (:func:`pad_extents`, :func:`pad_index`); the first round's
summed-area tables of occupied grid cells in one pass (:func:`occupied_table`); the
shortest edge's renumbering of the used vertices (:func:`used_renumbered`); boxes
widened outwards by a pad (:func:`widened`: nextafter from the bits). Every
value is that of the numpy pass it replaces
(:mod:`predicates.compiled.cells` for the boxes' min/max rule).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .cells import _box_row

__all__ = ["check_cells", "narrow_sums", "occupied_table", "pad_extents", "pad_index",
           "scale_exact", "summary_block", "used_renumbered", "widened"]


@njit(**INLINE_OPTIONS)
def _clean_rows(arr, r, lim, used):
    """The first row from ``r`` on with an id outside [0, lim) or a repeated id (or m);
    the rows before it mark ``used``. k = 2, 3, 4 written out: one branch-free test per
    row (the generic loop's per-id branches cost 4× the pass on W4: 20 vs 5 ns/cell)."""
    k = arr.shape[1]
    m = arr.shape[0]
    while r < m:
        if k == 4:
            a, b, c, e = arr[r, 0], arr[r, 1], arr[r, 2], arr[r, 3]
            ok = ((a >= 0) & (a < lim) & (b >= 0) & (b < lim) & (c >= 0) & (c < lim)
                  & (e >= 0) & (e < lim) & (a != b) & (a != c) & (a != e) & (b != c)
                  & (b != e) & (c != e))
            if not ok:
                return r
            used[a] = True
            used[b] = True
            used[c] = True
            used[e] = True
        elif k == 3:
            a, b, c = arr[r, 0], arr[r, 1], arr[r, 2]
            ok = ((a >= 0) & (a < lim) & (b >= 0) & (b < lim) & (c >= 0) & (c < lim)
                  & (a != b) & (a != c) & (b != c))
            if not ok:
                return r
            used[a] = True
            used[b] = True
            used[c] = True
        elif k == 2:
            a, b = arr[r, 0], arr[r, 1]
            if not ((a >= 0) & (a < lim) & (b >= 0) & (b < lim) & (a != b)):
                return r
            used[a] = True
            used[b] = True
        else:
            return r
        r += 1
    return r


@njit(**JIT_OPTIONS)
def check_cells(arr, top, first, used):
    """:func:`predicates.registration.plan.inputs.first_bad` and the used-vertex mask
    in one pass over signed integer cells ``arr`` (m, k): ``first`` (3,) gets the first
    row with a negative id, one ≥ ``top`` (top < 0: no bound) and one repeating an id
    (−1: none, as given on entry); ``used[v]`` is set for every id in range. Clean
    rows (every id in [0, min(top, len(used))), none repeated) take
    :func:`_clean_rows`' test; any other row is classified id by id."""
    k = arr.shape[1]
    lim = used.shape[0] if top < 0 else min(top, used.shape[0])
    r = 0
    while r < arr.shape[0]:
        r = _clean_rows(arr, r, lim, used)
        if r >= arr.shape[0]:
            break
        neg = False
        out = False
        rep = False
        for c in range(k):
            v = arr[r, c]
            neg |= v < 0
            out |= (top >= 0) & (v >= top)
            for e in range(c + 1, k):
                rep |= v == arr[r, e]
            if v >= 0 and (top < 0 or v < top) and v < used.shape[0]:
                used[v] = True
        if neg and first[0] < 0:
            first[0] = r
        if out and first[1] < 0:
            first[1] = r
        if rep and first[2] < 0:
            first[2] = r
        r += 1


@njit(**INLINE_OPTIONS)
def _narrow_status(bad, pmin, pmax, tiny, spread):
    """:func:`narrow_sums`' status from a block's scan: 0 — the general path (a value
    not below ``big``, or a positive one below ``tiny``, or more than ``spread``
    binades), 1 — no positive value, 2 — the two float sums are exact."""
    if bad:
        return 0
    if pmax == 0.0:
        return 1
    if pmin < tiny:  # (subnormals too: tiny is normal)
        return 0
    e_lo = (np.int64(np.float64(pmin).view(np.int64)) >> 52) & 0x7FF  # frexp's exponents
    e_hi = (np.int64(np.float64(pmax).view(np.int64)) >> 52) & 0x7FF  # + 1022, normal
    return 0 if e_hi - e_lo > spread else 2


@njit(**JIT_OPTIONS)
def narrow_sums(x, big, tiny, spread, split):
    """:class:`predicates.registration.spatial.exactsum.ExactSum`'s narrow path on one
    block ``x`` (binary64 ≥ 0 or −0.0), when it applies: status 1 — no positive value
    (nothing to add); status 2 — (Σ high parts, Σ low parts), Veltkamp-split by ``split``
    as ``ExactSum._narrow`` splits them, each sum exact in any order (its docstring) so
    the same as numpy's pairwise sums; status 0 — the block needs the general path (a
    NaN, a value ≥ ``big``, a subnormal, a positive value below ``tiny`` or more than
    ``spread`` binades)."""
    pmin = np.inf
    pmax = 0.0
    for i in range(x.shape[0]):
        v = x[i]
        if not v < big:  # NaN, inf or huge
            return 0, 0.0, 0.0
        if v > 0.0:
            pmin = v if v < pmin else pmin
            pmax = v if v > pmax else pmax
    status = _narrow_status(False, pmin, pmax, tiny, spread)
    if status != 2:
        return status, 0.0, 0.0
    hs = 0.0
    ls = 0.0
    for i in range(x.shape[0]):
        v = x[i] + 0.0
        c = v * split
        h = c - (c - v)
        hs += h
        ls += v - h
    return 2, hs, ls


@njit(**INLINE_OPTIONS)
def _axis(x, y, lo, hi):
    """A box's side [x, y] on one axis: the hull ``lo``, ``hi`` updated (numpy's
    NaN-propagating min/max); returns its extent e = y − x and the hull."""
    lo = x if (x < lo) | (x != x) | (lo != lo) else lo
    hi = y if (y > hi) | (y != y) | (hi != hi) else hi
    return y - x, lo, hi


@njit(**INLINE_OPTIONS)
def _box3(points, rows, r):
    """Row r's box in 3D, (lo, hi) per axis: :func:`~predicates.compiled.cells._box_row`
    with the ids read once and four vertices (tetrahedra) written out — the generic
    loops' re-reads cost 2× the box pass on W4."""
    if rows.shape[1] != 4:
        x0, y0 = _box_row(points, rows, r, 0)
        x1, y1 = _box_row(points, rows, r, 1)
        x2, y2 = _box_row(points, rows, r, 2)
        return x0, y0, x1, y1, x2, y2
    i, j, k, m = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
    x0, y0 = _side4(points, i, j, k, m, 0)
    x1, y1 = _side4(points, i, j, k, m, 1)
    x2, y2 = _side4(points, i, j, k, m, 2)
    return x0, y0, x1, y1, x2, y2


@njit(**INLINE_OPTIONS)
def _side4(points, i, j, k, m, ax):
    """min, max of four vertices' coordinates on ``ax``, numpy's fold as
    :func:`~predicates.compiled.cells._box_row` (the second operand among equals,
    NaN propagating), each converted to binary64 exactly."""
    a = np.float64(points[i, ax])
    b = a
    for v in (j, k, m):
        x = np.float64(points[v, ax])
        a = a if (a < x) | (a != a) else x
        b = b if (b > x) | (b != b) else x
    return a, b


@njit(**INLINE_OPTIONS)
def _wider(top, e):
    """np.maximum(top, e): top unless e is larger or top is NaN."""
    return top if (top > e) | (top != top) else e


@njit(**INLINE_OPTIONS)
def _extrema(top, e_min, e_max):
    """A box's largest extent ``top`` into the least and the largest (the largest as
    the former box_summary kept it: NaN-propagating)."""
    e_min = top if top < e_min else e_min
    e_max = top if (top > e_max) | (top != top) | (e_max != e_max) else e_max
    return e_min, e_max


@njit(**JIT_OPTIONS)
def summary_block(points, rows, lo_min, hi_max, hist):
    """One block of rows ``rows`` over ``points`` of
    :meth:`predicates.registration.plan.cellboxes.CellBoxes.summary` in one loop: each
    row's box (:func:`~predicates.compiled.cells.fill_boxes`' values), the hull
    ``lo_min``/``hi_max`` (d,) updated (numpy's NaN-propagating min/max), the largest
    extent of each box (+ 0.0) counted in ``hist`` by its biased exponent (finite
    ones). Returns (least, largest) of the boxes' largest extents, the largest
    propagating NaN as numpy's. d = 3 in scalars, the exponent histogram counted by
    runs of one bin."""
    d = points.shape[1]
    e_min, e_max = np.inf, -np.inf
    if d == 3:
        a0, a1, a2 = lo_min[0], lo_min[1], lo_min[2]
        b0, b1, b2 = hi_max[0], hi_max[1], hi_max[2]
        last, run = 0, 0  # hist's current bin and its pending count (one bin
        # per row in memory cost 1.6× the pass: a store-to-load chain)
        for r in range(rows.shape[0]):
            x0, y0, x1, y1, x2, y2 = _box3(points, rows, r)
            e0, a0, b0 = _axis(x0, y0, a0, b0)
            e1, a1, b1 = _axis(x1, y1, a1, b1)
            e2, a2, b2 = _axis(x2, y2, a2, b2)
            top = _wider(_wider(e0, e1), e2) + 0.0  # −0.0 to +0.0 (as summarize)
            e_min, e_max = _extrema(top, e_min, e_max)
            if top < np.inf:  # finite (not NaN): counted, a run of one bin at a time
                b = (np.int64(np.float64(top).view(np.int64)) >> 52) & 0x7FF
                if b != last:
                    hist[last] += run
                    last, run = b, 0
                run += 1
        hist[last] += run
        lo_min[0], lo_min[1], lo_min[2] = a0, a1, a2
        hi_max[0], hi_max[1], hi_max[2] = b0, b1, b2
    else:
        for r in range(rows.shape[0]):
            top = 0.0
            for ax in range(d):
                x, y = _box_row(points, rows, r, ax)
                e, lo_min[ax], hi_max[ax] = _axis(x, y, lo_min[ax], hi_max[ax])
                top = e if ax == 0 else _wider(top, e)
            top = top + 0.0
            e_min, e_max = _extrema(top, e_min, e_max)
            if top < np.inf:  # finite (not NaN): counted
                hist[(np.int64(np.float64(top).view(np.int64)) >> 52) & 0x7FF] += 1
    return e_min, e_max


def scale_exact(points, out, factor, back, limit):
    """``out`` = ``points``·``factor`` (a power of two, a normal number of the points'
    dtype: one correctly rounded multiplication, as
    :func:`predicates.registration.plan.inputs.times_pow2`) and the two refusals of
    ``inputs._check_scaled`` in the same pass: (some scaled value is not finite or
    beyond ``limit``, some is inexact: y·``back`` ≠ x with back = 1/factor). C-ordered
    arrays go to :func:`_scale_rows` as one row (one long loop: ~20 % less time on W4's
    points than rows of three; elementwise, the same values)."""
    if points.flags.c_contiguous and out.flags.c_contiguous:
        return _scale_rows(points.reshape(1, -1), out.reshape(1, -1), factor, back, limit)
    return _scale_rows(points, out, factor, back, limit)


@njit(**JIT_OPTIONS)
def _scale_rows(points, out, factor, back, limit):
    """:func:`scale_exact` on (n, d) arrays, row by row."""
    over = False
    inexact = False
    for i in range(points.shape[0]):
        for j in range(points.shape[1]):
            x = points[i, j]
            y = x * factor
            out[i, j] = y
            over |= not abs(y) <= limit
            inexact |= y * back != x
    return over, inexact


@njit(**JIT_OPTIONS)
def pad_extents(lo, hi, h, ext, lo_min, hi_max):
    """The report's pair estimate (:func:`predicates.registration.plan.resolution.
    _estimate_grid`) on boxes (n, d) enlarged by h (lo − h, hi + h, rounded as numpy
    rounds them): each one's largest edge into ``ext`` (box_extent: np.maximum over the
    axes from axis 0) and the enlarged boxes' hull ``lo_min``/``hi_max`` (d,) updated
    (min and max: exact; a signed zero of the hull only moves the origin by nothing)."""
    if lo.shape[1] == 3:  # the hull in registers, not loaded and stored a row
        return _pad_extents3(lo, hi, h, ext, lo_min, hi_max)
    for r in range(lo.shape[0]):
        e = 0.0
        for ax in range(lo.shape[1]):
            a = lo[r, ax] - h
            b = hi[r, ax] + h
            lo_min[ax] = a if a < lo_min[ax] else lo_min[ax]
            hi_max[ax] = b if b > hi_max[ax] else hi_max[ax]
            x = b - a
            e = x if ax == 0 else (e if (e > x) | (e != e) else x)
        ext[r] = e


@njit(**INLINE_OPTIONS)
def _pad_axis(lo, hi, r, ax, h, low, top):
    """Box r's padded extent on ``ax``, the hull updated (:func:`pad_extents`')."""
    a = lo[r, ax] - h
    b = hi[r, ax] + h
    return b - a, (a if a < low else low), (b if b > top else top)


@njit(**INLINE_OPTIONS)
def _pad_extents3(lo, hi, h, ext, lo_min, hi_max):
    """:func:`pad_extents`, d = 3 (W1: 0.39 -> 0.29 ms, benchmarks/README.md s19-wplan)."""
    l0, l1, l2 = lo_min[0], lo_min[1], lo_min[2]
    m0, m1, m2 = hi_max[0], hi_max[1], hi_max[2]
    for r in range(lo.shape[0]):
        e, l0, m0 = _pad_axis(lo, hi, r, 0, h, l0, m0)
        x, l1, m1 = _pad_axis(lo, hi, r, 1, h, l1, m1)
        e = e if (e > x) | (e != e) else x
        x, l2, m2 = _pad_axis(lo, hi, r, 2, h, l2, m2)
        ext[r] = e if (e > x) | (e != e) else x
    lo_min[0], lo_min[1], lo_min[2] = l0, l1, l2
    hi_max[0], hi_max[1], hi_max[2] = m0, m1, m2


@njit(**JIT_OPTIONS)
def pad_index(lo, hi, h, origin, g, i0, i1):
    """floor((lo − h − origin)/g) and floor((hi + h − origin)/g) into ``i0``, ``i1``
    (n, d) binary64 (numpy's roundings in its order), and Σ over the boxes of
    Π_axes (i1 − i0 + 1), the product from axis 0 (a float sum of integers: exact
    below 2^53, and beyond it far above any budget it is compared with)."""
    total = 0.0
    for r in range(lo.shape[0]):
        c = 1.0
        for ax in range(lo.shape[1]):
            a = np.floor((lo[r, ax] - h - origin[ax]) / g)
            b = np.floor((hi[r, ax] + h - origin[ax]) / g)
            i0[r, ax] = a
            i1[r, ax] = b
            c = (b - a + 1) if ax == 0 else c * (b - a + 1)
        total += c
    return total


@njit(**JIT_OPTIONS)
def occupied_table(cover, S):
    """The summed-area table ``S`` (same 3D shape as ``cover``: the (G + 1)-grid,
    reversed axes, both C-ordered) of the occupied cells ``cover`` > 0: S[i, j, k] =
    the occupied cells i' < i, j' < j, k' < k — lean._table(cover > 0)'s integers
    (exact in any order): each row's running count, plus the row before, plus the
    plane before — unsigned streams that vectorise (W1's grid ~0.2 -> 0.08 ms against
    an inclusion–exclusion recurrence, benchmarks/README.md "s19-wplan")."""
    A, B, D = cover.shape
    flat, cv = S.reshape(-1), cover.reshape(-1)
    plane, row, one = np.uint64(B * D), np.uint64(D), np.uint64(1)
    S[0, :, :] = 0
    for i in range(1, A):
        base = np.uint64(i) * plane
        S[i, 0, :] = 0
        for j in range(1, B):
            at = base + np.uint64(j) * row
            src = (np.uint64(i - 1) * np.uint64(B) + np.uint64(j - 1)) * row
            flat[at] = 0
            run = 0
            for k in range(one, row):  # the row's running count of occupied cells
                run += 1 if cv[src + k - one] > 0 else 0
                flat[at + k] = run
            for k in range(row):  # plus the row before: the plane's 2D table
                flat[at + k] += flat[at - row + k]
        for x in range(plane):  # plus the plane before: the 3D table
            flat[base + x] += flat[base - plane + x]


def used_renumbered(cells, n_points: int):
    """(ids, C): the vertices ``cells`` (m, k) use, ascending (np.flatnonzero of the
    used mask), and the cells' ids renumbered into them, transposed to (k, m) — what
    :func:`predicates.registration.plan.edges.edge_summary` builds in numpy with a mask,
    a scatter and two gathers (three passes over the cells, ~25 ms on W4's run), here two
    passes over the cells and one over the points (:func:`_renumber`; its local ids in
    int32 below 2^31 points: half the memory traffic); integers only."""
    local = np.full(n_points, -1, np.int32 if n_points < 2 ** 31 else np.int64)
    return _renumber(cells, local)


@njit(**JIT_OPTIONS)
def _renumber(cells, local):
    """:func:`used_renumbered`'s passes: ``local`` (all −1 on entry) marks the used
    vertices (counted as they are first marked: ``ids`` allocated at its size — an
    array of every point, mostly untouched, cost W4's run ~8 ms more), then numbers
    them in ascending order; returns (ids, the cells renumbered, (k, m) int64)."""
    m, k = cells.shape
    count = 0
    for r in range(m):
        for v in range(k):
            c = cells[r, v]
            count += local[c] != 0
            local[c] = 0
    ids = np.empty(count, np.int64)
    count = 0
    for i in range(local.shape[0]):  # ascending: the used vertices numbered in order
        if local[i] == 0:
            local[i] = count
            ids[count] = i
            count += 1
    C = np.empty((k, m), np.int64)
    for r in range(m):
        for v in range(k):
            C[v, r] = local[cells[r, v]]
    return ids, C


@njit(**INLINE_OPTIONS)
def _next_down(y):
    """np.nextafter(y, −inf) from the bits: the next binary64 below y (−inf and NaN
    stay; ±0 gives the least negative subnormal; an ulp off any other y)."""
    if y != y or y == -np.inf:
        return y
    if y == 0.0:
        return -5e-324
    bits = np.float64(y).view(np.int64)
    return np.int64(bits - 1 if y > 0.0 else bits + 1).view(np.float64)


@njit(**INLINE_OPTIONS)
def _next_up(y):
    """np.nextafter(y, +inf) from the bits (as :func:`_next_down`, mirrored)."""
    if y != y or y == np.inf:
        return y
    if y == 0.0:
        return 5e-324
    bits = np.float64(y).view(np.int64)
    return np.int64(bits + 1 if y > 0.0 else bits - 1).view(np.float64)


@njit(**JIT_OPTIONS)
def widened(lo, hi, pad, tiny, out_lo, out_hi):
    """Boxes (n, d) widened outwards: nextafter(lo − p, −inf) − tiny and
    nextafter(hi + p, +inf) + tiny (``tiny`` = 0: not added) with p = ``pad``'s row r
    (one value: every row), numpy's roundings in its order
    (:func:`predicates.registration.spatial.boxgrid.enlarge`, ``refine._reach``)."""
    per_row = pad.shape[0] > 1
    for r in range(lo.shape[0]):
        p = pad[r] if per_row else pad[0]
        for ax in range(lo.shape[1]):
            a = _next_down(lo[r, ax] - p)
            b = _next_up(hi[r, ax] + p)
            if tiny != 0.0:
                a = a - tiny
                b = b + tiny
            out_lo[r, ax] = a
            out_hi[r, ax] = b
