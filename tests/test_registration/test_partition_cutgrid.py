"""The first round's grid over the cutting boxes on the compiled path
(predicates/compiled/cutgrid.py, plan/first_round.fixed_grid) and the client's cutting
flags from the chunks' covered cells (partition/swept.cut_flags_from): the values of
their numpy references (benchmarks/README.md "The 2-worker W4 client, seventh pass")."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates import compiled
from predicates.registration.spatial.blocks import Blocks

pytestmark = pytest.mark.skipif(not compiled.available(), reason="numba not installed")


def _boxes(rng, n: int, d: int, scale: float, layout: str):
    lo = rng.standard_normal((n, d)) * scale
    lo[rng.random((n, d)) < 0.1] = -0.0  # signed zeros
    lo[rng.random((n, d)) < 0.05] = 0.0
    hi = lo + rng.random((n, d)) * scale * rng.choice([0.0, 0.01, 1.0])
    if layout == "F":  # boxes_of's column-major boxes
        lo, hi = np.asfortranarray(lo), np.asfortranarray(hi)
    return lo, hi


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.sampled_from(["C", "F"]),
       st.sampled_from([1.0, 1e-300, 1e300, 3.0]),
       st.sampled_from([0.0, 5e-324, 1e-3, 0.37, 1e299]), st.booleans())
def test_enlarged_ranges_are_enlarge_then_cell_index(seed, d, layout, scale, pad, pow2):
    """cutgrid.enlarged_ranges = numpy's cell_index(enlarge(...)) (nextafter outwards,
    floor of the quotient, clipped to the grid), value for value — also boxes beyond
    the grid on either side and an overflowing enlargement (clipped)."""
    from predicates.compiled.cutgrid import enlarged_ranges
    from predicates.registration.spatial.boxgrid import cell_index, enlarge

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 300))
    lo, hi = _boxes(rng, n, d, scale, layout)
    G = rng.integers(1, 60, size=d).astype(np.int64)
    h = float(2.0 ** rng.integers(-4, 4)) * scale if pow2 else float(rng.random()) * scale
    h = h if h > 0 else 1.0
    origin = lo.min(axis=0) - rng.random(d) * h * rng.choice([0, 1, 5, -5])
    # values on the grid lines and one ulp off them: where the outward rounding decides
    # the cell (h a power of two: j·h + origin exact for small j and origin)
    lines = np.floor(rng.random((n, d)) * G) * h + origin
    for x, toward in ((lo, np.inf), (hi, -np.inf)):
        on = rng.random((n, d)) < 0.3
        x[on] = lines[on]
        off = rng.random((n, d)) < 0.3
        x[off] = np.nextafter(x[off], toward)
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    if layout == "F":
        lo, hi = np.asfortranarray(lo), np.asfortranarray(hi)
    got0, got1 = np.empty((n, d), np.int32), np.empty((n, d), np.int32)
    enlarged_ranges(lo, hi, pad, origin, h, G, got0, got1)
    with np.errstate(all="ignore"):
        lo_x, hi_x = enlarge(lo, hi, pad)  # numpy's nextafter
    for got, x in ((got0, lo_x), (got1, hi_x)):
        np.testing.assert_array_equal(got, cell_index(x, origin, h, G))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.sampled_from(["C", "F"]),
       st.sampled_from([0.0, 1e-3, 0.37]), st.integers(1, 5000))
def test_fixed_grid_compiled_is_the_numpy_grid(seed, d, layout, pad, n_sim):
    """fixed_grid on the compiled path (the enlarged boxes' ranges in one pass, no
    enlarged boxes) gives the numpy path's grid: cell size, margin, origin, cells,
    every cutting range and the occupancy table."""
    from predicates.registration.plan.first_round import fixed_grid

    rng = np.random.default_rng(seed)
    lo, hi = _boxes(rng, int(rng.integers(1, 400)), d, float(rng.choice([1.0, 3e5])),
                    layout)
    want = fixed_grid(lo, hi, n_sim, pad, Blocks())
    got = fixed_grid(lo, hi, n_sim, pad, Blocks(accelerate=True))
    assert (got.h, got.margin) == (want.h, want.margin)
    for name in ("origin", "G", "ib0", "ib1", "table"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.booleans())
def test_cut_flags_from_covered_cells(seed, d, fast):
    """swept.cut_flags_from on the chunks' OR-ed occupancy (bools, read as 0/1 counts
    without a copy) flags exactly the cutting ranges any_in flags."""
    from predicates.registration.partition.swept import cut_flags_from
    from predicates.registration.spatial.gridsums import any_in, occupancy

    rng = np.random.default_rng(seed)
    G = rng.integers(1, 12, size=d).astype(np.int64)

    def ranges(n):
        a, b = (rng.integers(0, G, size=(n, d)) for _ in range(2))
        return np.minimum(a, b).astype(np.int32), np.maximum(a, b).astype(np.int32)

    blocks = Blocks(accelerate=fast)
    occ = occupancy(*ranges(int(rng.choice([0, 1, 5, 40]))), G, Blocks())
    assert occ.dtype == bool
    ib0, ib1 = ranges(80)
    want = any_in(occ, ib0, ib1, G, Blocks())
    np.testing.assert_array_equal(cut_flags_from(occ, ib0, ib1, G, blocks), want)
