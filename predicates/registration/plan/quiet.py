"""The numpy first round's shortcuts (docs/resolution.md, "The first round"; the pass:
:func:`~.lean.flag_pass`): most simulation cells are far from the cut, and the pass
decides them without the summed-area table's 2^d look-ups.

* Each grid cell has a *distance*: the Chebyshev distance (in cells) to the nearest
  cell an enlarged cutting box covers, capped at :data:`CAP` (0: the cell itself is
  covered) — from the table's single-cell counts, by dilations (shifted ORs).
* Each point's grid cell is computed once (N·d divisions instead of 2·d per cell:
  :func:`point_cells`), with its cell's distance.
* A cell's range is then exact integers: the index is non-decreasing in x, so the
  cell of the box's lower corner (the least vertex coordinate) is the least of the
  vertices' cells, the upper likewise — the values ``cell_index`` gives the box.
* A cell whose range is at most w cells wide on every axis lies within w cells of its
  first vertex's cell (which lies in the range); if that vertex's distance exceeds w,
  no covered cell is in the range: not flagged. Only the other rows take the look-ups.

The same flags, ranges and edges as the plain pass (integers; no rounding argument).

:func:`swept_summary` is the numpy summary's pass with the flags at the speculative
grid (as the compiled sweep, :func:`predicates.compiled.tetsums.swept_tetrahedra`): it
has each row's box and largest edge e already, so it takes the sweep's float rule
instead (docs/resolution.md, "The sweep's shortcut": e < (R − 1/4)·h and the first
vertex more than R cells from every covered cell, R = 1, 2, within h·2^46 of the
origin). Both tested against the plain pass:
``tests/test_registration/test_quiet_pass.py``.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxgrid import cell_index
from predicates.registration.spatial.gridsums import covered_in

__all__ = ["CAP", "PointCells", "cell_distances", "chunk_point_cells", "id_span",
           "point_cells", "swept_summary"]

#: the distances kept: 0 .. CAP (CAP: CAP cells or more)
CAP = 3


def cell_distances(table: np.ndarray, G) -> np.ndarray:
    """Per grid cell (linear key axis 0 fastest, (G,) grid), the Chebyshev distance to
    the nearest covered cell, capped at :data:`CAP` (uint8): the single cells' counts
    are the table's differences along every axis (exact integers), dilated one cell
    at a time (an OR with each axis' neighbours, clipped to the grid)."""
    G = np.asarray(G, dtype=np.int64)
    d = len(G)
    S = table.reshape(tuple((G + 1)[::-1]))
    covered = S
    for ax in range(d):
        covered = np.diff(covered, axis=ax)
    near = covered > 0
    dist = np.full(near.shape, CAP, dtype=np.uint8)
    for r in range(CAP):
        dist[near & (dist == CAP)] = r  # within r cells, not within r − 1
        if r == CAP - 1:
            break
        for ax in range(d):  # one cell more on every axis: the cube around each
            lead, tail = [slice(None)] * d, [slice(None)] * d
            lead[ax], tail[ax] = slice(1, None), slice(None, -1)
            grown = near.copy()
            grown[tuple(lead)] |= near[tuple(tail)]
            grown[tuple(tail)] |= near[tuple(lead)]
            near = grown
    return dist.ravel()


class PointCells:
    """Every point's grid cell (``cells`` (d, N) int32, by axis) and its cell's
    distance (``dist`` (N,) uint8) at a first-round grid (:func:`point_cells`)."""

    def __init__(self, cells: np.ndarray, dist: np.ndarray):
        self.cells, self.dist = cells, dist

    def ranges(self, R: np.ndarray, mode: str):
        """(i0, i1) (d, m) int32: the cell ranges of the cells ``R`` (k, m) vertex ids
        (the least and largest of their vertices' cells per axis), and the rows the
        shortcut decides (module docstring): a bool per row, True = not flagged."""
        d, m = self.cells.shape[0], R.shape[1]
        i0, i1 = np.empty((d, m), dtype=np.int32), np.empty((d, m), dtype=np.int32)
        x = np.empty(m, dtype=np.int32)
        for ax in range(d):
            np.take(self.cells[ax], R[0], out=i0[ax], mode=mode)
            i1[ax] = i0[ax]
            for v in range(1, R.shape[0]):
                np.take(self.cells[ax], R[v], out=x, mode=mode)
                np.minimum(i0[ax], x, out=i0[ax])
                np.maximum(i1[ax], x, out=i1[ax])
        wide = np.subtract(i1[0], i0[0])
        for ax in range(1, d):
            np.maximum(wide, np.subtract(i1[ax], i0[ax], out=x), out=wide)
        quiet = np.take(self.dist, R[0], mode=mode) > wide
        return i0, i1, quiet


def id_span(boxes) -> tuple[int, int] | None:
    """(least, largest) vertex id of the cells ``boxes`` (a
    :class:`~.cellboxes.CellBoxes`): every point when the points are at most as many as
    the cells' vertices and the ids validated, else the cells' least and largest id
    (a worker's chunk); None when that span holds more points than the cells have
    vertices (the points' cells would cost more than they save) or is out of range."""
    n, N = boxes.n, len(boxes.points)
    most = n * boxes.cells.shape[1]
    if n == 0:
        return None
    if N <= most and boxes.checked:  # (validated ids: every one is in range)
        return 0, N - 1
    low, top = int(boxes.cells.min()), int(boxes.cells.max())
    if low < 0 or top >= N or top - low + 1 > most:
        return None
    return low, top


def point_cells(points: np.ndarray, origin, h: float, G, table: np.ndarray,
                blocks: Blocks) -> PointCells:
    """:class:`PointCells` of ``points`` (N, d) at the grid (origin, h, G) whose
    summed-area table is ``table``: ``cell_index`` of each coordinate in binary64 (the
    values it gives a box corner equal to it). Points no cell uses (never validated:
    perhaps not finite) get some cell, never read."""
    G = np.asarray(G, dtype=np.int64)
    d = len(G)
    cols = np.empty((d, len(points)), dtype=np.int32)
    with np.errstate(invalid="ignore"):  # (NaN of an unused point: some index)
        for ax in range(d):
            x = np.ascontiguousarray(points[:, ax], dtype=np.float64)[:, None]
            cols[ax] = cell_index(x, origin[ax:ax + 1], h, G[ax:ax + 1], blocks)[:, 0]
    key = cols[d - 1].astype(np.int64)
    for ax in range(d - 2, -1, -1):
        key *= G[ax]
        key += cols[ax]
    # (clip: an unused point's NaN made some index, perhaps outside the grid)
    return PointCells(cols, cell_distances(table, G).take(key, mode="clip"))


def chunk_point_cells(boxes, origin, h: float, G, table: np.ndarray,
                      blocks: Blocks) -> tuple[PointCells, int] | None:
    """(:func:`point_cells` of the points between the cells' least and largest vertex
    id (:func:`id_span`: every point, or a worker's chunk's span), that least id), or
    None when the span holds more points than the cells have vertices (the shortcut
    would cost more than it saves)."""
    span = id_span(boxes)
    if span is None:
        return None
    low, top = span
    return point_cells(boxes.points[low:top + 1], np.asarray(origin, dtype=np.float64), h,
                       G, table, blocks), low


def swept_summary(boxes, grid) -> tuple:
    """The numpy summary's pass with the first round's flags at ``grid`` (a
    :class:`~.first_round.FixedGrid`; every point finite), as the compiled sweep
    (docs/resolution.md, "The sweep's shortcut"): (the boxes' summary, ((0, (flags,
    flagged ranges i0, i1, their largest edge)), (their boxes lo, hi and cells))) —
    :func:`~.lean.flag_pass`'s result and what it keeps. A row whose largest box edge
    e is below (R − 1/4)·h and whose first vertex lies more than R cells from every
    covered cell (R = 1, 2; a vertex within h·2^46 of the origin) is not flagged; the
    others take ``cell_index`` of their box and the table's look-ups."""
    d, k, n = boxes.d, boxes.cells.shape[1], boxes.n
    origin, h, G = np.asarray(grid.origin, dtype=np.float64), float(grid.h), grid.G
    low, dist = _first_vertex_distances(boxes, origin, h, G, grid.table)
    one, two = 0.75 * h, 1.75 * h  # exact: h is a power of two (q > 2: CAP ≥ 3)
    near = np.zeros(n, dtype=bool)
    mode = "clip" if boxes.checked else "raise"

    def span(a: int, b: int):
        out, r0, r1, ext, kept = None, [], [], 0.0, ([], [], [])
        for s, t in boxes.blocks.each(a, b):
            lo, hi = boxes.block(s, t)
            part, e = boxes.summarized(lo, hi)  # (CellBoxes' summarize: no import cycle)
            out = part if out is None else out.merge(part)
            rest = np.arange(t - s)
            if dist is not None:
                q = np.take(dist, boxes.cells[s:t, 0] - low if low else boxes.cells[s:t, 0],
                            mode=mode)
                rest = np.flatnonzero(~(((q > 1) & (e < one)) | ((q > 2) & (e < two))))
            if len(rest) == 0:
                continue
            i0, i1 = (cell_index(x[rest], origin, h, G) for x in (lo, hi))
            hit = covered_in(grid.table, i0, i1, G)
            if hit.any():
                ids = rest[hit]
                near[s + ids] = True
                r0.append(i0[hit])
                r1.append(i1[hit])
                ext = max(ext, float(e[ids].max()))
                for x, y in zip(kept, (lo[ids], hi[ids], boxes.cells[s + ids])):
                    x.append(y)
        return out, r0, r1, ext, kept

    parts = boxes.blocks.map(span, n)
    summary = parts[0][0]
    for p in parts[1:]:
        summary = summary.merge(p[0])
    result = _gathered([(0,) + p[1:4] for p in parts], grid.table, near, d)
    kept = tuple(_joined([x for p in parts for x in p[4][s]], empty) for s, empty in
                 enumerate((np.zeros((0, d)), np.zeros((0, d)),
                            np.zeros((0, k), dtype=boxes.cells.dtype))))
    return summary, (result, kept)


def _first_vertex_distances(boxes, origin, h: float, G, table):
    """(least id, each point's :func:`cell_distances` value — 0 for a point farther
    than h·2^46 from the origin on an axis, where fl(x − o) may round by more than
    h/64) for the points between the cells' least and largest id, or (0, None) when
    they are more than the cells' vertices (the shortcut is then not taken)."""
    got = chunk_point_cells(boxes, origin, h, G, table, Blocks())
    if got is None:
        return 0, None
    dist, low = got[0].dist, got[1]
    pts = boxes.points[low:low + len(dist)]
    bound = h * 2.0 ** 46
    with np.errstate(invalid="ignore", over="ignore"):
        for ax in range(len(G)):
            far = ~(np.abs(pts[:, ax].astype(np.float64) - origin[ax]) <= bound)
            dist[far] = 0
    return low, dist


def _gathered(parts, table, near, d):
    """:func:`~.lean.flag_pass`'s result from its spans' (count, r0, r1, ext)."""
    count = sum(p[0] for p in parts)
    if table is None:
        return count, None
    empty = np.zeros((0, d), dtype=np.int32)
    r0, r1 = (_joined([x for p in parts for x in p[s]], empty) for s in (1, 2))
    return count, (near, r0, r1, max(p[3] for p in parts))


def _joined(pieces: list, empty: np.ndarray) -> np.ndarray:
    """The pieces (row blocks) as one array: the piece itself when there is one (a
    serial pass writes its flagged rows into one array: no copy), ``empty`` if none."""
    if len(pieces) == 1:
        return pieces[0]
    return np.concatenate(pieces) if pieces else empty
