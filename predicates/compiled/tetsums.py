"""The boxes' summary of tetrahedra over finite points in one compiled loop
(:func:`summary_tetrahedra`): the values of
:func:`predicates.compiled.cellsums.summary_block` for d = 3, k = 4 when every
coordinate is finite (:func:`all_finite`; validation refuses any other used point,
:mod:`predicates.registration.plan.inputs`), at about half its cost.

Why it is faster (benchmarks/README.md, "Plan passes, eighth pass"): the general loop
keeps numpy's NaN propagation in every min/max select (two more compares each). On
finite values ``a if a < x else x`` is numpy's ``minimum(a, x)`` exactly (signed zeros
included: the second operand among equals), so the NaN tests go. Every floating-point
operation that makes a value (the extents y − x) is the general loop's. (Until 28 Nov
2026 both loops also summed the extents exactly per axis, for a mean extent nothing
has read since the first round's grid came from the cutting mesh: ~1/3 of the loop.)

:func:`checked_summary_tetrahedra` runs the same loop with validation's clean-row test
and the used-vertex marks (:func:`predicates.compiled.cellsums.check_cells`' fast path)
before each row's points are read: the plan reads the cells once for both
(docs/partitioned.md section 2; benchmarks/README.md, "Plan passes, eleventh pass").
:func:`swept_tetrahedra` adds the first round's flags; :func:`quiet_cells` gives the
grid cells' levels its shortcut reads (docs/resolution.md, "The first round").
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["all_finite", "checked_summary_tetrahedra", "quiet_cells",
           "summary_tetrahedra", "swept_tetrahedra"]


@njit(**JIT_OPTIONS)
def all_finite(points):
    """Is every value of ``points`` (N, d) finite? The largest exponent field of the
    values in binary64 (float32 converts exactly, infinities and NaN to theirs) is
    below all ones: an integer max over the flat array, which vectorises (a float
    test per value chained through one flag ran ~4x slower: W4's points 5.6 vs 1.5 ms)."""
    flat = points.reshape(-1) if points.flags.c_contiguous else points.copy().reshape(-1)
    top = np.int64(0)
    for i in range(flat.shape[0]):
        b = np.float64(flat[i]).view(np.int64) & 0x7FF0000000000000
        top = b if b > top else top
    return top != 0x7FF0000000000000


@njit(**INLINE_OPTIONS)
def _side(points, i, j, k, m, ax):
    """min, max of four vertices' coordinates on ``ax`` (finite), numpy's fold: the
    second operand among equals (:func:`~predicates.compiled.cellsums._side4`)."""
    a = np.float64(points[i, ax])
    b = a
    x = np.float64(points[j, ax])
    a = a if a < x else x
    b = b if b > x else x
    x = np.float64(points[k, ax])
    a = a if a < x else x
    b = b if b > x else x
    x = np.float64(points[m, ax])
    a = a if a < x else x
    b = b if b > x else x
    return a, b


@njit(**INLINE_OPTIONS)
def _less(x, a):
    """x if x < a else a: a running minimum's select (finite values)."""
    return x if x < a else a


@njit(**INLINE_OPTIONS)
def _more(y, b):
    """y if y > b else b: a running maximum's select (finite values)."""
    return y if y > b else b


@njit(**INLINE_OPTIONS)
def _clean(i, j, k, m, lim):
    """Are the ids in [0, lim) and distinct (:func:`~predicates.compiled.cellsums.
    _clean_rows`' test for k = 4)?"""
    return ((i >= 0) & (i < lim) & (j >= 0) & (j < lim) & (k >= 0) & (k < lim)
            & (m >= 0) & (m < lim) & (i != j) & (i != k) & (i != m) & (j != k)
            & (j != m) & (k != m))


@njit(**INLINE_OPTIONS)
def _cell(x, o, inv_h, top):
    """``clip(floor((x − o)·inv_h), 0, top)`` (:func:`~predicates.compiled.cells._index`
    when inv_h = 1/h is exact: h a power of two), clipped before it is rounded: on
    [0, top] the conversion's truncation is the floor, below 0 and above top both give
    the bound (no rounding instruction: ~0.7 ms of W1's sweep, benchmarks/README.md
    "s17-plan")."""
    t = (x - o) * inv_h
    t = 0.0 if t < 0 else t
    t = float(top) if t > top else t
    return np.int64(t)


@njit(**INLINE_OPTIONS)
def _corner_sum3(S, c0, c1, c2, d0, d1, d2):
    """The occupied cells of a range: the summed-area table's eight corners (low key
    terms c, high d; :func:`~predicates.compiled.cells._corner_sum`). Straight-line
    helpers only: numba's inlining of one with early returns cost 3–10x the loop."""
    return (np.int64(S[d0 + d1 + d2]) - np.int64(S[c0 + d1 + d2])
            - np.int64(S[d0 + c1 + d2]) - np.int64(S[d0 + d1 + c2])
            + np.int64(S[c0 + c1 + d2]) + np.int64(S[c0 + d1 + c2])
            + np.int64(S[d0 + c1 + c2]) - np.int64(S[c0 + c1 + c2]))


@njit(**INLINE_OPTIONS)
def _keep_row(i0, i1, fcells, flo, fhi, nf, u0, v0, w0, u1, v1, w1, i, j, k, m, x0, x1,
              x2, y0, y1, y2):
    """A flagged row's cell ranges, ids and box into row ``nf`` of the outputs; returns
    its largest box edge (np.maximum over the axes; finite: no NaN to propagate)."""
    i0[nf, 0], i0[nf, 1], i0[nf, 2] = u0, v0, w0
    i1[nf, 0], i1[nf, 1], i1[nf, 2] = u1, v1, w1
    fcells[nf, 0], fcells[nf, 1], fcells[nf, 2], fcells[nf, 3] = i, j, k, m
    flo[nf, 0], flo[nf, 1], flo[nf, 2] = x0, x1, x2
    fhi[nf, 0], fhi[nf, 1], fhi[nf, 2] = y0, y1, y2
    e = y0 - x0 if y0 - x0 > y1 - x1 else y1 - x1
    return e if e > y2 - x2 else y2 - x2


@njit(**INLINE_OPTIONS)
def _summary_rows(points, rows, used, lo_min, hi_max, hist, grid=None):
    """The loop of :func:`summary_tetrahedra`, :func:`checked_summary_tetrahedra` and
    :func:`swept_tetrahedra` (``used``, ``grid`` None: no check, no flags; numba prunes
    the branches); returns (rows read, least, largest extent, rows flagged, their
    largest box edge): the rows read stop at the first row that is not clean."""
    e_min, e_max, nf, ext = np.inf, -np.inf, 0, 0.0
    if grid is not None:  # unpacked once, not in the loop (a reference count a row)
        (origin, inv_h, last_cell, stride, S, levels, bound, quiet, near, i0, i1, flo, fhi,
         fcells) = grid
        one_at, two_at = 0.75 / inv_h, 1.75 / inv_h  # (R − 1/4)·h, exact (h = 2^k)
        o0, o1, o2 = origin[0], origin[1], origin[2]
        t0, t1, t2 = last_cell[0], last_cell[1], last_cell[2]
        s0, s1, s2 = stride[0], stride[1], stride[2]
    a0, a1, a2 = lo_min[0], lo_min[1], lo_min[2]
    b0, b1, b2 = hi_max[0], hi_max[1], hi_max[2]
    last, run = 0, 0  # hist's current bin and its pending count
    for r in range(rows.shape[0]):
        i, j, k, m = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
        # unsigned: no negative-index wraparound a gather (~15 % of the loop); the ids
        # are in range: checked here, or validated before a summary without ``used``
        ui, uj, uk, um = np.uint64(i), np.uint64(j), np.uint64(k), np.uint64(m)
        if used is not None:  # validation's test before any point is read
            if not _clean(i, j, k, m, used.shape[0]):
                return r, e_min, e_max, nf, ext
            used[ui] = used[uj] = used[uk] = used[um] = True
        x0, y0 = _side(points, ui, uj, uk, um, 0)
        x1, y1 = _side(points, ui, uj, uk, um, 1)
        x2, y2 = _side(points, ui, uj, uk, um, 2)
        a0, a1, a2 = _less(x0, a0), _less(x1, a1), _less(x2, a2)
        b0, b1, b2 = _more(y0, b0), _more(y1, b1), _more(y2, b2)
        e0, e1, e2 = y0 - x0, y1 - x1, y2 - x2
        t = e0 if e0 > e1 else e1
        top = (t if t > e2 else e2) + 0.0  # −0.0 to +0.0 (as summarize)
        e_min = top if top < e_min else e_min
        e_max = top if top > e_max else e_max
        if top < np.inf:  # finite: counted, a run of one bin at a time
            b = (np.int64(np.float64(top).view(np.int64)) >> 52) & 0x7FF
            if b != last:
                hist[last] += run
                last, run = b, 0
            run += 1
        if grid is not None:  # vertex i's level (quiet_level), once per point
            q = quiet[ui]
            if q == 255:
                q = _quiet_level(points, ui, o0, o1, o2, inv_h, t0, t1, t2, levels, bound)
                quiet[ui] = q
            if q >= 1 + (top >= one_at) + (top >= two_at):
                near[r] = False  # its range lies in the empty block around i's cell
                continue
        if grid is not None:  # the first round's flag (flag_tetrahedra_packed's test),
            # the box's cells: (x − o)·2^-k is (x − o)/h exactly (h = 2^k: the grid's)
            u0, u1 = _cell(x0, o0, inv_h, t0), _cell(y0, o0, inv_h, t0)
            v0, v1 = _cell(x1, o1, inv_h, t1), _cell(y1, o1, inv_h, t1)
            w0, w1 = _cell(x2, o2, inv_h, t2), _cell(y2, o2, inv_h, t2)
            # (no 2^d-block bit test before the sum: after the quiet levels it saved no
            # more than its table's pass cost, benchmarks/README.md "s17-plan")
            c0, c1, c2 = u0 * s0, v0 * s1, w0 * s2
            near[r] = _corner_sum3(S, c0, c1, c2, (u1 + 1) * s0, (v1 + 1) * s1,
                                   (w1 + 1) * s2) > 0
            if near[r]:  # kept: its ranges, ids and box, and its largest edge
                e = _keep_row(i0, i1, fcells, flo, fhi, nf, u0, v0, w0, u1, v1, w1, i, j,
                              k, m, x0, x1, x2, y0, y1, y2)
                nf, ext = nf + 1, (e if e > ext else ext)
    hist[last] += run
    lo_min[0], lo_min[1], lo_min[2] = a0, a1, a2
    hi_max[0], hi_max[1], hi_max[2] = b0, b1, b2
    return rows.shape[0], e_min, e_max, nf, ext


@njit(**JIT_OPTIONS)
def summary_tetrahedra(points, rows, lo_min, hi_max, hist):
    """:func:`~predicates.compiled.cellsums.summary_block` for tetrahedra ``rows``
    (m, 4) over finite ``points`` (N, 3), the same arguments and values (module
    docstring): the hull ``lo_min``/``hi_max`` updated, the largest extents' exponent
    histogram ``hist`` (finite ones, counted by runs of one bin); returns (least,
    largest) of the boxes' largest extents."""
    got = _summary_rows(points, rows, None, lo_min, hi_max, hist)
    return got[1], got[2]


@njit(**JIT_OPTIONS)
def checked_summary_tetrahedra(points, rows, used, lo_min, hi_max, hist):
    """Validation's cell check (:func:`~predicates.compiled.cellsums.check_cells`' clean
    rows: ids in [0, len(used)), none repeated; ``used`` marked) and
    :func:`summary_tetrahedra` in one pass over the cells (docs/partitioned.md section
    2): returns (rows read, least, largest extent). Fewer rows than given: that row is
    not clean, its points were not read and the outputs are not written (validation
    then names the problem from the cells alone)."""
    got = _summary_rows(points, rows, used, lo_min, hi_max, hist)
    return got[0], got[1], got[2]


@njit(**JIT_OPTIONS)
def swept_tetrahedra(points, rows, used, lo_min, hi_max, hist, grid):
    """:func:`checked_summary_tetrahedra` and the first round's flags of the same rows
    at a grid fixed before the sweep (:func:`predicates.compiled.flagpack.flag_row`,
    ``grid`` its tuple; docs/resolution.md, "The first round"): one read of the cells
    for validation, the summary and the flags. Returns (rows read, least, largest
    extent, rows flagged, their largest box edge)."""
    return _summary_rows(points, rows, used, lo_min, hi_max, hist, grid)


@njit(**JIT_OPTIONS)
def quiet_cells(S, G, stride, levels):
    """Per cell c of the grid (key c0 + G0·(c1 + G1·c2)): 2 when no cell of the 5^3
    block around c (clipped to the grid) is occupied, else 1 when none of the 3^3 block
    is, else 0 (the summed-area table ``S``). The block tests are separable (an
    occupied cell within Chebyshev distance R is one within R on each axis in turn):
    each cell's occupancy from ``S`` (along a row of x, T(x+1) − T(x), T the four y, z
    terms at x), then two bits — occupied within 1, within 2 — widened along x, y and z
    in turn: ~5 streamed byte reads a cell per axis instead of 16 look-ups a cell
    (benchmarks/README.md, "s19-wplan")."""
    s0, s1, s2 = stride[0], stride[1], stride[2]
    g0, g1, g2 = G[0], G[1], G[2]
    occ = np.empty(g0 + 4, dtype=np.uint8)  # one row's occupancy, two empty cells a side
    bits = np.empty(g0 * g1 * g2, dtype=np.uint8)  # (levels holds the first axis's)
    occ[0] = occ[1] = occ[g0 + 2] = occ[g0 + 3] = 0
    T = np.empty(g0 + 1, dtype=np.int64)
    for z in range(g2):  # (keys unsigned: no wraparound test a read)
        za, zb = np.uint64(z * s2), np.uint64((z + 1) * s2)
        for y in range(g1):
            ya, yb = np.uint64(y * s1), np.uint64((y + 1) * s1)
            aa, ab, ba, bb = ya + za, ya + zb, yb + za, yb + zb
            for x in range(np.uint64(g0 + 1)):  # T(x): four streams of the table
                u = x * np.uint64(s0)
                T[x] = (np.int64(S[u + bb]) - np.int64(S[u + ab]) - np.int64(S[u + ba])
                        + np.int64(S[u + aa]))
            for x in range(np.uint64(g0)):
                occ[x + 2] = T[x + 1] > T[x]
            row = np.uint64((z * g1 + y) * g0)
            for x in range(np.uint64(g0)):  # bit 0: occupied within 1 along x, bit 1: 2
                one = occ[x + 1] | occ[x + 2] | occ[x + 3]
                levels[row + x] = one | ((one | occ[x] | occ[x + 4]) << 1)
    _widen_bits(levels, g0, g0 * g1, g1, g2, bits, False)  # along y, in each z plane
    _widen_bits(bits, g0 * g1, g0 * g1 * g2, g2, 1, levels, True)  # along z: the levels


@njit(**INLINE_OPTIONS)
def _widen_bits(src, step, plane, n, planes, dst, last):
    """:func:`quiet_cells`' bits widened along one axis (``n`` cells ``step`` keys
    apart, in each of ``planes`` blocks of ``plane`` keys): bit 0 from the cells within
    1, bit 1 from those within 2 (clipped: a row repeated at the edge adds nothing to an
    or). ``last``: written as the levels, (1 − bit 0)·(2 − bit 1)."""
    for p in range(planes):
        base = p * plane
        for i in range(n):  # unsigned keys: no wraparound test a read (they vectorise)
            m2 = np.uint64(base + max(i - 2, 0) * step)
            m1 = np.uint64(base + max(i - 1, 0) * step)
            c = np.uint64(base + i * step)
            p1 = np.uint64(base + min(i + 1, n - 1) * step)
            p2 = np.uint64(base + min(i + 2, n - 1) * step)
            if last:
                for x in range(np.uint64(step)):
                    one = src[m1 + x] | src[c + x] | src[p1 + x]
                    two = one | src[m2 + x] | src[p2 + x]
                    dst[c + x] = (1 - (one & 1)) * (2 - ((two >> 1) & 1))
            else:
                for x in range(np.uint64(step)):
                    one = src[m1 + x] | src[c + x] | src[p1 + x]
                    two = one | src[m2 + x] | src[p2 + x]
                    dst[c + x] = (one & 1) | (two & 2)


@njit(**INLINE_OPTIONS)
def _quiet_level(points, p, o0, o1, o2, inv_h, t0, t1, t2, levels, bound):
    """Point p's level: its cell's :func:`quiet_cells` level when p is within ``bound``
    of the grid's origin on every axis (fl(x − o), as the flags compute it), else 0."""
    x0, x1, x2 = (np.float64(points[p, 0]), np.float64(points[p, 1]),
                  np.float64(points[p, 2]))
    inside = (abs(x0 - o0) <= bound) & (abs(x1 - o1) <= bound) & (abs(x2 - o2) <= bound)
    u, v, w = _cell(x0, o0, inv_h, t0), _cell(x1, o1, inv_h, t1), _cell(x2, o2, inv_h, t2)
    return levels[u + (t0 + 1) * (v + (t1 + 1) * w)] if inside else np.uint8(0)
