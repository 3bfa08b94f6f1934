"""The first round's grid (docs/partitioned.md section 2; plan/first_round.py): its
origin and extent from the cutting hull enlarged, equal to the hull of the enlarged
boxes (enlarge is non-decreasing in each value)."""
from __future__ import annotations

import numpy as np
import pytest

from predicates.registration.plan.first_round import fixed_grid
from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxgrid import cells_per_axis, enlarge


def _reference_hull(lo_b, hi_b, margin, accelerate):
    lo_bx, hi_bx = enlarge(lo_b, hi_b, margin, accelerate)
    return lo_bx.min(axis=0), hi_bx.max(axis=0)


@pytest.mark.parametrize("accelerate", [False, True])
@pytest.mark.parametrize("pad", [0.0, 1e-3, 0.37, 5e-324])
@pytest.mark.parametrize("seed", range(4))
def test_grid_from_the_hull_enlarged(seed, pad, accelerate):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    scale = [1.0, 1e-300, 1e300, 3.0][seed]
    lo = rng.standard_normal((n, 3)) * scale
    lo[rng.random((n, 3)) < 0.1] = -0.0  # signed zeros at the hull
    lo[rng.random((n, 3)) < 0.1] = 0.0
    hi = lo + rng.random((n, 3)) * scale * 0.01
    grid = fixed_grid(lo, hi, 1000, pad, Blocks(accelerate=accelerate))
    lo_h, hi_h = _reference_hull(lo, hi, grid.margin, accelerate)
    with np.errstate(over="ignore"):
        origin, top = lo_h - 2 * grid.h, hi_h + 2 * grid.h
    assert np.array_equal(grid.origin, origin)
    assert np.signbit(grid.origin).tolist() == np.signbit(origin).tolist()
    assert np.array_equal(grid.G, cells_per_axis(top - origin, grid.h))
