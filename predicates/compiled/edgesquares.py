"""The least squared edge of cells in local ids (the plan's shortest edge,
:func:`predicates.registration.plan.edges.shortest_edge`, compiled and GIL-free):
:func:`least_square_edge` for any cells, 3D tetrahedra and triangles written out
(:func:`least_square_kernel` picks one); the same squares, summed from axis 0, compared
in the same pair order — the same minimum. Straight from the points and cells as
given: :mod:`predicates.compiled.edgerows`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["least_square_edge", "least_square_kernel", "least_square_tetrahedra",
           "least_square_triangles"]


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
