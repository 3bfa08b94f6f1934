"""The complexes' compiled passes (predicates.compiled.rows: unique faces, face tables,
ranked cells) equal their numpy twins array for array (docs/design.md, "Compiled
candidate chain"), on each of unique_faces' routes (short runs by insertion, pairs of
ids by a stamp per run, long runs by the column counting sort) and on single ids
(flags); each against np.unique or a plain numpy reference."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from predicates.compiled import rows as compiled_rows  # noqa: E402
from predicates.registration.levels.complex import Complex, Side  # noqa: E402


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), k=st.integers(1, 3),
       n=st.sampled_from([2, 5, 40, 3000]), m=st.integers(1, 300),
       dtype=st.sampled_from([np.int32, np.int64]))
def test_unique_faces_equal_numpy_unique(seed, k, n, m, dtype):
    """unique_faces(rows, combos) = np.unique of the gathered faces (rows and inverse
    map), the rows' ids unsorted and repeated; n = 2, 5 give runs longer than _RUN (the
    counting-sort route), n = 3000 short runs (insertion)."""
    rng = np.random.default_rng(seed)
    rows = rng.integers(0, n, size=(m, k + 1)).astype(dtype)
    rows[rng.random(m) < 0.2] = rows[0]
    for width in range(1, k + 1):
        combos = np.array(list(itertools.combinations(range(k + 1), width)))
        faces = rows[:, combos].reshape(-1, width)
        want, inv = np.unique(faces, axis=0, return_inverse=True)
        got, got_inv = compiled_rows.unique_faces(rows, combos, n)
        assert got.dtype == rows.dtype and np.array_equal(got, want)
        assert np.array_equal(got_inv, inv.ravel())


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), g=st.integers(1, 6), w=st.integers(2, 4),
       n=st.sampled_from([3, 40, 3000]), m=st.integers(0, 200))
def test_unique_faces_any_number_of_faces_per_row(seed, g, w, n, m):
    """unique_faces with g = 1–6 combinations per row (the gather's row number split
    by a constant divisor for 1–4, by g else), columns in any order: np.unique's rows
    and map of the gathered faces."""
    rng = np.random.default_rng(seed)
    rows = rng.integers(0, n, size=(m, 4)).astype(np.int64)
    rows[rng.random(m) < 0.3] = rows[0] if m else 0
    combos = np.array([rng.permutation(4)[:w] for _ in range(g)])
    faces = rows[:, combos].reshape(-1, w)
    want, inv = np.unique(faces, axis=0, return_inverse=True)
    got, got_inv = compiled_rows.unique_faces(rows, combos, n)
    assert got.shape == (len(want), w) and np.array_equal(got, want)
    assert np.array_equal(got_inv, inv.ravel())


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.sampled_from([46340, 46341]),
       m=st.integers(1, 200), dtype=st.sampled_from([np.int32, np.int64]))
def test_unique_faces_key_widths(seed, n, m, dtype):
    """Rows of three ids packed into int32 keys while n^2 < 2^31 (n = 46,340: keys up
    to 2^31 − 1 − 92,680), int64 beyond (n = 46,341: keys past 2^31): ids near n, ties
    and repeated rows — np.unique's rows and map either way (an int32 key at n =
    46,341 wraps and misorders)."""
    rng = np.random.default_rng(seed)
    rows = (n - 1 - rng.integers(0, 6, size=(m, 4))).astype(dtype)
    rows[rng.random(m) < 0.3] = rows[0]
    rows[rng.random(m) < 0.2, 1:] = rng.integers(0, 3, 3)  # small rests: both ends
    combos = np.array(list(itertools.combinations(range(4), 3)))
    want, inv = np.unique(rows[:, combos].reshape(-1, 3), axis=0, return_inverse=True)
    got, got_inv = compiled_rows.unique_faces(rows, combos, n)
    assert got.dtype == rows.dtype and np.array_equal(got, want)
    assert np.array_equal(got_inv, inv.ravel())


def test_unique_faces_takes_both_routes():
    """The insertion route refuses a run longer than _RUN (and then the counting sort
    answers), takes short runs: the test above exercises both."""
    n = 3000
    short = np.arange(2 * n).reshape(-1, 2) % n
    long_ = np.zeros((compiled_rows._RUN + 1, 2), dtype=np.int64)
    long_[:, 1] = np.arange(len(long_))
    for rows, route in ((short, True), (long_, False)):
        m = len(rows)
        out = [np.empty(m, np.int64) for _ in range(4)]
        nu = compiled_rows._by_first(rows, np.arange(2)[None, :], n, 0,
                                     np.zeros(n + 1, np.int64), *out)
        assert (nu >= 0) == route
        assert np.array_equal(compiled_rows.unique_rows(rows, n)[0], np.unique(rows, axis=0))


def test_unique_pairs_take_both_routes():
    """Rows of two ids: the stamp route (each run's distinct second ids sorted) answers
    runs of up to 4·_RUN rows, many of them repeated, and refuses a longer run (a hub
    vertex; the counting sort answers): np.unique's rows and map either way."""
    n = 3000
    rng = np.random.default_rng(7)
    hub_run = 4 * compiled_rows._RUN
    repeated = np.stack([rng.integers(0, 5, hub_run), rng.integers(0, 9, hub_run)], 1)
    hub = np.stack([np.zeros(hub_run + 1, np.int64), np.arange(hub_run + 1)], 1)
    for rows, route in ((repeated, True), (hub, False)):
        m = len(rows)
        out = [np.zeros(n + 1, np.int64), np.empty(m, np.int32), np.empty(m, np.int32),
               np.full(n, -1, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)]
        nu = compiled_rows._pairs_by_first(rows, np.arange(2)[None, :], n, 0, *out)
        assert (nu >= 0) == route
        want, inv = np.unique(rows, axis=0, return_inverse=True)
        got, got_inv = compiled_rows.unique_rows(rows, n)
        assert np.array_equal(got, want) and np.array_equal(got_inv, inv.ravel())


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), w=st.integers(2, 4),
       n=st.sampled_from([1, 2, 1024, 1025, 2 ** 15, 2 ** 15 + 1, 2 ** 21, 2 ** 21 + 1]),
       m=st.integers(0, 120), dtype=st.sampled_from([np.int32, np.int64]),
       inverse=st.booleans())
