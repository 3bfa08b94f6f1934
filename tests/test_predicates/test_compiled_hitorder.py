"""The compiled order of a kind's registered pairs (predicates.compiled.hitorder)
against numpy: the radix passes on the first key are a stable argsort, and the whole
order is np.lexsort's (first key most significant) — for any rows, ties and
duplicates included (every pass stable), not only the distinct rows _output gives it."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")


def _keys(data, rng):
    """(rows, keys) int64: first keys over a drawn range (few values: long runs of
    ties; up to 2^62: every radix pass), duplicated rows, other keys over few values."""
    m = data.draw(st.integers(0, 600))
    nk = data.draw(st.integers(1, 3))
    span = data.draw(st.sampled_from([1, 2, 7, 300, 2 ** 11, 2 ** 11 + 1, 2 ** 33, 2 ** 62 - 1]))
    lo = data.draw(st.sampled_from([0, 5, 2 ** 40, -(2 ** 61)]))
    keys = rng.integers(0, 5, size=(m, nk), dtype=np.int64)
    keys[:, 0] = lo + rng.integers(0, span, size=m, dtype=np.int64, endpoint=True)
    if m and data.draw(st.booleans()):  # one first key shared by many rows
        keys[: m // 2, 0] = keys[0, 0]
    if m > 1 and data.draw(st.booleans()):  # duplicated rows
        keys[m // 2:] = keys[: m - m // 2]
    return keys


@settings(deadline=None, max_examples=200)
@given(data=st.data())
def test_radix_first_is_a_stable_argsort(data):
    from predicates.compiled.hitorder import _radix_first

    keys = _keys(data, np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1))))
    if not len(keys):
        return
    order, ranked = np.empty(len(keys), np.int64), np.empty(len(keys), np.int64)
    _radix_first(keys, order, ranked, np.full((2, len(keys)), -1, np.int64))
    want = np.argsort(keys[:, 0], kind="stable")
    assert np.array_equal(order, want)
    assert np.array_equal(ranked, keys[want, 0])


@settings(deadline=None, max_examples=200)
@given(data=st.data())
def test_order_is_lexsort(data):
    from predicates.compiled.hitorder import _order_of, distinct_lex_order

    keys = _keys(data, np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1))))
    want = np.lexsort(keys.T[::-1])
    assert np.array_equal(_order_of(keys), want)
    assert np.array_equal(_order_of(keys, np.zeros((2, len(keys)), np.int64)), want)
    if len(keys):
        assert np.array_equal(distinct_lex_order(list(keys.T)), want)


@settings(deadline=None, max_examples=200)
@given(data=st.data())
def test_order_over_run_heads_is_lexsort(data):
    """Rows in runs sharing their simplex (``s``) and so their first key — a
    simulation simplex's hits arrive together — sorted by the runs' heads, then
    expanded: np.lexsort's order; runs of one row each, one run, equal first keys in
    runs apart (the same simplex met again later, or two simplices' equal keys)."""
    from predicates.compiled.hitorder import _order_of, _run_heads

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    runs = data.draw(st.integers(1, 200))
    length = rng.integers(1, data.draw(st.sampled_from([2, 4, 40])), size=runs)
    simplex = rng.integers(0, data.draw(st.sampled_from([1, 3, 50, 10 ** 6])), size=runs)
    s = np.repeat(simplex, length)
    keys = rng.integers(0, 4, size=(len(s), data.draw(st.integers(1, 3))), dtype=np.int64)
    keys[:, 0] = s * data.draw(st.sampled_from([1, 2 ** 40])) + 7  # a function of s
    heads = np.full(len(s) + 1, -1, dtype=np.int64)
    m = _run_heads(s, heads)
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    assert m == len(starts) and np.array_equal(heads[:m], starts) and heads[m] == len(s)
    want = np.lexsort(keys.T[::-1])
    assert np.array_equal(_order_of(keys, None, (heads, m)), want)
    assert np.array_equal(_order_of(keys), want)


@settings(deadline=None, max_examples=100)
@given(data=st.data(), widths=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       n=st.sampled_from([41, 1000, 2 ** 20 + 1, 2 ** 40]))
def test_hits_in_runs_are_the_numpy_output(data, widths, n):
    """hits_in_order on pairs arriving in runs of their simulation simplex (stage 1's
    order: the run heads' path) is loop._output's numpy path: ids through the rank
    map, sorted_rows, packed_keys, distinct_lex_order, take."""
    from predicates.compiled.hitorder import hits_in_order
    from predicates.registration.levels.complex import (
        distinct_lex_order, packed_keys, sorted_rows)

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    sides = []
    for w in widths:  # simplices: distinct rows of ranks; ranks -> input ids < n
        S = np.unique(np.sort(rng.integers(0, 40, (60, w)), axis=1), axis=0)
        ids = rng.choice(min(n, 10 ** 6), 40, replace=False) + (n - min(n, 10 ** 6))
        sides.append((S, ids.astype(np.int64)))
    m = data.draw(st.integers(1, 400))
    pairs = np.unique(np.stack([rng.integers(0, min(len(sides[0][0]), 12), m),
                                rng.integers(0, len(sides[1][0]), m)], axis=1), axis=0)
    order = rng.permutation(len(pairs))  # runs of s, each run's c in no order
    pairs = pairs[order[np.argsort(pairs[order, 0], kind="stable")]]
    if data.draw(st.booleans()):  # a simplex met again after others
        pairs = np.concatenate([pairs[len(pairs) // 2:], pairs[:len(pairs) // 2]])
    s, c = pairs[:, 0], pairs[:, 1]
    (S1, ids1), (S2, ids2) = sides
    sid, cid = ids1[S1[s]], ids2[S2[c]]
    want = distinct_lex_order(packed_keys(sorted_rows(sid), n) + packed_keys(sorted_rows(cid), n))
    got, got1, got2 = hits_in_order((S1, ids1, s, n), (S2, ids2, c, n))
    assert np.array_equal(got, want)
    assert np.array_equal(got1, sid[want]) and np.array_equal(got2, cid[want])


def test_radix_first_takes_both_routes():
    """Keys over more than two digits: the passes over the two highest, then runs of
    equal high bits by insertion (``_low_bits`` True) — or, at a run over 2·_SHORT rows
    (many keys below 2^19 beside one at 2^40), every digit's pass after all (False):
    a stable argsort either way, ties and equal high bits included."""
    from predicates.compiled.hitorder import _SHORT, _low_bits, _radix_first

    rng = np.random.default_rng(3)
    spread = rng.integers(0, 2 ** 40, 3000, dtype=np.int64)
    spread[:300:7] = spread[0]  # ties (43 rows): their order kept
    spread[1:300:7] = spread[1] + rng.integers(0, 8, 43)  # equal high bits, ties
    crowded = np.r_[rng.integers(0, 2 ** 10, 4 * _SHORT), 2 ** 40].astype(np.int64)
    for keys, route in ((spread, True), (crowded, False)):
        n, shift = len(keys), (int(keys.max() - keys.min()).bit_length() - 22)
        order = np.argsort(keys >> shift, kind="stable")
        ranked = keys[order] - keys.min()
        assert _low_bits(order, ranked, shift, 2 * _SHORT) == route
        got, vals = np.empty(n, np.int64), np.empty(n, np.int64)
        _radix_first(keys[:, None], got, vals, np.empty((2, n), np.int64))
        want = np.argsort(keys, kind="stable")
        assert np.array_equal(got, want) and np.array_equal(vals, keys[want])


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), m=st.integers(0, 300), w=st.integers(1, 5),
       dtype=st.sampled_from([np.float64, np.float32]))
def test_rows_in_order_is_take(seed, m, w, dtype):
    """rows_in_order(W, order) = W.take(order, axis=0) for a permutation (the weights'
    final order): widths written out (2, 3) and looped, ±0.0, NaN and ±inf kept bit
    for bit, float32 and float64, no rows."""
    from predicates.compiled.hitorder import rows_in_order

    rng = np.random.default_rng(seed)
    W = rng.standard_normal((m, w)).astype(dtype)
    W[rng.random((m, w)) < 0.1] = -0.0
    W[rng.random((m, w)) < 0.05] = np.nan
    W[rng.random((m, w)) < 0.05] = -np.inf
    order = rng.permutation(m)
    got, want = rows_in_order(W, order), W.take(order, axis=0)
    assert got.dtype == W.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()
