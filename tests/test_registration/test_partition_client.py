"""The client's share of a partitioned plan with the cells on the workers
(benchmarks/README.md "The 2-worker W4 client, fifth pass"): the flagged cells' boxes,
the used vertices and the split's Morton box, against their definitions."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates.registration.partition.remote import _used
from predicates.registration.partition.run_arrays import DeferredRun
from predicates.registration.partition.split_keys import chunk_run, first_hull
from predicates.registration.partition.split_remote import run_hull
from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import boxes_of

_VALUES = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.5, 3.25, 1e300, -1e-300, np.nan,
                           np.inf, -np.inf, 2.0 ** -1074])


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 12), m=st.integers(0, 40), seed=st.integers(0, 2 ** 32 - 1),
       special=st.lists(_VALUES, max_size=8), dtype=st.sampled_from(["f8", "f4"]),
       ids=st.sampled_from(["i4", "i8", "u4"]), block=st.integers(1, 9))
def test_flagged_boxes_are_numpy_boxes(n, m, seed, special, dtype, ids, block):
    """The flagged cells' boxes the compiled client computes
    (:meth:`~predicates.registration.partition.remote.RemoteCells.flag_pass`:
    :func:`boxes_of` with the accelerator, each tetrahedron's ids read once by
    ``compiled.cells.fill_boxes``) are bit for bit numpy's (:func:`boxes_of` on the
    numpy path): NaN, signed zeros, infinities and subnormals among the points, float32
    points, any id dtype, blocks of a few rows — tetrahedra and the other branches
    (triangles, 2D)."""
    pytest.importorskip("numba")
    rng = np.random.default_rng(seed)
    P = rng.integers(-3, 4, (n, 3)) * 0.5
    flat = P.ravel()
    flat[rng.integers(0, flat.size, len(special))] = special
    with np.errstate(over="ignore"):
        P = P.astype(dtype)
    for width, pts in ((4, P), (3, P), (3, np.ascontiguousarray(P[:, :2]))):
        cells = rng.integers(0, n, (m, width)).astype(ids)
        want = boxes_of(pts, cells, SERIAL)
        got = boxes_of(pts, cells, Blocks(accelerate=True, block=block))
        for g, w in zip(got, want):
            assert g.shape == w.shape and g.dtype == w.dtype
            assert np.array_equal(g.view(np.uint64), w.view(np.uint64))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 70), chunks=st.lists(st.one_of(st.none(), st.integers(0, 2 ** 32 - 1)),
                                           min_size=1, max_size=4))
def test_used_is_the_or_of_the_chunks_masks(n, chunks):
    """:func:`_used`: the OR of every chunk's unpacked mask; a chunk that failed a check
    (no bits, None here) adds nothing."""
    masks = [np.zeros(n, bool) if c is None else np.random.default_rng(c).random(n) < 0.3
             for c in chunks]
    bits = [np.packbits(np.zeros(0, bool)) if c is None else np.packbits(mask)
            for c, mask in zip(chunks, masks)]
    want = np.logical_or.reduce(masks)
    got = _used(n, bits)
    assert got.dtype == bool and got.shape == (n,) and np.array_equal(got, want)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), dim=st.sampled_from([2, 3]),
       dtype=st.sampled_from([np.float64, np.float32]), n_chunks=st.integers(1, 5),
       e=st.integers(-4, 4), fast=st.booleans())
def test_run_hull_is_the_chunks_first_hulls(seed, dim, dtype, n_chunks, e, fast):
    """:func:`run_hull` on the client: the box and count the chunks' ``first_hull``
    give (min, max over their hulls), for random run masks and chunkings, float32
    points and scalings, numpy and compiled (``fast``: min and max, then the scaling);
    None without run cells."""
    if fast:
        pytest.importorskip("numba")
    rng = np.random.default_rng(seed)
    n = int(rng.integers(dim + 1, 40))
    P = (rng.normal(size=(n, dim)) * 2.0 ** rng.integers(-3, 4)).astype(dtype)
    P[rng.integers(0, n, 2)] = rng.choice([0.0, -0.0], (2, dim))
    m_all = int(rng.integers(1, 60))
    C = np.argsort(rng.random((m_all, n)), axis=1)[:, :dim + 1]
    ms = rng.random(m_all) < rng.uniform(0.0, 1.0)
    cuts = np.linspace(0, m_all, n_chunks + 1).astype(int)
    runs = [chunk_run(C[a:b], P, np.packbits(ms[a:b]), int(a), e, P.dtype, False)
            for a, b in zip(cuts[:-1], cuts[1:])]
    hulls = [first_hull(r) for r in runs]
    got = run_hull(DeferredRun(P, C[ms], e, fast))
    if not ms.any():
        assert got is None
        return
    lo, hi, m = got
    assert m == sum(h[1] for h in hulls) == ms.sum()
    want_lo = np.min([h[0][0] for h in hulls if h[1]], axis=0)
    want_hi = np.max([h[0][1] for h in hulls if h[1]], axis=0)
    # equal values (a zero's sign may differ: the same Morton codes)
    assert lo.dtype == hi.dtype == np.float64
    assert np.array_equal(lo, want_lo) and np.array_equal(hi, want_hi)
    assert run_hull(None) is None


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(1, 30), m=st.integers(1, 50),
       dim=st.sampled_from([2, 3]), k=st.integers(1, 4),
       dtype=st.sampled_from(["f8", "f4"]), ids=st.sampled_from(["i4", "i8", "u4"]),
       special=st.lists(st.sampled_from([0.0, -0.0, 1e300, -1e300, 2.0 ** -1074]),
                        max_size=4))
def test_first_vertex_hull_is_numpys_min_and_max(seed, n, m, dim, k, dtype, ids, special):
    """:func:`predicates.compiled.runhull.first_vertex_hull`: the min and max per axis
    of the first column's vertices, as numpy reduces their gather (equal values, the
    points' dtype; extremes and subnormals among them; any id dtype; one row)."""
    pytest.importorskip("numba")
    from predicates.compiled.runhull import first_vertex_hull

    rng = np.random.default_rng(seed)
    P = (rng.integers(-5, 6, (n, dim)) * 0.25).astype(dtype)
    flat = P.ravel()
    flat[rng.integers(0, flat.size, len(special))] = np.array(special, dtype=float).astype(dtype)
    run = rng.integers(0, n, (m, k)).astype(ids)
    lo, hi = np.empty(dim, P.dtype), np.empty(dim, P.dtype)
    first_vertex_hull(P, run, lo, hi)
    first = P[run[:, 0]]
    assert np.array_equal(lo, first.min(axis=0)) and np.array_equal(hi, first.max(axis=0))
