"""Bounding boxes of simplices and their largest edges, the input of every box test of
the registration (the broad phase of section 4.1, L of Algorithms 1 and 6, the
refinement's scale): exact, since min and max round nothing."""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks

__all__ = ["box_extent", "boxes_of", "fill_boxes"]


def boxes_of(points: np.ndarray, rows: np.ndarray, blocks: Blocks = SERIAL):
    """Bounding boxes (lo, hi), each (n, d) float64 (column-major), of the simplices
    ``points[rows]`` (rows (n, k) of vertex ids): per coordinate and vertex column, one
    1D ``take`` into a reused buffer — never the (n, k, d) gather, ~4x faster than
    gathering point rows — block by block (:mod:`~predicates.registration.spatial.blocks`; on a
    pool in a partitioned run's plan). Exact (min and max round nothing)."""
    n = rows.shape[0]
    d = points.shape[1]
    lo, hi = np.empty((d, n)), np.empty((d, n))
    rows = np.asarray(rows)
    if blocks.accelerate:  # the same boxes, compiled (GIL-free), points and rows as given
        from predicates.compiled.cells import fill_boxes as kernel

        P = np.ascontiguousarray(points)  # (no copy when it already is)
        blocks.rows(lambda a, b: kernel(P, rows[a:b], lo[:, a:b], hi[:, a:b]), n)
        return lo.T, hi.T
    cols = np.ascontiguousarray(points.T, dtype=np.float64)

    def fill(a: int, b: int) -> None:
        fill_boxes(cols, np.ascontiguousarray(rows[a:b].T), lo[:, a:b], hi[:, a:b])

    blocks.rows(fill, n)
    return lo.T, hi.T


def fill_boxes(cols: np.ndarray, R: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               checked: bool = False) -> None:
    """:func:`boxes_of`'s loop: ``cols`` (d, N) float64 coordinates by axis, ``R``
    (k, m) vertex ids by column; writes the boxes into ``lo``, ``hi`` (d, m) (rows
    contiguous: views of a larger buffer are fine, e.g. a chunk of the cells).
    ``checked``: the ids were validated in range, so the takes skip numpy's per-index
    bounds check (``mode="clip"`` clips nothing then; the same boxes)."""
    mode = "clip" if checked else "raise"
    x = np.empty(R.shape[1])
    for ax in range(cols.shape[0]):
        np.take(cols[ax], R[0], out=lo[ax], mode=mode)
        hi[ax] = lo[ax]
        for v in range(1, R.shape[0]):
            np.take(cols[ax], R[v], out=x, mode=mode)
            np.minimum(lo[ax], x, out=lo[ax])
            np.maximum(hi[ax], x, out=hi[ax])


def box_extent(lo: np.ndarray, hi: np.ndarray, out: np.ndarray | None = None,
               tmp: np.ndarray | None = None) -> np.ndarray:
    """Each box's largest edge (column by column: faster than (hi - lo).max(1); the
    same values, max being exact). ``out``, ``tmp``: buffers of len(lo) to reuse (a
    pass over blocks of rows allocates nothing)."""
    e = np.subtract(hi[:, 0], lo[:, 0], out=out)
    for ax in range(1, lo.shape[1]):
        np.maximum(e, np.subtract(hi[:, ax], lo[:, ax], out=tmp), out=e)
    return e