def test_unique_rows_packed_whole_or_gathered(seed, w, n, m, dtype, inverse):
    """Rows packed whole by shifts (ids < 2^sh, sh·w ≤ 63: 4 ids to n = 2^15, 3 to
    2^21) and unpacked, or gathered past that (n = 2^15 + 1, 2^21 + 1), int32 or int64
    keys (n = 1024, 1025): ids near n and near 0, ties, repeats, no rows — np.unique's
    rows and map, and no map when ``inverse`` is False (the distinct cells)."""
    rng = np.random.default_rng(seed)
    rows = (n - 1 - rng.integers(0, min(n, 6), size=(m, 4))).astype(dtype)
    rows[rng.random(m) < 0.3] = rows[0] if m else 0
    rows[rng.random(m) < 0.2, 1:] = rng.integers(0, min(n, 3), 3)
    for g in (1, 4):
        combos = (np.arange(w)[None, :] if g == 1
                  else np.array(list(itertools.combinations(range(4), w))))
        faces = rows[:, combos].reshape(-1, w)
        want, inv = np.unique(faces, axis=0, return_inverse=True)
        got, got_inv = compiled_rows.unique_faces(rows, combos, n, inverse)
        assert got.dtype == rows.dtype and got.shape == (len(want), w)
        assert np.array_equal(got, want)
        assert np.array_equal(got_inv, inv.ravel()) if inverse else got_inv is None


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(1, 3000), shape=st.sampled_from(
    [(0, 3), (1, 1), (50, 3), (40, 4), (7,)]), dtype=st.sampled_from([np.int32, np.int64]))
def test_looked_up_is_take(seed, n, shape, dtype):
    """looked_up(table, ids) = table.take(ids) (the complexes' F[k, 0]): values, shape,
    dtype; ids at both ends of the table, repeated, none."""
    rng = np.random.default_rng(seed)
    table = rng.integers(-(2 ** 40), 2 ** 40, n)
    ids = rng.integers(0, n, size=shape).astype(dtype)
    if ids.size:
        ids.reshape(-1)[0], ids.reshape(-1)[-1] = 0, n - 1
    got, want = compiled_rows.looked_up(table, ids), table.take(ids)
    assert got.dtype == want.dtype and got.shape == want.shape and np.array_equal(got, want)


def test_unpack_reads_every_field():
    """_unpack's written-out widths and its loop: each field at its shift."""
    for w in (2, 3, 4):
        rows = np.array([[5, 0, 7, 1][:w], [1, 2, 3, 4][:w]], dtype=np.int64)
        packed = np.zeros(2, np.int64)
        for c in range(w):
            packed = (packed << 3) | rows[:, c]
        out = np.empty((2, w), np.int64)
        compiled_rows._unpack(packed, 3, out)
        assert np.array_equal(out, rows)


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), w=st.integers(1, 5), n=st.sampled_from([3, 50]),
       m=st.integers(0, 100), dtype=st.sampled_from([np.int32, np.int64]))
