"""The corner updates of a difference grid (``gridsums.coverage``'s summed-area
tables, built by :func:`predicates.compiled.cells.add_corners` and
:func:`predicates.compiled.estimate.pad_corners`): ±v at the 2^d corners of a range of
grid cells, d = 2 and 3 written out. Integer adds: the same counts in any order."""
from __future__ import annotations

from numba import njit

from .build import INLINE_OPTIONS

__all__ = ["corners2", "corners3"]


@njit(**INLINE_OPTIONS)
def corners3(diff, x0, x1, y0, y1, z0, z1, v):
    """±v at the 8 corners of a 3D range given by its key terms (x0 + y0 + z0 the
    lowest corner's key, x1 + … one past the highest): the sign is (−1)^(d − corners
    at the upper end)."""
    diff[x1 + y1 + z1] += v
    diff[x0 + y1 + z1] -= v
    diff[x1 + y0 + z1] -= v
    diff[x1 + y1 + z0] -= v
    diff[x0 + y0 + z1] += v
    diff[x0 + y1 + z0] += v
    diff[x1 + y0 + z0] += v
    diff[x0 + y0 + z0] -= v


@njit(**INLINE_OPTIONS)
def corners2(diff, x0, x1, y0, y1, v):
    """:func:`corners3` for d = 2 (4 corners)."""
    diff[x1 + y1] += v
    diff[x0 + y1] -= v
    diff[x1 + y0] -= v
    diff[x0 + y0] += v
