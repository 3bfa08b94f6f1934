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
