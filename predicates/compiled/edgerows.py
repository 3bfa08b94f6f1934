"""The least squared edge of 3D tetrahedra or triangles read straight from the points
and the cells as given (:func:`least_square_rows`): the values of
:func:`predicates.compiled.edgesquares.least_square_tetrahedra` on the renumbered, scaled
copy :func:`predicates.registration.plan.edges.edge_summary` makes, without making it.

Why (benchmarks/README.md, "s17-plan"): a minimum needs neither unique vertices nor
compact ids. The copy cost a pass over the cells to mark the used vertices, one over
every point to number them, one more over the cells to renumber them, and a gather and
a scaling of the used points — more than the least squares themselves (W1's report:
1.2 of 2.8 ms in the renumbering alone). Here each coordinate is converted to binary64
and multiplied by the same power of two as it is read: the scaled copy's values (one
correctly rounded product each, elementwise), the same squares summed from axis 0, the
same pairs; min is exact in any order.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["least_square_rows"]


@njit(**INLINE_OPTIONS)
def _vertex(points, i, factor):
    """Point i's coordinates in binary64 times ``factor`` (times_pow2's products)."""
    return (np.float64(points[i, 0]) * factor, np.float64(points[i, 1]) * factor,
            np.float64(points[i, 2]) * factor)


@njit(**INLINE_OPTIONS)
def _square(u, v):
    """Σ (u − v)² over the three axes, summed from axis 0 (``cells._square3``)."""
    t = u[0] - v[0]
    sq = t * t
    t = u[1] - v[1]
    sq = sq + t * t
    t = u[2] - v[2]
    return sq + t * t


@njit(**JIT_OPTIONS)
def least_square_rows(points, cells, factor):
    """The least squared edge of the cells (m, k), k = 4 or 3, over ``points`` (n, 3),
    each coordinate scaled by ``factor`` (a power of two whose products are exact or
    correctly rounded: times_pow2's) as it is read; +inf for no cells. The ids are in
    range (validated): read unsigned, no wraparound test."""
    best = np.inf
    if cells.shape[1] == 4:
        for r in range(cells.shape[0]):
            a = _vertex(points, np.uint64(cells[r, 0]), factor)
            b = _vertex(points, np.uint64(cells[r, 1]), factor)
            c = _vertex(points, np.uint64(cells[r, 2]), factor)
            d = _vertex(points, np.uint64(cells[r, 3]), factor)
            for sq in (_square(a, b), _square(a, c), _square(a, d), _square(b, c),
                       _square(b, d), _square(c, d)):
                best = sq if sq < best else best
    else:
        for r in range(cells.shape[0]):
            a = _vertex(points, np.uint64(cells[r, 0]), factor)
            b = _vertex(points, np.uint64(cells[r, 1]), factor)
            c = _vertex(points, np.uint64(cells[r, 2]), factor)
            for sq in (_square(a, b), _square(a, c), _square(b, c)):
                best = sq if sq < best else best
    return best
