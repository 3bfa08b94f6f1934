"""The plan's per-cell passes, compiled and GIL-free (``nogil=True``): a partitioned
run's plan runs them on its thread pool block by block
(:mod:`predicates.registration.spatial.blocks`) and the threads truly overlap.

Each kernel computes exactly the values of the numpy pass it replaces:

* :func:`fill_boxes` — min and max of the cell's vertices per axis, with numpy's
  ``minimum``/``maximum`` choice among equal values (the second operand: ``-0.0`` vs
  ``0.0`` comes out as numpy's) and NaN propagation;
* :func:`cell_index` — ``clip(floor((x − origin) / h), 0, G − 1)``: one subtraction, one
  division, floor; the same roundings as the numpy expression;
* :func:`add_corners`, :func:`look_corners` — the summed-area tables' ±1 at the 2^d
  corners of each box's cell range and the 2^d look-ups (integers: exact).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .corners import corners2, corners3

__all__ = ["add_corners", "cell_index", "fill_boxes", "flag_block", "flag_block_indexed",
           "pair_bits", "point_index", "least_square_edge", "least_square_kernel",
           "least_square_tetrahedra", "least_square_triangles", "look_corners"]


@njit(**INLINE_OPTIONS)
def _fold(a, b, x):
    """np.minimum(a, x), np.maximum(b, x): a only if a < x or a NaN; `|` and a conditional
    expression (no short-circuit): a select, no branch to mispredict on random data."""
    return (a if (a < x) | (a != a) else x), (b if (b > x) | (b != b) else x)


@njit(**INLINE_OPTIONS)
def _box_row(points, rows, m, ax):
    """lo, hi of row m on axis ax: numpy's ``minimum``/``maximum`` fold over the
    vertices (module docstring), each coordinate converted to binary64 exactly."""
    a = b = np.float64(points[rows[m, 0], ax])
    for v in range(1, rows.shape[1]):
        a, b = _fold(a, b, np.float64(points[rows[m, v], ax]))
    return a, b


@njit(**JIT_OPTIONS)
def fill_boxes(points, rows, lo, hi):
    """As :func:`predicates.registration.spatial.boxes.fill_boxes`, from the points
    (N, d) and ``rows`` (m, k) as given (no transposed or float64 copy: each coordinate
    is converted on reading, exactly); one pass over the rows, all axes per row; 3D
    triangles' ids (in range) once a row, unsigned (benchmarks/README.md s19-wplan)."""
    for m in range(rows.shape[0]):
        if rows.shape[1] == 3 and points.shape[1] == 3:
            i, j, k = np.uint64(rows[m, 0]), np.uint64(rows[m, 1]), np.uint64(rows[m, 2])
            for ax in range(3):
                x = np.float64(points[i, ax])
                a, b = _fold(x, x, np.float64(points[j, ax]))
                lo[ax, m], hi[ax, m] = _fold(a, b, np.float64(points[k, ax]))
            continue
        for ax in range(points.shape[1]):
            lo[ax, m], hi[ax, m] = _box_row(points, rows, m, ax)


@njit(**INLINE_OPTIONS)
def _index(x, o, h, top):
    """``clip(floor((x − o) / h), 0, top)`` as int32 (boxgrid.cell_index's roundings),
    clipped before it is rounded (truncation is the floor on [0, top]: tetsums._cell)."""
    t = (x - o) / h
    t = 0.0 if t < 0 else t
    t = float(top) if t > top else t
    return np.int32(t)


@njit(**JIT_OPTIONS)
def cell_index(x, origin, h, G, out):
    """As :func:`predicates.registration.spatial.boxgrid.cell_index` (rows of x)."""
    for r in range(x.shape[0]):
        for ax in range(x.shape[1]):
            out[r, ax] = _index(x[r, ax], origin[ax], h, G[ax] - 1)


@njit(**INLINE_OPTIONS)
def _key(i0, i1, r, pick, stride):
    key = 0
    ups = 0
    for ax in range(i0.shape[1]):
        if pick >> ax & 1:
            key += (np.int64(i1[r, ax]) + 1) * stride[ax]
            ups += 1
        else:
            key += np.int64(i0[r, ax]) * stride[ax]
    sign = 1 if (i0.shape[1] - ups) % 2 == 0 else -1
    return key, sign


