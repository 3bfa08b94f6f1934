"""The compiled dense-grid join (predicates.compiled.gridjoin) repeats the pairs of an a
box equal to the previous one instead of joining it again: the same pairs in the same
order as joining every a box on its own (the join's definition), on boxes with runs of
equal boxes (signed zeros included), and the same count and written prefix when the
output is too short (the caller's retry)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from predicates.compiled.gridjoin import _bucket_b, _bucket_b3, _grid_join, grid_join  # noqa: E402
from predicates.registration.spatial.boxgrid import grid  # noqa: E402
from predicates.registration.spatial.broadphase import box_pairs_bruteforce  # noqa: E402

_SLOW = settings(max_examples=40, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _boxes(rng, n: int, d: int, runs: bool):
    """n boxes on a few coarse values (boxes on grid lines, signed zeros); ``runs``:
    each box repeated 1–6 times in a row (as a Kuhn cube's six tetrahedra), a repeated
    zero bound sometimes with the other sign."""
    lo = rng.choice([-0.0, 0.0, 0.25, 0.5, 1.0, 1.5], size=(n, d)) + rng.random((n, d)) * (
        rng.random((n, 1)) < 0.5)
    hi = lo + rng.choice([0.0, 2.0 ** -40, 0.25, 0.5, 1.25], size=(n, 1))
    if runs:
        reps = rng.integers(1, 7, size=n)
        lo, hi = np.repeat(lo, reps, axis=0), np.repeat(hi, reps, axis=0)
        flip = (lo == 0.0) & (rng.random(lo.shape) < 0.5)
        lo[flip] = -lo[flip]
    return lo, hi


def _setup(lo_a, hi_a, lo_b, hi_b, pad):
    *_, G, _, ia0, ia1, ib0, ib1 = grid(lo_a, hi_a, lo_b, hi_b, pad)
    cols = tuple(np.ascontiguousarray(x.T) for x in (lo_a, hi_a, lo_b, hi_b))
    return (ia0, ia1, ib0, ib1), np.asarray(G, dtype=np.int64), cols


def _one_by_one(ranges, G, pad, cols):
    """The join of each a box alone on the same grid, concatenated: no previous box."""
    ia0, ia1, ib0, ib1 = ranges
    lo_a, hi_a, lo_b, hi_b = cols
    pairs = []
    for a in range(len(ia0)):
        got = grid_join((ia0[a:a + 1], ia1[a:a + 1], ib0, ib1), G, pad,
                        (lo_a[:, a:a + 1], hi_a[:, a:a + 1], lo_b, hi_b), 1 << 40)
        pairs += [(a, int(b)) for b in got[1]] if got is not None and len(got[0]) else []
    return pairs


@_SLOW
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([2, 3]),
       pad=st.sampled_from([0.0, 2.0 ** -30, 0.05]))
def test_repeated_boxes_give_the_pairs_of_joining_each_alone(seed, d, pad):
    rng = np.random.default_rng(seed)
    lo_a, hi_a = _boxes(rng, int(rng.integers(1, 60)), d, runs=True)
    lo_b, hi_b = _boxes(rng, int(rng.integers(1, 40)), d, runs=False)
    ranges, G, cols = _setup(lo_a, hi_a, lo_b, hi_b, pad)
    got = grid_join(ranges, G, pad, cols, 1 << 40)
    pairs = [(int(a), int(b)) for a, b in zip(*got)]
    assert pairs == _one_by_one(ranges, G, pad, cols)
    want = set(zip(*(x.tolist() for x in box_pairs_bruteforce(lo_a, hi_a, lo_b, hi_b, pad))))
    assert set(pairs) == want and len(pairs) == len(want)


@pytest.mark.parametrize("ids", [np.int64, np.int32])
def test_a_short_output_counts_every_pair_and_writes_its_prefix(ids):
    """Copies past the output's end are counted, not written; what is written is the
    full join's prefix (grid_join then retries with the count). Cell offsets and entry
    ids int64 or int32 (grid_join's, when they fit): the same join."""
    rng = np.random.default_rng(7)
    lo_a, hi_a = _boxes(rng, 80, 3, runs=True)
    lo_b, hi_b = _boxes(rng, 60, 3, runs=False)
    same = np.all(lo_a[1:] == lo_a[:-1], axis=1) & np.all(hi_a[1:] == hi_a[:-1], axis=1)
    assert same.sum() > 20  # the repeat path runs, also near the output's end
    (ia0, ia1, ib0, ib1), G, cols = _setup(lo_a, hi_a, lo_b, hi_b, 0.05)
    start = np.zeros(int(np.prod(G)) + 1, dtype=ids)
    n_entries = int((ib1.astype(np.int64) - ib0 + 1).prod(axis=1).sum())
    ids, first = np.empty(n_entries, ids), np.empty(n_entries, np.uint8)
    _bucket_b(ib0, ib1, G, start, ids, first)
    assert start[-1] == n_entries and np.all(np.diff(start) >= 0)
    full = [np.empty(1 << 16, np.int64) for _ in range(2)]
    n, props = _grid_join(ia0, ia1, G, start, ids, first, 0.05, *cols, 1 << 40, *full)
    assert n > 40 and props >= n
    for size in (1, n // 3, n - 1):
        short = [np.full(size, -1, np.int64) for _ in range(2)]
        m, p = _grid_join(ia0, ia1, G, start, ids, first, 0.05, *cols, 1 << 40, *short)
        assert (m, p) == (n, props)
        assert all(np.array_equal(s, f[:size]) for s, f in zip(short, full))
    # past the proposal limit: refused whether the limit falls in a repeated box or not
    assert all(_grid_join(ia0, ia1, G, start, ids, first, 0.05, *cols, lim, *full)[0] == -1
               for lim in range(0, props, max(1, props // 17)))


def test_covered_cells_is_the_numpy_sum():
    """The grid's covered-cell count compiled (gridjoin.covered_cells via
    boxgrid.covered) equals numpy's block sums; 2D and 3D, empty, and boxes many cells
    wide."""
    from predicates.registration.spatial.blocks import Blocks
    from predicates.registration.spatial.boxgrid import covered

    rng = np.random.default_rng(11)
    for d, n in ((2, 0), (2, 1000), (3, 70000)):
        i0 = rng.integers(0, 1 << 19, size=(n, d)).astype(np.int32)
        i1 = (i0 + rng.integers(0, 300, size=(n, d)) * (rng.random((n, 1)) < 0.1)).astype(
            np.int32)
        want = covered(i0, i1)
        assert covered(i0, i1, Blocks(accelerate=True)) == want
        assert want == int((i1.astype(np.int64) - i0 + 1).prod(axis=1).sum())


@_SLOW
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([2, 3]))
def test_int32_offsets_and_ids_bucket_and_join_as_int64(seed, d):
    """grid_join's int32 cell offsets and entry ids (when they fit) give the int64
    arrays' buckets, start bits and pairs, in the same order."""
    rng = np.random.default_rng(seed)
    lo_a, hi_a = _boxes(rng, int(rng.integers(1, 60)), d, runs=True)
    lo_b, hi_b = _boxes(rng, int(rng.integers(1, 40)), d, runs=False)
    (ia0, ia1, ib0, ib1), G, cols = _setup(lo_a, hi_a, lo_b, hi_b, 0.05)
    n_entries = int((ib1.astype(np.int64) - ib0 + 1).prod(axis=1).sum())
    got = []
    for ids in (np.int64, np.int32):
        start = np.zeros(int(np.prod(G)) + 1, dtype=ids)
        entries, first = np.empty(n_entries, ids), np.empty(n_entries, np.uint8)
        _bucket_b(ib0, ib1, G, start, entries, first)
        out = [np.empty(1 << 14, np.int64) for _ in range(2)]
        n, props = _grid_join(ia0, ia1, G, start, entries, first, 0.05, *cols, 1 << 40, *out)
        got.append((start.tolist(), entries.tolist(), first.tolist(), n, props,
                    out[0][:n].tolist(), out[1][:n].tolist()))
    assert got[0] == got[1]


def _odometer_join(ranges, G, pad, cols):
    """The join in plain Python: b boxes bucketed in order, each a's cells walked axis 0
    fastest, each cell's entries in bucket order, kept in the lower overlap corner and
    by the test — the pairs and their order as the general (odometer) route makes them."""
    ia0, ia1, ib0, ib1 = ranges
    lo_a, hi_a, lo_b, hi_b = cols
    d = ia0.shape[1]

    def cells(r0, r1):
        return itertools.product(*(range(int(r0[ax]), int(r1[ax]) + 1)
                                   for ax in reversed(range(d))))

    bucket = {}
    for b in range(len(ib0)):
        for c in cells(ib0[b], ib1[b]):
            bucket.setdefault(c[::-1], []).append(b)
    pairs = []
    for a in range(len(ia0)):
        for c in cells(ia0[a], ia1[a]):
            cell = c[::-1]
            for b in bucket.get(cell, []):
                if any(max(ia0[a, ax], ib0[b, ax]) != cell[ax] for ax in range(d)):
                    continue
                if all(lo_b[ax, b] - hi_a[ax, a] <= pad and lo_a[ax, a] - hi_b[ax, b] <= pad
                       for ax in range(d)):
                    pairs.append((a, b))
    return pairs


@_SLOW
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([2, 3]),
       ids=st.sampled_from([np.int64, np.int32]))
def test_written_out_3d_walks_are_the_odometer_walks(seed, d, ids):
    """In 3D the bucketing (_bucket_b3) and the join's cell walk are three written-out
    loops: the same offsets, entries and start bits as the odometer's _bucket_b, and the
    join's pairs in the order of a plain Python odometer join (2D: the odometer itself)."""
    rng = np.random.default_rng(seed)
    lo_a, hi_a = _boxes(rng, int(rng.integers(1, 50)), d, runs=True)
    lo_b, hi_b = _boxes(rng, int(rng.integers(1, 30)), d, runs=False)
    ranges, G, cols = _setup(lo_a, hi_a, lo_b, hi_b, 0.05)
    ia0, ia1, ib0, ib1 = ranges
    n_entries = int((ib1.astype(np.int64) - ib0 + 1).prod(axis=1).sum())
    got = []
    for bucket in ((_bucket_b, _bucket_b3) if d == 3 else (_bucket_b,)):
        start = np.zeros(int(np.prod(G)) + 1, dtype=ids)
        entries, first = np.empty(n_entries, ids), np.empty(n_entries, np.uint8)
        bucket(ib0, ib1, G, start, entries, first)
        got.append((start.tolist(), entries.tolist(), first.tolist()))
    assert all(g == got[0] for g in got)
    pairs = grid_join(ranges, G, 0.05, cols, 1 << 40)
    assert [(int(a), int(b)) for a, b in zip(*pairs)] == _odometer_join(ranges, G, 0.05, cols)
