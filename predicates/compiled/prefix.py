"""Inclusive prefix sums of integer grids along every axis (the summed-area tables of
:func:`predicates.registration.spatial.gridsums.coverage` and the pair estimate's
coverages, :func:`predicates.registration.plan.paircount.compiled_count`), compiled:
``for ax in range(ndim): np.cumsum(a, axis=ax, out=a)``'s integers in one call.

Why: numpy's cumulative sum along a grid's outer axes walks it with a stride per
element; on W4's grids of ~1.8 M cells the three sums cost ~9 ms a grid, eight grids a
plan (benchmarks/README.md, "Plan passes, ninth pass"). Here each axis is a stream over
contiguous rows (2D, 3D). Integer additions: the same values in any order as long as no
partial sum overflows the dtype — every partial sum of a coverage's difference array is
a signed count of boxes, at most their number (docs/design.md, "Compiled candidate
chain": integers are exact), which is what chose the dtype.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import JIT_OPTIONS

__all__ = ["prefix_sums"]


@njit(**JIT_OPTIONS)
def _prefix2(a):
    """Inclusive prefix sums of ``a`` (A, B) along both axes, in place."""
    A, B = a.shape
    for i in range(A):
        for k in range(1, B):
            a[i, k] += a[i, k - 1]
        if i > 0:
            for k in range(B):
                a[i, k] += a[i - 1, k]


@njit(**JIT_OPTIONS)
def _prefix3(a):
    """Inclusive prefix sums of ``a`` (A, B, D) along the three axes, in place: each
    plane's two inner sums, then the plane added to the one before it."""
    A, B, D = a.shape
    for i in range(A):
        for j in range(B):
            for k in range(1, D):
                a[i, j, k] += a[i, j, k - 1]
        for j in range(1, B):
            for k in range(D):
                a[i, j, k] += a[i, j - 1, k]
        if i > 0:
            for j in range(B):
                for k in range(D):
                    a[i, j, k] += a[i - 1, j, k]


def prefix_sums(a: np.ndarray) -> np.ndarray:
    """``a`` (a C-contiguous integer grid) with its inclusive prefix sums along every
    axis, in place, and returned: compiled for 2 and 3 axes, numpy's ``cumsum`` for
    any other."""
    if a.ndim == 3 and a.flags.c_contiguous:
        _prefix3(a)
    elif a.ndim == 2 and a.flags.c_contiguous:
        _prefix2(a)
    else:
        for ax in range(a.ndim):
            np.cumsum(a, axis=ax, out=a)
    return a