@njit(**INLINE_OPTIONS)
def _terms(i0, i1, r, ax, stride):
    """Box r's key terms on ``ax``: i0·stride, (i1 + 1)·stride, unsigned (cells ≥ 0)."""
    s = np.uint64(stride[ax])
    return np.uint64(i0[r, ax]) * s, (np.uint64(i1[r, ax]) + np.uint64(1)) * s


@njit(**JIT_OPTIONS)
def add_corners(i0, i1, stride, diff, flip):
    """``np.add.at(diff, key, ±sign)`` at every corner of every box (gridsums.coverage).
    d = 2 and 3 written out: the generic loop's per-corner, per-axis branches made it
    6–8× slower (W4's estimate: 81–108 vs 13 ms; benchmarks/README.md, "Part 2,
    fourth pass"). Integer adds: the same counts in any order."""
    v = -1 if flip else 1
    d = i0.shape[1]
    for r in range(i0.shape[0]):
        if d == 3:
            x0, x1 = _terms(i0, i1, r, 0, stride)
            y0, y1 = _terms(i0, i1, r, 1, stride)
            z0, z1 = _terms(i0, i1, r, 2, stride)
            corners3(diff, x0, x1, y0, y1, z0, z1, v)
        elif d == 2:
            x0, x1 = _terms(i0, i1, r, 0, stride)
            y0, y1 = _terms(i0, i1, r, 1, stride)
            corners2(diff, x0, x1, y0, y1, v)
        else:
            for pick in range(1 << d):
                key, sign = _key(i0, i1, r, pick, stride)
                diff[key] += -sign if flip else sign


@njit(**JIT_OPTIONS)
def look_corners(S, i0, i1, stride, out):
    """Per box: Σ ±S[corner] > 0 (gridsums.any_in); d = 2, 3 written out as in
    :func:`add_corners` (integer sums: exact in any order)."""
    d = i0.shape[1]
    for r in range(i0.shape[0]):
        count = 0
        if d == 3:
            x0, x1 = _terms(i0, i1, r, 0, stride)
            y0, y1 = _terms(i0, i1, r, 1, stride)
            z0, z1 = _terms(i0, i1, r, 2, stride)
            count = (np.int64(S[x1 + y1 + z1]) - np.int64(S[x0 + y1 + z1])
                     - np.int64(S[x1 + y0 + z1]) - np.int64(S[x1 + y1 + z0])
                     + np.int64(S[x0 + y0 + z1]) + np.int64(S[x0 + y1 + z0])
                     + np.int64(S[x1 + y0 + z0]) - np.int64(S[x0 + y0 + z0]))
        elif d == 2:
            x0, x1 = _terms(i0, i1, r, 0, stride)
            y0, y1 = _terms(i0, i1, r, 1, stride)
            count = (np.int64(S[x1 + y1]) - np.int64(S[x0 + y1]) - np.int64(S[x1 + y0])
                     + np.int64(S[x0 + y0]))
        else:
            for pick in range(1 << d):
                key, sign = _key(i0, i1, r, pick, stride)
                count += sign * np.int64(S[key])
        out[r] = count > 0


@njit(**INLINE_OPTIONS)
def _corner_loop(S, low_term, up_term):
    """Σ ±S[corner] over the 2^d corners of a cell range (per-axis key terms of the
    lower and the upper corner; integers: exact)."""
    d = low_term.shape[0]
    count = 0
    for pick in range(1 << d):
        key = 0
        ups = 0
        for ax in range(d):
            if pick >> ax & 1:
                key += up_term[ax]
                ups += 1
            else:
                key += low_term[ax]
        value = np.int64(S[key])
        count += value if (d - ups) % 2 == 0 else -value
    return count


@njit(**INLINE_OPTIONS)
def _corner_sum(S, low_term, up_term):
    """:func:`_corner_loop` for d = 3, unrolled (no per-corner branches: 2× the pass)."""
    l0, l1, l2 = low_term[0], low_term[1], low_term[2]
    u0, u1, u2 = up_term[0], up_term[1], up_term[2]
    return (np.int64(S[u0 + u1 + u2]) - np.int64(S[l0 + u1 + u2])
            - np.int64(S[u0 + l1 + u2]) - np.int64(S[u0 + u1 + l2])
            + np.int64(S[l0 + l1 + u2]) + np.int64(S[l0 + u1 + l2])
            + np.int64(S[u0 + l1 + l2]) - np.int64(S[l0 + l1 + l2]))


