"""The plan's per-cell passes, compiled and GIL-free (``nogil=True``): a partitioned
run's plan runs them on its thread pool block by block
(:mod:`predicates.registration.spatial.blocks`) and the threads truly overlap.

Each kernel computes exactly the values of the numpy pass it replaces:

* :func:`fill_boxes` — min and max of the cell's vertices per axis, with numpy's
  ``minimum``/``maximum`` choice among equal values (the second operand: ``-0.0`` vs
  ``0.0`` comes out as numpy's) and NaN propagation;
* :func:`cell_index`, :func:`point_index` — ``clip(floor((x − origin) / h), 0, G − 1)``:
  one subtraction, one division, floor; the same roundings as the numpy expression;
* :func:`add_corners`, :func:`look_corners` — the summed-area tables' ±1 at the 2^d
  corners of each box's cell range and the 2^d look-ups (integers: exact).

The lean plan's fused flag pass built from these is :mod:`predicates.compiled.flagpass`
(and :mod:`predicates.compiled.flagpack` for tetrahedra), the cells' least squared edge
:mod:`predicates.compiled.edgesquares`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .corners import corners2, corners3

__all__ = ["add_corners", "cell_index", "fill_boxes", "look_corners", "point_index"]


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
    is converted on reading, exactly); one pass over the rows, all axes per row. 3D
    triangles' and tetrahedra's ids once a row, unsigned (in range: the plan validated
    them; benchmarks/README.md s19-wplan and s23-cells), folded in the same order."""
    if points.shape[1] == 3 and rows.shape[1] == 4:
        for m in range(rows.shape[0]):
            i, j = np.uint64(rows[m, 0]), np.uint64(rows[m, 1])
            k, v = np.uint64(rows[m, 2]), np.uint64(rows[m, 3])
            for ax in range(3):
                x = np.float64(points[i, ax])
                a, b = _fold(x, x, np.float64(points[j, ax]))
                a, b = _fold(a, b, np.float64(points[k, ax]))
                lo[ax, m], hi[ax, m] = _fold(a, b, np.float64(points[v, ax]))
        return
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


@njit(**JIT_OPTIONS)
def point_index(points, origin, h, G, out):
    """Each point's grid cell per axis, ``out`` (N, d) int32: :func:`_index` of its
    binary64 coordinate (:func:`predicates.compiled.flagpass.flag_block_indexed` reads
    the cells' ranges from it)."""
    for r in range(points.shape[0]):
        for ax in range(points.shape[1]):
            out[r, ax] = _index(np.float64(points[r, ax]), origin[ax], h, G[ax] - 1)


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
