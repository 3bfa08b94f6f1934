"""The boxes of a partitioned plan's flagged tetrahedra on the client
(:meth:`predicates.registration.partition.remote.RemoteCells.flag_pass`;
benchmarks/README.md "The 2-worker W4 client, fifth pass"): the values of
:func:`predicates.compiled.cells.fill_boxes` — numpy's ``minimum``/``maximum`` fold
over the four vertices in column order, NaN and signed zeros as numpy gives them —
with each row's four ids read once (as unsigned: validated in range) instead of once
per axis (W4's 465 k flagged cells: ~20 → ~14 ms).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS
from .cells import _fold

__all__ = ["tetrahedra_boxes"]


@njit(**JIT_OPTIONS)
def tetrahedra_boxes(points, rows, lo, hi):
    """``lo``, ``hi`` (3, m) of the tetrahedra ``rows`` (m, 4) of ``points`` (N, 3),
    each coordinate converted to binary64 exactly on reading."""
    for m in range(rows.shape[0]):
        i, j = np.uint64(rows[m, 0]), np.uint64(rows[m, 1])
        k, v = np.uint64(rows[m, 2]), np.uint64(rows[m, 3])
        for ax in range(3):
            x = np.float64(points[i, ax])
            a, b = _fold(x, x, np.float64(points[j, ax]))
            a, b = _fold(a, b, np.float64(points[k, ax]))
            lo[ax, m], hi[ax, m] = _fold(a, b, np.float64(points[v, ax]))