@njit(**JIT_OPTIONS)
def flag_block(points, rows, origin, h, G, stride, S, has_table, i0, i1, near):
    """One block of :func:`predicates.registration.plan.lean.flag_pass`, fused: each
    row's box (:func:`fill_boxes`), its cell range (:func:`cell_index`), the cells it
    covers (``ncells``, summed), and with a table ``S`` the flag ``near``
    (:func:`look_corners`: the 2^d corners' keys from per-axis terms, as
    gridsums._corners), the flagged rows' cell ranges, in order, into the first rows of
    ``i0``, ``i1`` (no mask pass after) and their largest box edge (``box_extent``: per
    row max over the axes of hi − lo, exact). Returns (cells covered, largest edge of
    the flagged rows or 0.0, rows flagged)."""
    d = points.shape[1]
    lo = np.empty(d)
    hi = np.empty(d)
    low_term = np.empty(d, dtype=np.int64)
    up_term = np.empty(d, dtype=np.int64)
    covered = 0
    ext = 0.0
    nf = 0  # rows flagged so far: row m's range is written at row nf, kept if flagged
    for m in range(rows.shape[0]):
        cells = 1
        for ax in range(d):
            lo[ax], hi[ax] = _box_row(points, rows, m, ax)
            j0 = _index(lo[ax], origin[ax], h, G[ax] - 1)
            j1 = _index(hi[ax], origin[ax], h, G[ax] - 1)
            i0[nf, ax], i1[nf, ax] = j0, j1
            low_term[ax] = np.int64(j0) * stride[ax]
            up_term[ax] = (np.int64(j1) + 1) * stride[ax]
            cells *= np.int64(j1) - j0 + 1
        covered += cells
        if not has_table:
            continue
        count = _corner_sum(S, low_term, up_term) if d == 3 else \
            _corner_loop(S, low_term, up_term)
        near[m] = count > 0
        if count > 0:
            nf += 1
            e = hi[0] - lo[0]
            for ax in range(1, d):
                x = hi[ax] - lo[ax]
                e = e if (e > x) | (e != e) else x  # np.maximum(e, x)
            ext = e if e > ext else ext  # Python's max(ext, e): e only when larger
    return covered, ext, nf


@njit(**JIT_OPTIONS)
def point_index(points, origin, h, G, out):
    """Each point's grid cell per axis, ``out`` (N, d) int32: :func:`_index` of its
    binary64 coordinate (:func:`flag_block_indexed` reads the cells' ranges from it)."""
    for r in range(points.shape[0]):
        for ax in range(points.shape[1]):
            out[r, ax] = _index(np.float64(points[r, ax]), origin[ax], h, G[ax] - 1)


@njit(**JIT_OPTIONS)
def pair_bits(S, G, stride, bits):
    """Per cell c of the (G + 1)-grid with c + 1 inside it on every axis: is any cell of
    the 2^d block [c, c + 1] occupied (its corner sum in the summed-area table ``S``
    > 0)? As bits of ``bits`` (uint8, little-endian bit order, key = the linear key of
    c). :func:`flag_block_indexed` decides a row whose range spans at most two cells
    per axis from one bit (a range inside the block: no occupied cell in the block,
    none in the range — the corner sum is a count of occupied cells)."""
    if G.shape[0] == 3:  # written out (W4's 1.8 M grid cells: 22.5 -> 15.6 ms)
        _pair_bits3(S, G, stride, bits)
        return
    d = G.shape[0]
    low = np.empty(d, dtype=np.int64)
    up = np.empty(d, dtype=np.int64)
    c = np.zeros(d, dtype=np.int64)  # the cell, axis 0 fastest (as the keys)
    total = 1
    for ax in range(d):
        total *= G[ax]
    for _ in range(total):  # every cell c ≤ G − 1: c + 1 ≤ G is on the (G + 1)-grid
        key = 0
        for ax in range(d):
            low[ax] = c[ax] * stride[ax]
            # the block's far corner c + 2, or G: the grid's last row holds no cell
            up[ax] = min(c[ax] + 2, G[ax]) * stride[ax]
            key += low[ax]
        count = _corner_sum(S, low, up) if d == 3 else _corner_loop(S, low, up)
        if count > 0:
            bits[key >> 3] |= np.uint8(1 << (key & 7))
        for ax in range(d):  # next cell
            c[ax] += 1
            if c[ax] < G[ax]:
                break
            c[ax] = 0


