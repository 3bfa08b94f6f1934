"""The first round's grid over the cutting boxes, compiled without temporaries
(:func:`predicates.registration.plan.first_round.fixed_grid`; benchmarks/README.md
"The 2-worker W4 client, seventh pass"):

* :func:`enlarged_ranges` — each box enlarged by the margin and its cell range, in
  one loop: ``cellsums.widened``'s roundings (x ∓ pad, then nextafter outwards) then
  ``cells.cell_index``'s (one subtraction, one division, clipped, truncated) on each
  value, the operations of ``boxgrid.enlarge`` followed by ``boxgrid.cell_index`` in
  their order — without the enlarged boxes (two (n, d) float64 arrays) in memory.

Comparisons and a conversion only after the roundings named above: the same values.
"""
from __future__ import annotations

from numba import njit

from .build import JIT_OPTIONS
from .cells import _index
from .cellsums import _next_down, _next_up

__all__ = ["enlarged_ranges"]


@njit(**JIT_OPTIONS)
def enlarged_ranges(lo, hi, pad, origin, h, G, ib0, ib1):
    """``cell_index(enlarge(lo, hi, pad)[s], origin, h, G)`` for s = 0, 1 into ``ib0``,
    ``ib1`` (n, d) int32; ``lo``, ``hi`` (n, d) binary64 in any layout, ``pad`` ≥ 0."""
    for r in range(lo.shape[0]):
        for ax in range(lo.shape[1]):
            top = G[ax] - 1
            ib0[r, ax] = _index(_next_down(lo[r, ax] - pad), origin[ax], h, top)
            ib1[r, ax] = _index(_next_up(hi[r, ax] + pad), origin[ax], h, top)
