"""The compiled boxes (predicates.compiled.cells.fill_boxes, behind
``boxes_of(..., Blocks(accelerate=True))``) are numpy's ``boxes_of`` bit for bit
(docs/design.md, "Compiled candidate chain"): every branch — 3D tetrahedra and
triangles (each row's ids read once, unsigned) and any other d and k — on adversarial
points drawn by hypothesis (NaN, ±inf, −0.0 beside 0.0, subnormals, float32), repeated
ids, every id dtype and layout, empty inputs, blocks of a few rows.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from predicates.registration.spatial.blocks import SERIAL, Blocks  # noqa: E402
from predicates.registration.spatial.boxes import boxes_of  # noqa: E402

_SPECIAL = [0.0, -0.0, np.nan, np.inf, -np.inf, 2.0 ** -1074, -(2.0 ** -1074), 1e300,
            -1e300, 0.5, -0.5]


def _same(got, want) -> None:
    """(lo, hi) pairs with the same shapes, dtypes, strides and bytes."""
    for g, w in zip(got, want):
        assert g.shape == w.shape and g.dtype == w.dtype and g.strides == w.strides
        assert g.tobytes() == w.tobytes()


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([1, 2, 3, 3, 3, 4]),
       k=st.sampled_from([1, 2, 3, 4, 4, 5]), n=st.integers(1, 10), m=st.integers(0, 50),
       share=st.sampled_from([0.0, 0.3, 1.0]), dtype=st.sampled_from(["f8", "f4"]),
       ids=st.sampled_from(["i4", "i8", "u4", "u8", "i2"]),
       layout=st.sampled_from(["C", "F", "strided"]), block=st.integers(1, 9),
       repeat=st.booleans())
def test_compiled_boxes_are_numpy_boxes(seed, d, k, n, m, share, dtype, ids, layout,
                                        block, repeat):
    """lo and hi of every row bit for bit numpy's: the points from a few values (so
    −0.0 and 0.0 tie often) and a share of specials, rows with repeated ids (forced
    in some), ids of any integer dtype in C, Fortran or strided layout, serial or in
    blocks of a few rows; m = 0 gives empty (0, d) boxes."""
    rng = np.random.default_rng(seed)
    P = rng.choice([0.0, -0.0, 1.0, -1.0, 0.25], size=(n, d))
    special = rng.random((n, d)) < share
    P[special] = rng.choice(_SPECIAL, size=int(special.sum()))
    with np.errstate(over="ignore"):
        P = P.astype(dtype)
    rows = rng.integers(0, n, size=(m, 2 * k if layout == "strided" else k))
    if repeat and k > 1:
        rows[:, -1] = rows[:, 0]
    rows = rows.astype(ids)
    rows = {"C": rows, "F": np.asfortranarray(rows), "strided": rows[:, ::2]}[layout]
    want = boxes_of(P, rows, SERIAL)
    for blocks in (Blocks(accelerate=True), Blocks(accelerate=True, block=block)):
        _same(boxes_of(P, rows, blocks), want)


def test_the_comparison_tells_a_wrong_fold():
    """Rows where numpy's fold (the vertices in column order, the second operand among
    equal values, NaN kept) differs from a fold in reverse order, with the middle
    vertices swapped, from the first operand among equals and from a NaN-ignoring min:
    the compiled tetrahedra and triangles give numpy's, so this test and the one above
    fail on such a kernel (a kernel folding j and k swapped failed both, 29 Nov)."""
    P = np.array([[0.0, -0.0, np.nan], [-0.0, 0.0, 1.0], [0.0, -0.0, 2.0],
                  [-0.0, 0.0, 3.0], [1.0, 1.0, 1.0]])
    # (row [4, 0, 1, 4]: x = 1, 0, −0, 1 — lo is −0.0 only if 0 is folded before −0)
    for rows, swap in ((np.array([[0, 1, 2, 3], [3, 2, 1, 0], [0, 0, 1, 1], [4, 0, 1, 4]]),
                        [0, 2, 1, 3]),
                       (np.array([[0, 1, 2], [2, 1, 0], [1, 1, 0], [4, 0, 1]]), [0, 2, 1])):
        want = boxes_of(P, rows, SERIAL)
        _same(boxes_of(P, rows, Blocks(accelerate=True)), want)
        _same(boxes_of(P.astype(np.float32), rows, Blocks(accelerate=True)),
              boxes_of(P.astype(np.float32), rows, SERIAL))
        X = P[rows]  # (m, k, d)
        reversed_ = boxes_of(P, rows[:, ::-1].copy(), SERIAL)
        swapped = boxes_of(P, rows[:, swap], SERIAL)  # the middle vertices swapped
        first = [X[:, 0].copy(), X[:, 0].copy()]
        fmin = [X[:, 0].copy(), X[:, 0].copy()]
        for v in range(1, rows.shape[1]):
            first = [np.where(X[:, v] < first[0], X[:, v], first[0]),
                     np.where(X[:, v] > first[1], X[:, v], first[1])]
            fmin = [np.fmin(fmin[0], X[:, v]), np.fmax(fmin[1], X[:, v])]
        for wrong in (reversed_, swapped, first, fmin):
            assert any(a.tobytes() != b.tobytes() for a, b in zip(wrong, want))