@njit(**INLINE_OPTIONS)
def _pair_bits3(S, G, stride, bits):
    """:func:`pair_bits` for d = 3: the cells in nested loops; along a row of x the
    corner sum (:func:`_corner_sum`'s eight terms) is T(x1) − T(x0) with T(x) the four
    terms at x, each T computed once a row (four loads a cell instead of eight; the
    same integers)."""
    s0, s1, s2 = stride[0], stride[1], stride[2]
    T = np.empty(G[0] + 1, dtype=np.int64)
    for z in range(G[2]):
        z0, z1 = z * s2, min(z + 2, G[2]) * s2
        for y in range(G[1]):
            y0, y1 = y * s1, min(y + 2, G[1]) * s1
            for x in range(G[0] + 1):
                u = x * s0
                T[x] = (np.int64(S[u + y1 + z1]) - np.int64(S[u + y0 + z1])
                        - np.int64(S[u + y1 + z0]) + np.int64(S[u + y0 + z0]))
            for x in range(G[0]):
                if T[min(x + 2, G[0])] - T[x] > 0:
                    key = x * s0 + y0 + z0
                    bits[key >> 3] |= np.uint8(1 << (key & 7))


@njit(**JIT_OPTIONS)
def flag_block_indexed(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi,
                       bits, fcells):
    """:func:`flag_block` from the vertices' grid cells ``index`` (:func:`point_index`)
    instead of each row's box: the same values, because the index
    ``clip(floor((x − o)/h), 0, G − 1)`` is a non-decreasing function of x (each
    rounding is monotone), so the index of the box's lo (the vertices' min) is the
    vertices' least index and that of hi their largest — no division per row, and the
    float box only for the flagged rows: their largest edge, and their boxes into the
    first rows of ``flo``, ``fhi`` (m, d) (kept for the later rounds and the report).
    ``bits`` (:func:`pair_bits`, or empty: not used) decides rows spanning at most two
    cells per axis without the table's 2^d scattered look-ups; the flagged rows' vertex
    ids into the first rows of ``fcells`` (m, k) (the run's cells, gathered here while
    the block is in cache). Returns as flag_block. Tetrahedra in 3D take
    :func:`predicates.compiled.flagpack.flag_tetrahedra_packed` instead (the plan's
    choice: the same values from one packed index a point)."""
    return _flag_rows(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi,
                      bits, fcells)


@njit(**INLINE_OPTIONS)
def _flagged(points, rows, m, nf, flo, fhi, fcells, ext):
    """A flagged row's boxes and vertex ids into row ``nf`` of ``flo``, ``fhi``,
    ``fcells`` and its largest edge (box_extent: np.maximum over the axes) into ``ext``
    (Python's max: only when larger)."""
    for v in range(rows.shape[1]):
        fcells[nf, v] = rows[m, v]
    e = 0.0
    for ax in range(points.shape[1]):
        a, b = _box_row(points, rows, m, ax)
        flo[nf, ax], fhi[nf, ax] = a, b
        x = b - a
        e = x if ax == 0 else (e if (e > x) | (e != e) else x)
    return e if e > ext else ext


@njit(**INLINE_OPTIONS)
def _flag_rows(points, index, rows, stride, S, has_table, i0, i1, near, flo, fhi, bits,
               fcells):
    """:func:`flag_block_indexed` on any d and k."""
    d = points.shape[1]
    k = rows.shape[1]
    low_term = np.empty(d, dtype=np.int64)
    up_term = np.empty(d, dtype=np.int64)
    covered = 0
    ext = 0.0
    nf = 0  # rows flagged so far: row m's range is written at row nf, kept if flagged
    use_bits = bits.shape[0] > 0
    for m in range(rows.shape[0]):
        cells = 1
        key = 0
        small = True  # at most two cells per axis
        for ax in range(d):
            j0 = index[rows[m, 0], ax]
            j1 = j0
            for v in range(1, k):
                j = index[rows[m, v], ax]
                j0 = j if j < j0 else j0
                j1 = j if j > j1 else j1
            i0[nf, ax], i1[nf, ax] = j0, j1
            low_term[ax] = np.int64(j0) * stride[ax]
            up_term[ax] = (np.int64(j1) + 1) * stride[ax]
            key += low_term[ax]
            small &= j1 - j0 <= 1
            cells *= np.int64(j1) - j0 + 1
        covered += cells
        if not has_table:
            continue
        if use_bits and small and (bits[key >> 3] >> (key & 7)) & 1 == 0:
            near[m] = False  # nothing occupied in the 2^d block holding the range
            continue
        count = _corner_sum(S, low_term, up_term) if d == 3 else \
            _corner_loop(S, low_term, up_term)
        near[m] = count > 0
        if count > 0:
            ext = _flagged(points, rows, m, nf, flo, fhi, fcells, ext)
            nf += 1
    return covered, ext, nf


