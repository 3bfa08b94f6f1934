"""The fused chain's helpers (predicates.compiled.chain) against their numpy
counterparts: the cutting faces' boxes as rows (``box_rows``), bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

pytest.importorskip("numba")

from predicates.compiled.chain import box_rows  # noqa: E402

_FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64) | st.sampled_from(
    [0.0, -0.0, 1.0, np.nextafter(1.0, 2.0)])


@settings(max_examples=60, deadline=None)
@given(d=st.integers(1, 3), n=st.integers(0, 40), data=st.data())
def test_box_rows_are_the_columns_side_by_side(d, n, data):
    """Row g is (lo[:, g], hi[:, g]): the same bits (NaN payloads, −0.0), any count
    (none included), from C-contiguous columns and from transposed views alike."""
    lo = data.draw(hnp.arrays(np.float64, (d, n), elements=_FLOATS))
    hi = data.draw(hnp.arrays(np.float64, (d, n), elements=_FLOATS))
    if data.draw(st.booleans()):  # (d, n) views of (n, d) arrays, as the plan holds them
        lo, hi = np.ascontiguousarray(lo.T).T, np.ascontiguousarray(hi.T).T
    rows = box_rows(lo, hi)
    want = np.concatenate([lo, hi]).T
    assert rows.shape == (n, 2 * d) and rows.dtype == np.float64
    assert np.array_equal(rows.view(np.uint64), np.ascontiguousarray(want).view(np.uint64))


def test_box_rows_of_w1_like_boxes():
    """A few thousand random boxes, duplicates included: the columns' values, row-wise."""
    rng = np.random.default_rng(5)
    lo = rng.integers(-4, 4, (3, 3000)).astype(np.float64) / 3
    hi = lo + rng.random((3, 3000))
    rows = box_rows(lo, hi)
    assert np.array_equal(rows[:, :3], lo.T) and np.array_equal(rows[:, 3:], hi.T)
