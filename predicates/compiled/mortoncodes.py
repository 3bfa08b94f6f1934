"""The Morton codes of a partitioned run's cells on the client (benchmarks/README.md
"The 2-worker W4 client, seventh pass"): :func:`first_codes` gives each run cell the
code of its first vertex, :func:`predicates.registration.partition.assign.
morton_codes`' integers, read in place from the points and the run cells — the split
then selects its boundary keys on the client
(:func:`predicates.registration.partition.split_remote.local_boundaries`) instead of
rounds of tasks over the chunks' codes.

The floating-point operations are numpy's, in its order: the coordinate times the
power of two 2^-e in the points' dtype (``times_pow2``'s product), converted to
binary64, then ``(c − lo) / span · (2^bits − 1)``, clipped to [0, 2^bits − 1] and
truncated; the bits are spread and interleaved with integer operations (exact).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["first_codes"]


@njit(**INLINE_OPTIONS)
def _spread3(v):
    """assign._spread's bits of v (< 2^21) spaced 3 apart."""
    v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    return (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)


@njit(**INLINE_OPTIONS)
def _spread2(v):
    """assign._spread's bits of v (< 2^31) spaced 2 apart."""
    v = (v | (v << np.uint64(16))) & np.uint64(0x0000FFFF0000FFFF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF00FF00FF)
    v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    v = (v | (v << np.uint64(2))) & np.uint64(0x3333333333333333)
    return (v | (v << np.uint64(1))) & np.uint64(0x5555555555555555)


@njit(**INLINE_OPTIONS)
def _quantum(points, i, ax, factor, lo, span, topf):
    """morton_codes' integer coordinate: (c − lo) / span · topf clipped to [0, topf],
    truncated (through int64: exact, the value is below 2^31; the direct uint64
    conversion is a slower instruction sequence without AVX-512)."""
    c = np.float64(points[i, ax] * factor)
    q = (c - lo[ax]) / span[ax] * topf
    q = 0.0 if q < 0.0 else q
    q = topf if q > topf else q
    return np.uint64(np.int64(q))


@njit(**JIT_OPTIONS)
def first_codes(points, run, factor, lo, span, out):
    """``out`` (m,) uint64: ``morton_codes(times_pow2(points[run[:, 0]], −e) as
    binary64, transposed, lo, hi)`` with ``factor`` = 2^-e in the points' dtype (a
    normal number there), ``span`` = where(hi > lo, hi − lo, 1) (d,); ``points``
    (N, d), d = 2 or 3, finite; ``run`` (m, k) ids in range. One loop per d (the
    spread chosen outside the rows)."""
    if points.shape[1] == 3:
        topf = np.float64((1 << 21) - 1)
        for m in range(run.shape[0]):
            i = np.uint64(run[m, 0])
            code = _spread3(_quantum(points, i, 0, factor, lo, span, topf))
            code |= _spread3(_quantum(points, i, 1, factor, lo, span, topf)) << np.uint64(1)
            code |= _spread3(_quantum(points, i, 2, factor, lo, span, topf)) << np.uint64(2)
            out[m] = code
        return
    topf = np.float64((1 << 31) - 1)
    for m in range(run.shape[0]):
        i = np.uint64(run[m, 0])
        code = _spread2(_quantum(points, i, 0, factor, lo, span, topf))
        out[m] = code | (_spread2(_quantum(points, i, 1, factor, lo, span, topf))
                         << np.uint64(1))
