"""The resolution report's pair estimate, its exact integer parts (docs/resolution.md:
the memory guard's count of cell pairs within the pad): the dot product of two count
arrays, exactly (:func:`count_dot`), the keyed count's cell keys (:func:`cell_keys`),
and the dense count compiled without its grid indices in memory (:func:`compiled_count`:
:func:`predicates.registration.plan.resolution.estimate_cell_pairs`' integer). Exact
integer arithmetic only, no BLAS (the count decides refusals, docs/design.md).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.gridsums import _stride

__all__ = ["KEY_RADIX", "cell_keys", "compiled_count", "count_dot", "grid_start"]

KEY_RADIX = 1_000_003  # the per-axis radix of cell_keys


def count_dot(x: np.ndarray, y: np.ndarray) -> int:
    """Σ x·y of two non-negative integer arrays, exactly: int64 products summed in int64
    when Σx · max y (a bound on every partial sum) is below 2^63 — integer sums are
    exact in any order — else Python integers."""
    if x.size == 0:
        return 0
    x, y = x.astype(np.int64, copy=False), y.astype(np.int64, copy=False)
    if int(x.sum(dtype=np.int64)) * int(y.max()) < 2 ** 63:
        return int(np.multiply(x, y).sum(dtype=np.int64))
    nz = np.flatnonzero(x)
    return sum(a * b for a, b in zip(x[nz].tolist(), y[nz].tolist()))


def cell_keys(i0, i1):
    """Keys (hashable int64 from the grid indices) of every grid cell each box covers."""
    i0, i1 = i0.astype(np.int64), i1.astype(np.int64)
    c = i1 - i0 + 1
    per = np.prod(c, axis=1)
    box = np.repeat(np.arange(len(c)), per)
    t = np.arange(box.size, dtype=np.int64) - np.repeat(np.cumsum(per) - per, per)
    key = np.zeros(box.size, dtype=np.int64)
    for ax in range(c.shape[1]):
        cb = c[box, ax]
        key = key * KEY_RADIX + (i0[box, ax] + t % cb)
        t //= cb
    return key


def grid_start(lo_a, hi_a, lo_b, hi_b, pad: float, as_array=np.asarray) -> tuple:
    """What the compiled estimate grids start from (``resolution._compiled_grid``,
    :func:`compiled_count`): h = pad/2, both sides' boxes as float64 (``as_array``), the
    padded boxes' hull lo_min, hi_max and its span, in one pass per side
    (:func:`predicates.compiled.cellsums.pad_extents`), the first cell size g (the padded
    extents' median, at least the pad and 2^-20 of the span) and the budget of cells."""
    from predicates.compiled.cellsums import pad_extents

    d = lo_a.shape[1]
    h = 0.5 * pad
    sides = [tuple(as_array(x, dtype=np.float64) for x in s)
             for s in ((lo_a, hi_a), (lo_b, hi_b))]
    ext = np.empty(len(lo_a) + len(lo_b))
    lo_min, hi_max = np.full(d, np.inf), np.full(d, -np.inf)
    pad_extents(*sides[0], h, ext[:len(lo_a)], lo_min, hi_max)
    pad_extents(*sides[1], h, ext[len(lo_a):], lo_min, hi_max)
    span = float((hi_max - lo_min).max())
    g = max(float(np.median(ext)), float(pad), span * 2.0 ** -20, 1e-300)
    return h, sides, lo_min, hi_max, span, g, 8 * (len(lo_a) + len(lo_b)) + (1 << 20)


def compiled_count(lo_a, hi_a, lo_b, hi_b, pad: float) -> int | None:
    """``estimate_cell_pairs``' dense count with compiled passes that never store the
    grid indices (:mod:`predicates.compiled.estimate`): ``_compiled_grid``'s cell size
    (the same totals, the same doublings), the grid's cells per axis from the padded
    hull (the largest last index is that of the largest hi + h: every rounding is
    monotone), ``_dense_pair_count``'s refusals, the two coverages' corners added
    straight from the boxes in the pass that sums the total. None (the caller counts
    as before) for d other than 2, 3, a hull not finite, or where ``_dense_pair_count``
    gives None."""
    from predicates.compiled.estimate import pad_corners, pad_total
    from predicates.compiled.prefix import prefix_sums

    d = lo_a.shape[1]
    if d not in (2, 3):
        return None
    # the boxes as laid out: no copies
    h, sides, lo_min, hi_max, span, g, budget = grid_start(lo_a, hi_a, lo_b, hi_b, pad)
    if not np.isfinite(span):  # (no grid: the keys' path decides, as before)
        return None
    while True:  # _compiled_grid's doublings, each grid's coverage in the same pass
        G = np.floor((hi_max - lo_min) / g).astype(np.int64) + 1  # colmax(i1) + 1
        if not _dense(G, budget):  # the total alone: is this the last cell size?
            if sum(pad_total(*side, h, lo_min, g) for side in sides) <= budget:
                return None
            g *= 2
            continue
        diffs = [np.zeros(int(np.prod(G + 1)), dtype=np.int64) for _ in sides]
        if sum(pad_corners(*side, h, lo_min, g, _stride(G), diff, d % 2)
               for side, diff in zip(sides, diffs)) <= budget:
            break
        g *= 2
    # gridsums.coverage's prefix sums (compiled: the same integers)
    covers = [prefix_sums(diff.reshape(tuple((G + 1)[::-1]))).ravel() for diff in diffs]
    return count_dot(*covers)


def _dense(G, budget: int) -> bool:
    """``_dense_pair_count``'s test of the grid G (cells per axis): keys injective and
    in int64, at most ``budget`` cells."""
    top = float(G[0])
    for n in G[1:]:
        top *= KEY_RADIX
    return not (np.any(G[1:] > KEY_RADIX) or top >= 2.0 ** 62
                or float(np.prod(G + 1.0)) > budget)
