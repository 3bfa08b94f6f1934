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


def _lookup_reference(s, c, A, B, nb, keys):
    """The numpy path's look-up (loop._blocked): every face pair's key searched."""
    fa = s[:, None] if A is None else A.take(s, axis=0)
    fb = c[:, None] if B is None else B.take(c, axis=0)
    k = (fa[:, :, None].astype(np.int64) * nb + fb[:, None, :]).reshape(
        len(s), fa.shape[1] * fb.shape[1])
    if len(keys) == 0:
        return np.zeros(len(s), dtype=bool)
    pos = np.searchsorted(keys, k).clip(max=len(keys) - 1)
    return (keys.take(pos) == k).any(axis=1)


@settings(max_examples=80, deadline=None)
@given(na=st.integers(1, 30), nb=st.integers(1, 30), wa=st.sampled_from([0, 2, 3]),
       wb=st.sampled_from([0, 2, 3]), data=st.data())
def test_registered_any_skips_only_unflagged_faces(na, nb, wa, wb, data):
    """``registered_any`` with the involved flags (the faces of the registered keys,
    plus any others) answers as the numpy look-up of every face pair: ties, repeated
    faces in a row, pairs already hit, no keys; flags that miss a key's face fail."""
    from predicates.compiled.chain import registered_any

    n = data.draw(st.integers(0, 40))
    A = None if wa == 0 else data.draw(hnp.arrays(np.int32, (50, wa), elements=st.integers(0, na - 1)))
    B = None if wb == 0 else data.draw(hnp.arrays(np.int64, (50, wb), elements=st.integers(0, nb - 1)))
    s = data.draw(hnp.arrays(np.int64, n, elements=st.integers(0, (na if A is None else 50) - 1)))
    c = data.draw(hnp.arrays(np.int64, n, elements=st.integers(0, (nb if B is None else 50) - 1)))
    pairs = data.draw(st.lists(st.tuples(st.integers(0, na - 1), st.integers(0, nb - 1)),
                               max_size=40))
    keys = np.unique(np.array([a * nb + b for a, b in pairs], dtype=np.int64))
    in_a, in_b = np.zeros(na, bool), np.zeros(nb, bool)
    in_a[[a for a, _ in pairs]] = True
    in_b[[b for _, b in pairs]] = True
    in_a |= data.draw(hnp.arrays(np.bool_, na))  # a superset answers the same
    in_b |= data.draw(hnp.arrays(np.bool_, nb))
    before = data.draw(hnp.arrays(np.bool_, n))
    hit = before.copy()
    registered_any(s, c, A, B, nb, keys, hit, in_a, in_b)
    assert np.array_equal(hit, before | _lookup_reference(s, c, A, B, nb, keys))


def test_registered_any_reads_the_flags():
    """A registered face pair whose face is not flagged is not found: the flags are
    what the kernel skips by (so the test above would see a wrong flag's index)."""
    from predicates.compiled.chain import registered_any

    keys = np.array([1 * 4 + 2], dtype=np.int64)
    s, c = np.array([1, 1], dtype=np.int64), np.array([2, 3], dtype=np.int64)
    on, off = np.ones(4, bool), np.zeros(4, bool)
    hit = np.zeros(2, bool)
    registered_any(s, c, None, None, 4, keys, hit, on, on)
    assert hit.tolist() == [True, False]
    for fa, fb in ((off, on), (on, off)):
        hit = np.zeros(2, bool)
        registered_any(s, c, None, None, 4, keys, hit, fa, fb)
        assert hit.tolist() == [False, False]


@settings(max_examples=60, deadline=None)
@given(d=st.integers(1, 3), k=st.integers(1, 4), n=st.integers(0, 30),
       dt=st.sampled_from([np.float64, np.float32]), it=st.sampled_from([np.int32, np.int64]),
       data=st.data())
def test_point_box_rows_are_the_boxes_as_rows(d, k, n, dt, it, data):
    """``point_box_rows`` (one pass from the points) gives ``box_rows`` of
    ``boxtest.boxes``' columns bit for bit: NaN (propagated, its payload), ±0.0 and
    ±inf coordinates, repeated vertices, binary32 points, any count (none included)."""
    from predicates.compiled.boxtest import boxes
    from predicates.compiled.chain import point_box_rows

    npts = data.draw(st.integers(1, 12))
    elems = st.floats(allow_nan=True, allow_infinity=True, width=32) | st.sampled_from(
        [0.0, -0.0, 1.0, -1.0])
    P = data.draw(hnp.arrays(dt, (npts, d), elements=elems))
    R = data.draw(hnp.arrays(it, (n, k), elements=st.integers(0, npts - 1)))
    lo, hi = boxes(P, R)
    want = box_rows(lo.T, hi.T)
    got = point_box_rows(P, R)
    assert got.shape == (n, 2 * d) and got.dtype == np.float64
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
