"""Per-row passes in blocks (predicates.registration.spatial.blocks): the same values and the same
error messages for every block size, sequential or on a thread pool."""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from predicates.registration.spatial import blocks as B
from predicates.registration.plan.inputs import validate_pair
from predicates.registration.plan.resolution import shortest_edge

WHOLE = B.Blocks(block=1 << 30)


@pytest.fixture
def small_spans(monkeypatch):
    monkeypatch.setattr(B, "MIN_SPAN", 2)


def _variants(pool):
    return [B.Blocks(block=3), B.Blocks(block=1), B.Blocks(pool, 2, block=3),
            B.Blocks(pool, 3, block=2)]


def test_spans_and_blocks_cover_every_row_once(small_spans):
    for n in (0, 1, 5, 17, 64):
        for bl in (B.Blocks(block=4), B.Blocks(object(), 3, block=5)):
            rows = [r for a, b in bl.spans(n) for lo, hi in bl.each(a, b)
                    for r in range(lo, hi)]
            assert rows == list(range(n))
    with pytest.raises(ValueError, match="block"):
        B.Blocks(block=0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["negative", "range", "repeat", "two"]))
def test_validation_reports_the_first_bad_cell_whatever_the_blocks(seed, fault):
    """A bad cell is reported with the same message (the first such cell, checks in the
    order negative, out of range, repeated vertex) for every blocking."""
    rng = np.random.default_rng(seed)
    P = rng.random((30, 3))
    C = np.array([rng.permutation(30)[:4] for _ in range(int(rng.integers(5, 40)))])
    where = rng.integers(0, len(C), 2)
    if fault in ("negative", "two"):
        C[where[0], 1] = -1
    if fault in ("range", "two"):
        C[where[1], 2] = 30
    if fault == "repeat":
        C[where[0], 3] = C[where[0], 0]
    cut = (P, np.array([[0, 1, 2]]))

    def message(bl):
        with pytest.raises(ValueError) as e:
            validate_pair(P, C, *cut, np.float64, bl)
        return str(e.value)

    old = B.MIN_SPAN
    B.MIN_SPAN = 2
    try:
        ref = message(WHOLE)
        with ThreadPoolExecutor(2) as pool:
            assert all(message(bl) == ref for bl in _variants(pool))
    finally:
        B.MIN_SPAN = old
    # the message of the definition: the first cell failing the first check that fails
    neg, out = (C < 0).any(axis=1), (C >= 30).any(axis=1)
    rep = np.array([len(set(c.tolist())) < 4 for c in C])
    t, bad = next((t, b) for t, b in enumerate((neg, out, rep)) if b.any())
    i = int(np.argmax(bad))
    words = ("negative vertex index in cell", "vertex index out of range in cell",
             "cell")[t]
    assert f"{words} {i}" in ref and ref.split(": ", 2)[-1].startswith(str(C[i].tolist())), ref


def test_validation_keeps_the_cells_whatever_the_blocks(small_spans):
    """Validated cells are the input array itself (integer dtype kept, no int64 copy:
    a mesh's cells are most of its bytes), checked block by block."""
    rng = np.random.default_rng(3)
    P = rng.random((50, 3))
    C = np.array([rng.permutation(50)[:4] for _ in range(23)], dtype=np.int32)
    _, ref, _ = validate_pair(P, C, P, C[:, :3], np.float64, WHOLE)
    with ThreadPoolExecutor(2) as pool:
        for bl in _variants(pool):
            _, got, _ = validate_pair(P, C, P, C[:, :3], np.float64, bl)
            assert got.cells is C and got.cells.dtype == np.int32
            assert np.array_equal(got.cells, ref.cells)
    for dt in (np.uint8, np.int16, np.uint32, np.int64):
        _, got, _ = validate_pair(P, C.astype(dt), P, C[:, :3], np.float64, WHOLE)
        assert got.cells.dtype == dt and np.array_equal(got.cells, C)
    small = C.astype(np.uint8)  # 50 points: every uint8 id ≥ 50 is out of range
    small[4, 2] = 200
    with pytest.raises(ValueError, match="out of range in cell 4"):
        validate_pair(P, small, P, C[:, :3], np.float64, B.Blocks(block=3))
    neg = C.astype(np.int8)
    neg[9, 0] = -1
    with pytest.raises(ValueError, match="negative vertex index in cell 9"):
        validate_pair(P, neg, P, C[:, :3], np.float64, B.Blocks(block=3))
    big = C.astype(np.uint64)
    big[7, 1] = 2**63 + 5  # wraps negative as int64: still "out of range", cell 7
    with pytest.raises(ValueError, match="out of range in cell 7"):
        validate_pair(P, big, P, C[:, :3], np.float64, B.Blocks(block=3))


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]))
@example(63823, 3)
def test_shortest_edge_is_the_definition(seed, dim):
    """The shortest edge of the selected cells: min over cells and vertex pairs of
    sqrt of the squared differences summed axis by axis (the same float expression),
    for every blocking."""
    rng = np.random.default_rng(seed)
    P = rng.uniform(-1, 1, (40, dim)) * 10.0 ** rng.integers(-3, 3)
    C = np.array([rng.permutation(40)[:dim + 1] for _ in range(int(rng.integers(1, 30)))])
    mask = rng.random(len(C)) < 0.7
    mask[int(rng.integers(len(C)))] = True
    # d * d, not d ** 2: CPython's float ** calls the C library's pow, which is not
    # correctly rounded everywhere (seed 63823: one square 1 ulp off on this machine)
    ref = min(math.sqrt(sum(d * d for d in (float(P[c[u], ax]) - float(P[c[v], ax])
                                            for ax in range(dim))))
              for c in C[mask] for u in range(dim + 1) for v in range(u + 1, dim + 1))
    old = B.MIN_SPAN
    B.MIN_SPAN = 2
    try:
        with ThreadPoolExecutor(2) as pool:
            for bl in [WHOLE] + _variants(pool):
                assert shortest_edge(P, C, mask, bl) == ref
    finally:
        B.MIN_SPAN = old
    assert shortest_edge(P, C, np.zeros(len(C), bool)) is None
