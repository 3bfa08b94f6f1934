"""Exact sums and exactly rounded means of binary64 values
(predicates.registration.spatial.exactsum): the broad-phase grid's mean extent is the
same bit for bit whatever the order of the boxes and however they are split
(docs/partitioned.md, section 2)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings, strategies as st

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxgrid import extent_sums, mean_extent
from predicates.registration.spatial.exactsum import ExactSum

values = st.lists(st.one_of(st.floats(0, 1e308), st.just(5e-324), st.just(-0.0),
                            st.floats(0, 2.0 ** -1020), st.floats(1, 2)), max_size=200)


@settings(max_examples=200, deadline=None)
@given(values, st.randoms(use_true_random=False))
def test_sum_and_mean_are_exact_and_split_independent(xs, rnd):
    x = np.array(xs, dtype=np.float64)
    ref = sum((Fraction(v) for v in xs), Fraction(0))
    s = ExactSum().add(x)
    assert Fraction(s.total(), 2 ** 1074) == ref and s.n == len(xs)
    assert s.mean() == (float(ref / len(xs)) if xs else 0.0)
    perm = x[np.array(rnd.sample(range(len(xs)), len(xs)), dtype=np.int64)]
    cut = sorted(rnd.sample(range(len(xs) + 1), min(3, len(xs) + 1)))
    parts = [ExactSum().add(p) for p in np.split(perm, cut)]
    for p in parts[1:]:
        parts[0].merge(p)
    assert parts[0].total() == s.total() and parts[0].mean() == s.mean()


def test_many_values_flush_exactly():
    """More values per binade than the float accumulators hold exactly (2^25)."""
    x = np.full(1 << 16, 1.0 - 2.0 ** -53)
    s = ExactSum()
    for _ in range(520):
        s.add(x)
    assert s.total() == 520 * (1 << 16) * ((1 << 1074) - (1 << 1021))
    assert s.mean() == 1.0 - 2.0 ** -53


def test_infinity_and_nan_as_a_float_sum():
    assert ExactSum().add(np.array([1.0, np.inf])).mean() == np.inf
    assert np.isnan(ExactSum().add(np.array([np.nan, 1.0])).mean())


def test_mean_extent_is_the_rounded_exact_mean_for_any_blocks():
    rng = np.random.default_rng(5)
    lo = rng.random((1000, 3)) * 2.0 ** rng.integers(-30, 30, (1000, 1))
    hi = lo + rng.random((1000, 3)) ** 3
    want = max(float(sum(Fraction(float(v)) for v in hi[:, ax] - lo[:, ax]) / 1000)
               for ax in range(3))
    for bl in (Blocks(), Blocks(block=7), Blocks(block=1)):
        assert mean_extent(lo, hi, blocks=bl) == want
        assert mean_extent(lo[::-1], hi[::-1], blocks=bl) == want
    capped = extent_sums(lo, hi, cap=0.25)
    assert all(s.mean() <= 0.25 for s in capped)