def test_ranked_rows_are_sorted_ranks(seed, w, n, m, dtype):
    """ranked_rows (rows of 3 and 4 by written-out compare-exchanges, others by
    insertion) = np.sort(rank.take(cells), axis=1): repeated ids and ranks (ties)."""
    rng = np.random.default_rng(seed)
    rank = rng.integers(0, n, size=n).astype(dtype)  # (not a permutation: ties)
    cells = rng.integers(0, n, size=(m, w))
    got = compiled_rows.ranked_rows(rank, cells)
    assert got.dtype == rank.dtype and np.array_equal(got, np.sort(rank.take(cells), axis=1))


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([2, 3]),
       n=st.sampled_from([6, 60, 2000]), m=st.integers(1, 200))
def test_compiled_sides_and_complexes_are_numpys(seed, d, n, m):
    """Side(..., accelerate=True) (used vertices, each cell's sorted ranks) and its
    complex (unique faces, face tables via a middle level) equal the numpy path's,
    every array; repeated and degenerate cells, points with equal coordinates."""
    rng = np.random.default_rng(seed)
    P = rng.integers(0, 4, size=(n, d)).astype(np.float64)
    cells = rng.integers(0, n, size=(m, d + 1))
    a, b = Side(P, cells), Side(P, cells, accelerate=True)
    assert np.array_equal(a.cells, b.cells) and a.cells.dtype == b.cells.dtype
    assert np.array_equal(a.order, b.order) and np.array_equal(a.P, b.P)
    tops = a.unique_cells()
    assert np.array_equal(tops, b.unique_cells())
    a.build_unique(tops)
    b.build_unique(tops)
    assert a.cx.S.keys() == b.cx.S.keys() and a.cx.F.keys() == b.cx.F.keys()
    for key in a.cx.S:
        assert np.array_equal(a.cx.S[key], b.cx.S[key])
    for key in a.cx.F:
        assert a.cx.F[key].dtype == b.cx.F[key].dtype
        assert np.array_equal(a.cx.F[key], b.cx.F[key])
    # the face tables' meaning: each listed face's vertices are among the simplex's
    cx = b.cx
    for (k, j), F in cx.F.items():
        for r in range(min(len(F), 20)):
            assert set(cx.S[j][F[r]].ravel()) <= set(cx.S[k][r])


def test_complex_numpy_path_without_compiled_kernels():
    """The numpy path's complex (accelerate=False) never calls the compiled passes."""
    cells = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
    called = []
    orig = compiled_rows.faces_via
    compiled_rows.faces_via = lambda *a: called.append(1) or orig(*a)
    try:
        Complex(cells, 5)
    finally:
        compiled_rows.faces_via = orig
    assert not called


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_compiled_boxes_are_boxes_of(dtype, k):
    """The registration's compiled boxes (one call on whole arrays, unsigned gathers)
    are boxes_of's numpy boxes bit for bit, the sign of a zero included (np.minimum's
    choice among equal values), for int32 and int64 vertex ids."""
    from predicates.compiled.boxtest import boxes
    from predicates.registration.spatial.boxes import boxes_of

    rng = np.random.default_rng(k)
    P = rng.integers(-3, 4, size=(40, 3)).astype(dtype) * dtype(0.5)
    P[rng.random(40) < 0.3, 1] = dtype(-0.0)  # −0.0 beside 0.0: the fold's choice shows
    for ids in (np.int32, np.int64):
        R = rng.integers(0, 40, size=(300, k)).astype(ids)
        want, got = boxes_of(P, R), boxes(P, R)
        for w, g in zip(want, got):
            assert g.shape == w.shape and g.dtype == w.dtype
            assert np.array_equal(g.view(np.int64), w.view(np.int64))  # bits, −0.0 too


@settings(deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(0, 400), d=st.integers(1, 3),
       levels=st.sampled_from([2, 5, 1000]), special=st.booleans())
def test_lex_point_order_equals_lexsort(seed, n, d, levels, special):
    """pointorder.lex_point_order = np.lexsort(X.T[::-1]) (x first, ties by position),
    on coordinates with few distinct values (long runs: both the insertions and the
    np.lexsort route) and, with ``special``, NaN, ±0.0 and infinities among them; the
    compiled route itself (quicksort of x, then the runs) whenever it accepts the runs,
    and leaving the order as it was when it declines them."""
    from predicates.compiled.pointorder import _finish, lex_point_order

    rng = np.random.default_rng(seed)
    X = rng.integers(0, levels, size=(n, d)).astype(np.float64) / 7
    if special and n:
        X.ravel()[rng.integers(0, X.size, size=X.size // 3 + 1)] = rng.choice(
            [np.nan, 0.0, -0.0, np.inf, -np.inf], size=X.size // 3 + 1)
    assert np.array_equal(lex_point_order(X), np.lexsort(X.T[::-1]))
    if n > 1 and d:
        order = np.argsort(X[:, 0])
        before = order.copy()
        if _finish(X, order):
            assert np.array_equal(order, np.lexsort(X.T[::-1]))
        else:
            assert np.array_equal(order, before)