@njit(**JIT_OPTIONS)
def least_square_edge(rows, C, a, b):
    """min over cells a … b − 1 (columns of ``C``, (k, m) vertex ids into ``rows``,
    (n, d) coordinates: a vertex's d values in one cache line) and their vertex pairs
    u < v of Σ_ax (x_u − x_v)², summed from axis 0 as
    :func:`predicates.registration.plan.edges.shortest_edge` sums (min: exact)."""
    best = np.inf
    for m in range(a, b):
        for u in range(C.shape[0]):
            for v in range(u + 1, C.shape[0]):
                t = rows[C[u, m], 0] - rows[C[v, m], 0]
                sq = t * t
                for ax in range(1, rows.shape[1]):
                    t = rows[C[u, m], ax] - rows[C[v, m], ax]
                    sq = sq + t * t
                if sq < best:
                    best = sq
    return best


@njit(**INLINE_OPTIONS)
def _square3(xu, yu, zu, xv, yv, zv):
    """(x_u − x_v)² + (y_u − y_v)² + (z_u − z_v)², summed from axis 0 as
    :func:`least_square_edge` sums it."""
    t = xu - xv
    sq = t * t
    t = yu - yv
    sq = sq + t * t
    t = zu - zv
    return sq + t * t


@njit(**JIT_OPTIONS)
def least_square_tetrahedra(rows, C, a, b):
    """:func:`least_square_edge` for tetrahedra in 3D (C (4, m), rows (n, 3)): each
    vertex's coordinates read once, not once per edge (a third of the time on W4's
    run); the same squares, compared in the same pair order (u < v), the same minimum."""
    best = np.inf
    for m in range(a, b):
        # unsigned: no wraparound test a gather (local ids: in range by construction)
        i, j, k, w = (np.uint64(C[0, m]), np.uint64(C[1, m]), np.uint64(C[2, m]),
                      np.uint64(C[3, m]))
        x0, y0, z0 = rows[i, 0], rows[i, 1], rows[i, 2]
        x1, y1, z1 = rows[j, 0], rows[j, 1], rows[j, 2]
        x2, y2, z2 = rows[k, 0], rows[k, 1], rows[k, 2]
        x3, y3, z3 = rows[w, 0], rows[w, 1], rows[w, 2]
        for sq in (_square3(x0, y0, z0, x1, y1, z1), _square3(x0, y0, z0, x2, y2, z2),
                   _square3(x0, y0, z0, x3, y3, z3), _square3(x1, y1, z1, x2, y2, z2),
                   _square3(x1, y1, z1, x3, y3, z3), _square3(x2, y2, z2, x3, y3, z3)):
            if sq < best:
                best = sq
    return best


@njit(**JIT_OPTIONS)
def least_square_triangles(rows, C, a, b):
    """:func:`least_square_tetrahedra` for triangles in 3D (C (3, m), rows (n, 3))."""
    best = np.inf
    for m in range(a, b):
        i, j, k = np.uint64(C[0, m]), np.uint64(C[1, m]), np.uint64(C[2, m])
        x0, y0, z0 = rows[i, 0], rows[i, 1], rows[i, 2]
        x1, y1, z1 = rows[j, 0], rows[j, 1], rows[j, 2]
        x2, y2, z2 = rows[k, 0], rows[k, 1], rows[k, 2]
        for sq in (_square3(x0, y0, z0, x1, y1, z1), _square3(x0, y0, z0, x2, y2, z2),
                   _square3(x1, y1, z1, x2, y2, z2)):
            if sq < best:
                best = sq
    return best


def least_square_kernel(d: int, k: int):
    """The least squared edge's kernel for cells of k vertices in d dimensions: the
    3D tetrahedra's and triangles' written out, :func:`least_square_edge` otherwise
    (the same value for every one)."""
    if d == 3 and k in (3, 4):
        return least_square_tetrahedra if k == 4 else least_square_triangles
    return least_square_edge
