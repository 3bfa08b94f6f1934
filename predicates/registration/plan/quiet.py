"""The numpy flag pass's shortcut (docs/resolution.md, "The first round"; the pass:
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

The same flags, ranges and edges as the plain pass (integers; no rounding argument:
unlike the compiled sweep's, which reads the boxes' float edges). Tested against the
plain pass: ``tests/test_registration/test_quiet_pass.py``.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxgrid import cell_index

__all__ = ["CAP", "PointCells", "cell_distances", "point_cells"]

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
