"""The plan's compiled flag pass (predicates.compiled.flagpass, .cells) and the hits' final order
(packed keys) are bit-identical to their numpy twins
(docs/design.md, "Compiled candidate chain"), on adversarial inputs drawn by hypothesis:
signed zeros, repeated coordinates, binades far apart, float32 points, boxes on grid
lines; serial and on a thread pool with tiny blocks. Each test also checks the property
the pass exists for against a brute-force reference.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from predicates.registration.plan.cellboxes import CellBoxes  # noqa: E402
from predicates.registration.plan.first_round import near_fixed  # noqa: E402
from predicates.registration.spatial.blocks import SERIAL, Blocks  # noqa: E402
from predicates.registration.spatial.broadphase import box_pairs_bruteforce  # noqa: E402

_VALUES = [-0.0, 0.0, 0.25, -0.5, 1.0, 1.0 + 2.0 ** -52, 3.0, 2.0 ** -30, -(2.0 ** 20)]
_SLOW = settings(max_examples=max(10, settings.default.max_examples // 4), deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _mesh(data, d: int):
    """Points (float64 or float32) from adversarial values and random ones, cells of
    d + 1 (possibly repeated) vertex ids."""
    seed = data.draw(st.integers(0, 2 ** 32 - 1))
    rng = np.random.default_rng(seed)
    n = data.draw(st.integers(2, 120))
    P = rng.choice(_VALUES, size=(n, d))
    mixed = rng.random(n) < 0.5
    P[mixed] = rng.random((int(mixed.sum()), d)) * 2.0 ** rng.integers(-3, 3)
    dtype = data.draw(st.sampled_from([np.float64, np.float32]))
    cells = rng.integers(0, n, size=(data.draw(st.integers(1, 400)), d + 1))
    return P.astype(dtype), cells, rng


def _blocks(pool):
    """(numpy, compiled) twins: the same spans and blocks (a hull's signed zero may
    depend on the blocks' merge order: −0.0 and 0.0 are the same origin)."""
    return [(Blocks(pool, t, block=b), Blocks(pool, t, block=b, accelerate=True))
            for t, b in ((1, None), (2, 7), (1, 5))]


@_SLOW
@given(data=st.data(), d=st.sampled_from([2, 3]))
def test_flag_pass_identical(data, d):
    """CellBoxes' blocks, summary and the lean plan's first round (near_fixed: flags of
    both sides, the largest edge of the flagged cells) with the fused compiled pass
    equal numpy's; every simulation cell with a partner within pad (brute force) is
    flagged, and the edge is exactly the flagged boxes' largest."""
    P, cells, rng = _mesh(data, d)
    lo_b = rng.choice(_VALUES[:5], size=(30, d)) + rng.random((30, d))
    hi_b = lo_b + rng.choice([0.0, 0.01, 0.5], size=(30, 1))
    pad = data.draw(st.sampled_from([0.0, 2.0 ** -20, 0.1]))
    ref_box = CellBoxes(P, cells, SERIAL)
    ref = near_fixed(ref_box, lo_b, hi_b, pad)
    lo, hi = ref_box.block(0, len(cells))
    ia, _ = box_pairs_bruteforce(lo, hi, lo_b, hi_b, pad)
    assert ref[0][ia].all()
    # the edge is hi − lo rounded once (monotone: the rounded exact maximum)
    flagged = [max(Fraction(float(h)) - Fraction(float(x)) for x, h in zip(lo[k], hi[k]))
               for k in np.flatnonzero(ref[0])]
    assert ref[2] == float(max(flagged, default=Fraction(0)))
    with ThreadPoolExecutor(2) as pool:
        for numpy_blocks, blocks in _blocks(pool):
            ref_box, box = CellBoxes(P, cells, numpy_blocks), CellBoxes(P, cells, blocks)
            for a, b in ((0, len(cells)), (1, min(len(cells), 6))):
                assert all(x.tobytes() == y.tobytes()
                           for x, y in zip(ref_box.block(a, b), box.block(a, b)))
            S, T = ref_box.summary(), box.summary()
            assert np.array_equal(S.lo_min, T.lo_min) and np.array_equal(S.hi_max, T.hi_max)
            assert (S.ext_max, S.ext_min) == (T.ext_max, T.ext_min)
            assert (S.hist is None) == (T.hist is None)
            assert S.hist is None or np.array_equal(S.hist, T.hist)
            want, got = near_fixed(ref_box, lo_b, hi_b, pad), near_fixed(box, lo_b, hi_b, pad)
            assert np.array_equal(want[0], ref[0]) and np.array_equal(want[1], ref[1])
            assert np.array_equal(want[0], got[0]) and np.array_equal(want[1], got[1])
            assert np.float64(want[2]).tobytes() == np.float64(got[2]).tobytes()


@settings(deadline=None)
@given(data=st.data(), widths=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       n=st.sampled_from([2, 3, 1000, 2 ** 20 + 1, 2 ** 31 - 1, 2 ** 40]))
def test_packed_order_is_lexsort(data, widths, n):
    """The hits' final order (loop._output: packed keys, lex_order) is np.lexsort's
    over the 2 + i + j id columns, equal rows included (stable), ids up to n − 1."""
    from predicates.registration.levels.complex import lex_order, packed_keys

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    m = data.draw(st.integers(0, 300))
    pool = np.array(sorted({0, 1, n - 1, n // 2, max(0, n - 2)}), dtype=np.int64)
    a = rng.choice(pool, size=(m, widths[0]))
    b = rng.choice(pool, size=(m, widths[1]))
    a[: m // 2] = rng.integers(0, n, size=(m // 2, widths[0]))
    both = np.concatenate([a, b], axis=1)
    want = np.lexsort(both.T[::-1])
    got = lex_order(packed_keys(a, n) + packed_keys(b, n))
    assert np.array_equal(got, want)
    # and the reference is what it claims: rows in lexicographic order, ties by position
    rows = [tuple(r) + (k,) for k, r in enumerate(both.tolist())]
    assert [r[-1] for r in sorted(rows)] == want.tolist()


@settings(deadline=None)
@given(data=st.data(), widths=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       n=st.sampled_from([2, 5, 1000, 2 ** 20 + 1, 2 ** 40]), long_runs=st.booleans())
def test_distinct_order_is_lexsort(data, widths, n, long_runs):
    """loop._output's order of a kind's hits (distinct rows: each pair registered
    once): sorted_rows is np.sort per row, and distinct_lex_order — numpy's and the
    compiled one (short runs by insertion, runs over 32 rows by stable passes) — is
    np.lexsort's permutation over the 2 + i + j sorted id columns."""
    from predicates.compiled.hitorder import distinct_lex_order as compiled_order
    from predicates.registration.levels.complex import (
        distinct_lex_order, packed_keys, sorted_rows)

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    m = data.draw(st.integers(0, 400))
    a = rng.integers(0, n, size=(m, widths[0]))
    if long_runs and m:  # one first row shared by many: a face met by many others
        a[: m // 2] = a[0]
    b = rng.integers(0, n, size=(m, widths[1]))
    rows = np.concatenate([np.sort(a, axis=1), np.sort(b, axis=1)], axis=1)
    keep = np.sort(np.unique(rows, axis=0, return_index=True)[1]) if m else np.zeros(0, int)
    a, b = a[keep], b[keep]  # distinct rows (as sorted ids), in their drawn order
    sa, sb = sorted_rows(a), sorted_rows(b)
    assert np.array_equal(sa, np.sort(a, axis=1)) and np.array_equal(sb, np.sort(b, axis=1))
    want = np.lexsort(np.concatenate([sa, sb], axis=1).T[::-1])
    keys = packed_keys(sa, n) + packed_keys(sb, n)
    assert np.array_equal(distinct_lex_order(keys), want)
    if len(a):
        assert np.array_equal(compiled_order(keys), want)


@settings(deadline=None)
@given(data=st.data(), width=st.integers(1, 6), n=st.integers(1, 50))
def test_compiled_any_flagged_is_any_of_the_row(data, width, n):
    """The suppression pre-filter's flags (loop._any_face, compiled): per row of ids,
    True exactly when one of its ids is flagged — checked id by id in Python, and
    against the numpy twin (complex.any_flagged)."""
    from predicates.compiled.rows import any_flagged as compiled_any_flagged
    from predicates.registration.levels.complex import any_flagged

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    flags = rng.random(n) < data.draw(st.sampled_from([0.0, 0.05, 0.5, 1.0]))
    rows = rng.integers(0, n, size=(data.draw(st.integers(0, 300)), width))
    got = compiled_any_flagged(flags, rows)
    assert got.dtype == bool and got.shape == (len(rows),)
    assert got.tolist() == [any(bool(flags[v]) for v in row) for row in rows.tolist()]
    assert np.array_equal(got, any_flagged(flags, rows))



def _pair_list(parts) -> list:
    return [(int(a), int(b)) for ia, ib in parts for a, b in zip(ia, ib)]


@_SLOW
@given(data=st.data(), d=st.sampled_from([2, 3]))
def test_grid_join_pairs_are_box_pairs(data, d):
    """box_pairs compiled (its dense-grid join, predicates.compiled.gridjoin.grid_join)
    reports exactly the pairs of the exact test (brute force), each once, as the numpy
    path does — on adversarial boxes: signed zeros, repeated and degenerate boxes, boxes
    many cells wide, pads 0 and positive (NaN: the grid refuses it on both paths)."""
    from predicates.registration.spatial.broadphase import box_pairs

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    na, nb = data.draw(st.integers(1, 300)), data.draw(st.integers(1, 120))
    lo = [rng.choice(_VALUES[:5], size=(n, d)) + rng.random((n, d)) * rng.choice(
        [0.0, 1.0], size=(n, 1)) for n in (na, nb)]
    hi = [x + rng.choice([0.0, 2.0 ** -40, 0.01, 0.3, 1.5], size=(len(x), 1)) for x in lo]
    pad = data.draw(st.sampled_from([0.0, 2.0 ** -30, 0.05]))
    want = set(zip(*(x.tolist() for x in box_pairs_bruteforce(lo[0], hi[0], lo[1], hi[1],
                                                              pad))))
    numpy_pairs = _pair_list(box_pairs(lo[0], hi[0], lo[1], hi[1], pad))
    got = _pair_list(box_pairs(lo[0], hi[0], lo[1], hi[1], pad, accelerate=True))
    assert len(got) == len(set(got)), "a pair was reported twice"
    assert set(got) == set(numpy_pairs) == want


def test_grid_join_defers_a_crowded_grid():
    """Past its proposal budget (tiny boxes crowded in a cell of a grid sized by large
    ones) the compiled join returns None and box_pairs refines as on the numpy path:
    the same pairs as brute force."""
    from predicates.compiled.gridjoin import grid_join
    from predicates.registration.spatial.boxgrid import grid
    from predicates.registration.spatial.broadphase import box_pairs

    rng = np.random.default_rng(3)
    la = np.concatenate([rng.uniform(0, 0.01, (1500, 3)), rng.uniform(1, 50, (50, 3))])
    ha = la + np.concatenate([np.full((1500, 1), 1e-4), np.full((50, 1), 20.0)])
    lb, hb = la[::-1] + 1e-5, ha[::-1] + 1e-5
    *_, G, _, ia0, ia1, ib0, ib1 = grid(la, ha, lb, hb, 0.0)
    cols = tuple(np.ascontiguousarray(x.T) for x in (la, ha, lb, hb))
    assert grid_join((ia0, ia1, ib0, ib1), G, 0.0, cols, 1000) is None
    want = set(zip(*(x.tolist() for x in box_pairs_bruteforce(la, ha, lb, hb, 0.0))))
    got = _pair_list(box_pairs(la, ha, lb, hb, 0.0, accelerate=True))
    assert len(got) == len(set(got)) and set(got) == want


@settings(deadline=None)
@given(data=st.data(), w=st.integers(1, 4), n=st.sampled_from([1, 2, 7, 1000]))
def test_compiled_unique_rows_are_numpys(data, w, n):
    """The complexes' unique rows by the compiled counting sort (predicates.compiled.rows)
    equal np.unique's rows and inverse map (many repeats, ids 0 and n − 1, one row);
    and a complex built with it is the same, array for array."""
    from predicates.registration.levels.complex import Complex, unique_rows

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    m = data.draw(st.integers(1, 400))
    rows = rng.integers(0, n, size=(m, w)).astype(data.draw(st.sampled_from(
        [np.int32, np.int64])))
    rows[rng.random(m) < 0.3] = n - 1
    want, inv = np.unique(rows, axis=0, return_inverse=True)
    got, got_inv = unique_rows(rows, n, accelerate=True)
    assert got.dtype == rows.dtype and np.array_equal(got, want)
    assert np.array_equal(got_inv, inv.ravel())
    cells = np.sort(rng.integers(0, max(n, 5), size=(m, 4)), axis=1)
    a, b = Complex(cells, max(n, 5)), Complex(cells, max(n, 5), accelerate=True)
    assert a.S.keys() == b.S.keys() and a.F.keys() == b.F.keys()
    assert all(np.array_equal(a.S[k], b.S[k]) for k in a.S)
    assert all(np.array_equal(a.F[k], b.F[k]) for k in a.F)


def _outcome(f):
    """f()'s result, or its error's type and message."""
    try:
        return "ok", f()
    except (ValueError, TypeError) as e:
        return type(e).__name__, str(e)


@_SLOW
@given(data=st.data(), d=st.sampled_from([2, 3]))
def test_compiled_cell_check_is_numpys(data, d):
    """validate_mesh with the compiled cell check (first bad cell of each kind and the
    used vertices in one pass) refuses the same cell with the same message, or returns
    the same points (unused ones zeroed) and cells, as the numpy check — negative,
    out-of-range and repeated ids anywhere, several in one cell, int32 and int64,
    tiny blocks on a thread pool."""
    from predicates.registration.plan.inputs import validate_mesh

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n, m = data.draw(st.integers(1, 40)), data.draw(st.integers(1, 200))
    cells = np.array([rng.permutation(max(n, d + 1))[:d + 1] for _ in range(m)]) % \
        max(n + data.draw(st.integers(0, 2)), 1)
    for _ in range(data.draw(st.integers(0, 3))):
        cells[rng.integers(0, m), rng.integers(0, d + 1)] = data.draw(st.sampled_from(
            [-1, n, n + 7, 0, int(cells[0, 0])]))
    cells = cells.astype(data.draw(st.sampled_from([np.int32, np.int64])))
    P = rng.random((n, d))
    with ThreadPoolExecutor(2) as pool:
        for numpy_blocks, blocks in _blocks(pool):
            want = _outcome(lambda: validate_mesh(P, cells, "simulation", d, np.float64,
                                                  False, numpy_blocks))
            got = _outcome(lambda: validate_mesh(P, cells, "simulation", d, np.float64,
                                                 False, blocks))
            assert want[0] == got[0]
            if want[0] != "ok":
                assert want[1] == got[1]
            else:
                assert np.array_equal(want[1].points, got[1].points)
                assert want[1].cells is got[1].cells is cells


@_SLOW
@given(data=st.data())
def test_tetrahedra_summary_is_the_general_loop(data):
    """summary_tetrahedra (finite points, the plan's tetrahedra) writes exactly what
    the general summary_block writes — hull bit for bit (signed zeros), exponent
    histogram, least and largest extent — on adversarial finite points (float64 and
    float32, repeated vertices, zeros of both signs, binades far apart); the hull and
    the largest extent are the exact ones (Fractions). A non-finite point makes
    CellBoxes take the general loop."""
    from predicates.compiled.cellsums import summary_block
    from predicates.compiled.tetsums import all_finite, summary_tetrahedra

    P, cells, rng = _mesh(data, 3)
    P = np.ascontiguousarray(P)
    assert all_finite(P)
    outs = []
    for kernel in (summary_block, summary_tetrahedra):
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        hist = np.zeros(2048, np.int64)
        got = kernel(P, cells, lo, hi, hist)
        outs.append((lo.tobytes(), hi.tobytes(), hist.tobytes(), np.array(got).tobytes()))
    assert outs[0] == outs[1]
    X = [[Fraction(float(v)) for v in P[row, ax]] for row in cells for ax in range(3)]
    ext = [max(x) - min(x) for x in X]
    assert np.frombuffer(outs[1][0])[0] == min(min(X[3 * r]) for r in range(len(cells)))
    assert np.frombuffer(outs[1][3])[1] == float(max(ext))  # exact: one rounding
    bad = P.copy()
    bad[rng.integers(0, len(P)), rng.integers(0, 3)] = data.draw(
        st.sampled_from([np.nan, np.inf, -np.inf]))
    assert not all_finite(bad)
    box = CellBoxes(bad, cells, Blocks(accelerate=True))
    assert box._summary_kernel() is summary_block


@settings(deadline=None)
@given(data=st.data())
def test_compiled_widening_is_numpys_nextafter(data):
    """boxgrid.enlarge and refine._reach compiled (cellsums.widened: nextafter from the
    bits) give numpy's values bit for bit — zeros of both signs, subnormals, the largest
    finite values, infinities, NaN, one pad or one per row, with and without the
    2^-1000 of _reach — and the widened box holds every point within the pad (exact
    comparison in Fractions)."""
    from predicates.registration.plan.refine import _reach
    from predicates.registration.spatial.boxgrid import enlarge

    odd = [0.0, -0.0, 5e-324, -5e-324, 2.0 ** -1022, -(2.0 ** -1074) * 3, 1.0,
           -1.0 - 2.0 ** -52, 1.7976931348623157e308, -1.7976931348623157e308, np.inf,
           -np.inf, np.nan]
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n, d = data.draw(st.integers(1, 40)), data.draw(st.sampled_from([2, 3]))
    lo = np.where(rng.random((n, d)) < 0.5, rng.choice(odd, size=(n, d)),
                  rng.standard_normal((n, d)))
    pad = data.draw(st.sampled_from([0.0, 5e-324, 2.0 ** -30, 0.25, 1e308]))
    with np.errstate(all="ignore"):
        hi = lo + rng.choice([0.0, 5e-324, 0.5, 1e300], size=(n, d))
        want, got = enlarge(lo, hi, pad), enlarge(lo, hi, pad, accelerate=True)
        assert all(a.tobytes() == b.tobytes() for a, b in zip(want, got))
        fin = np.isfinite(lo) & np.isfinite(hi) & np.isfinite(got[0]) & np.isfinite(got[1])
        for x, y, a, b in zip(lo[fin], hi[fin], got[0][fin], got[1][fin]):
            assert Fraction(float(a)) <= Fraction(float(x)) - Fraction(pad)
            assert Fraction(float(b)) >= Fraction(float(y)) + Fraction(pad)
        ok = np.isfinite(lo).all(1) & np.isfinite(hi).all(1) & (hi >= lo).all(1)
        boxes = (lo[ok], hi[ok])
        (wl, wh), we = _reach(None, None, boxes)
        (gl, gh), ge = _reach(None, None, boxes, accelerate=True)
        assert wl.tobytes() == gl.tobytes() and wh.tobytes() == gh.tobytes()
        assert we.tobytes() == ge.tobytes()


@settings(deadline=None)
@given(data=st.data())
def test_compiled_exact_sums_are_exact(data):
    """ExactSum with its compiled narrow path (predicates.compiled.cellsums.narrow_sums)
    gives the exact sum (Fraction) and numpy's mean, on blocks that take the narrow path
    (one to ten binades), blocks that must not (subnormals, 2^-1000, wide spreads,
    huge values, inf and NaN), zeros of both signs, blocks longer than 2^16 values."""
    from predicates.registration.spatial.exactsum import ExactSum

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n = data.draw(st.sampled_from([1, 5, 300, (1 << 16) + 3]))
    base = data.draw(st.sampled_from([1.0, 2.0 ** -40, 2.0 ** 40]))
    x = rng.random(n) * base * 2.0 ** rng.integers(0, data.draw(st.integers(1, 12)), n)
    odd = data.draw(st.lists(st.sampled_from(
        [-0.0, 0.0, 5e-324, 2.0 ** -1000, 2.0 ** -1022, 2.0 ** 996, np.inf, np.nan,
         1.0 + 2.0 ** -52]), max_size=4))
    for v in odd:
        x[rng.integers(0, n)] = v
    ref, fast = ExactSum().add(x), ExactSum(accelerate=True).add(x)
    assert (ref.n, fast.n) == (n, n)
    if np.isfinite(x).all():
        want = sum(Fraction(float(v)) for v in x)
        assert Fraction(fast.total(), 1 << 1074) == want == Fraction(ref.total(), 1 << 1074)
    assert np.float64(ref.mean()).tobytes() == np.float64(fast.mean()).tobytes()


@pytest.mark.parametrize("d", [2, 3])
def test_compiled_refinement_is_numpys(d):
    """The refinement's edges by the compiled unique rows: the same refined mesh, bit for
    bit, on a cutting cell far coarser than the grid (several rounds of splits)."""
    from predicates.registration.examples import cube_grid, square_grid
    from predicates.registration.plan.refine import refine
    from predicates.registration.spatial.boxes import boxes_of

    sp, sc = (square_grid(24) if d == 2 else cube_grid(8))
    lo, hi = boxes_of(sp, sc)
    k = d  # the cutting mesh: one coarse segment (2D) or triangle (3D) across the grid
    cp = np.array([[0.1, 0.3], [0.9, 0.55]] if d == 2
                  else [[0.1, 0.2, 0.3], [0.9, 0.25, 0.6], [0.4, 0.95, 0.45]])
    cc = np.arange(k)[None, :]
    got = [refine(cp, cc, lo, hi, accelerate=a) for a in (False, True)]
    assert got[0].rounds > 0 and len(got[0].cells) > 1
    for name in ("points", "cells", "cut_origin", "bary"):
        a, b = getattr(got[0], name), getattr(got[1], name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name


def test_the_plan_passes_its_accelerate_to_refinement_and_estimate(monkeypatch):
    """intersect(accelerate=True) runs the refinement's unique rows and the pair
    estimate's occupancy counts compiled (and =False on numpy), with the same result."""
    import predicates
    from predicates.registration import pipeline
    from predicates.registration.examples import cube_grid

    seen = []
    refine, estimate = pipeline.refine, pipeline.estimate_cell_pairs
    monkeypatch.setattr(pipeline, "refine", lambda *a, **k: (
        seen.append(("refine", k["accelerate"])), refine(*a, **k))[1])
    monkeypatch.setattr(pipeline, "estimate_cell_pairs", lambda *a: (
        seen.append(("estimate", a[-1].accelerate)), estimate(*a))[1])
    sp, sc = cube_grid(6)
    cp = np.array([[-0.2, -0.1, 0.31], [1.3, 0.0, 0.52], [0.3, 1.4, 0.44]])
    res = [predicates.intersect((sp, sc), (cp, np.array([[0, 1, 2]])), accelerate=a)
           for a in (False, True)]
    assert seen == [("refine", False), ("estimate", False), ("refine", True),
                    ("estimate", True)]
    assert res[0].kinds == res[1].kinds and sum(len(res[0][k]) for k in res[0].kinds) > 0
    for kind in res[0].kinds:
        for name in ("sim", "cut", "sim_weights", "cut_weights"):
            a, b = getattr(res[0][kind], name), getattr(res[1][kind], name)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), (kind, name)


@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_compiled_corner_sums_are_numpys(d):
    """The summed-area tables' corners compiled (d = 2, 3 written out, other d by the
    generic loop): coverage equals a brute-force count of the boxes covering each cell,
    and the look-ups equal numpy's, in int64 and int32."""
    import itertools

    from predicates.registration.spatial import gridsums

    rng = np.random.default_rng(d)
    G = rng.integers(1, 6, size=d).astype(np.int64)
    i0 = rng.integers(0, G, size=(300, d))
    i1 = np.minimum(i0 + rng.integers(0, 3, size=(300, d)), G - 1)
    fast = Blocks(accelerate=True)
    for dtype in (np.int64, np.int32):
        cov = gridsums.coverage(i0, i1, G, fast, dtype)
        for cell in itertools.product(*(range(g) for g in G)):
            inside = np.all((i0 <= cell) & (np.asarray(cell) <= i1), axis=1)
            assert cov[tuple(cell[::-1])] == inside.sum()
        occ = gridsums.occupancy(i0[:40], i1[:40], G)
        assert np.array_equal(gridsums.any_in(occ, i0, i1, G),
                              gridsums.any_in(occ, i0, i1, G, fast))


@_SLOW
@given(data=st.data(), d=st.sampled_from([2, 3]),
       h=st.sampled_from([0.25, 0.1, 1 / 3, 1.0 + 2.0 ** -52, 2.0 ** -30]))
def test_indexed_flag_block_is_the_per_row_block(data, d, h):
    """flag_block_indexed (the rows' cell ranges from the points' grid cells) gives
    flag_block's counts, flags, ranges and largest edge, on points drawn on and next to
    grid lines (the floor's boundary cases), grids clipped on both sides; the flagged
    rows' boxes it keeps are fill_boxes' boxes of those rows."""
    from predicates.compiled.cells import fill_boxes, point_index
    from predicates.compiled.flagpass import flag_block, flag_block_indexed, pair_bits
    from predicates.registration.spatial.gridsums import _stride

    P, cells, rng = _mesh(data, d)
    if data.draw(st.booleans()):  # coordinates on grid lines and one ulp either side
        k = rng.integers(-3, 12, size=P.shape).astype(np.float64) * h
        P = np.nextafter(k, k + rng.choice([-1.0, 0.0, 1.0], size=P.shape)).astype(P.dtype)
    origin = np.full(d, float(np.min(P)) + data.draw(st.sampled_from([0.0, 0.5])))
    G = rng.integers(1, 9, size=d).astype(np.int64)  # small: indices clipped at G − 1
    stride = _stride(G)
    occ = np.zeros(tuple((G + 1)[::-1]), np.int32)  # a summed-area table of occupancy
    occ[tuple(slice(None, -1) for _ in range(d))] = rng.random(tuple(G[::-1])) < \
        data.draw(st.sampled_from([0.0, 0.05, 0.5]))
    S = np.zeros_like(occ)
    S[tuple(slice(1, None) for _ in range(d))] = occ[tuple(slice(None, -1) for _ in range(d))]
    for ax in range(d):
        np.cumsum(S, axis=ax, out=S)
    S = S.ravel()
    m = len(cells)
    out = [[np.zeros((m, d), np.int32), np.zeros((m, d), np.int32), np.zeros(m, bool)]
           for _ in range(2)]
    ref = flag_block(P, cells, origin, h, G, stride, S, True, *out[0])
    index = np.empty(P.shape, np.int32)
    point_index(P, origin, h, G, index)
    flo, fhi = np.empty((m, d)), np.empty((m, d))
    bits = np.zeros(0, np.uint8)
    if data.draw(st.booleans()):  # the 2^d blocks' bits decide the small ranges
        bits = np.zeros(len(S) // 8 + 1, np.uint8)
        pair_bits(S, G, stride, bits)
    fcells = np.empty_like(cells)
    got = flag_block_indexed(P, index, cells, stride, S, True, *out[1], flo, fhi, bits,
                             fcells)
    assert ref[0] == got[0] and ref[2] == got[2]
    assert np.float64(ref[1]).tobytes() == np.float64(got[1]).tobytes()
    nf = ref[2]
    assert np.array_equal(out[0][2], out[1][2])
    assert np.array_equal(out[0][0][:nf], out[1][0][:nf])
    assert np.array_equal(out[0][1][:nf], out[1][1][:nf])
    lo, hi = np.empty((d, m)), np.empty((d, m))
    fill_boxes(P, cells, lo, hi)
    rows = np.flatnonzero(out[0][2])
    assert flo[:nf].tobytes() == np.ascontiguousarray(lo.T[rows]).tobytes()
    assert fhi[:nf].tobytes() == np.ascontiguousarray(hi.T[rows]).tobytes()
    assert np.array_equal(fcells[:nf], cells[rows])  # the run's cells, in order
    # the points' grid cells are numpy's cell_index of the binary64 coordinates
    from predicates.registration.spatial.boxgrid import cell_index

    assert np.array_equal(index, cell_index(P.astype(np.float64), origin, h, G))
    if d == 3:  # tetrahedra from packed indices (flagpack.py): the same values, writes
        from predicates.compiled.flagpack import flag_tetrahedra_packed, pack_index

        packed = np.empty(len(P), np.int64)
        pack_index(P, origin, h, G, packed)
        assert np.array_equal(packed, (index.astype(np.int64) << [0, 21, 42]).sum(1))
        again = [np.zeros((m, d), np.int32), np.zeros((m, d), np.int32), np.zeros(m, bool),
                 np.empty((m, d)), np.empty((m, d))]
        fc = np.empty_like(cells)
        pk = flag_tetrahedra_packed(P, packed, cells, stride, S, True, *again, bits, fc)
        assert (pk[0], pk[2]) == (got[0], got[2])
        assert np.float64(pk[1]).tobytes() == np.float64(got[1]).tobytes()
        assert np.array_equal(again[2], out[1][2]) and np.array_equal(fc[:nf], fcells[:nf])
        for x, y in zip(again[:2] + again[3:], out[1][:2] + [flo, fhi]):
            assert x[:nf].tobytes() == y[:nf].tobytes()


def test_the_run_cells_are_gathered_once():
    """CellBoxes.cells_of returns the kept cells for the same selection (the report
    and the plan ask with one mask) and the right cells for another one."""
    P, C = np.random.default_rng(0).random((40, 3)), np.arange(120).reshape(30, 4) % 40
    box = CellBoxes(P, C, Blocks(accelerate=True))
    sel = np.arange(30) % 3 == 0
    first = box.cells_of(sel)
    assert box.cells_of(sel) is first and np.array_equal(first, C[sel])
    other = ~sel
    assert np.array_equal(box.cells_of(other), C[other])
    # the first round's flagged cells are kept by the flag pass: their cells (and a
    # subset's) come from there, the same rows in the same order; others are gathered
    from predicates.registration.examples import cube_grid
    from predicates.registration.spatial.boxes import boxes_of

    P, C = cube_grid(6)
    box = CellBoxes(P, C, Blocks(accelerate=True, block=97))
    lo_b = np.array([[0.3, 0.3, 0.3]])
    near = near_fixed(box, lo_b, lo_b + 0.2, 0.01)[0]
    assert box._kept_cells is not None and 0 < near.sum() < len(C)
    assert np.array_equal(box._kept_cells[1], C[near])
    half = near & (np.arange(len(C)) % 2 == 0)
    for sel in (near.copy(), half, np.flatnonzero(half), ~near):
        assert np.array_equal(box.cells_of(sel), C[sel])
    # the flags' own mask is recognised (no look-up): the kept rows, the same values as
    # for an equal mask looked up
    lo, hi = boxes_of(P, C[near])
    for sel in (near, near.copy()):
        got = box.rows(sel)
        assert got[0].tobytes() == lo.tobytes() and got[1].tobytes() == hi.tobytes()
    assert box.rows(near)[0] is box._kept[1]
    assert box.cells_of(near) is box._kept_cells[1]


@settings(deadline=None)
@given(data=st.data(), widths=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       n=st.sampled_from([41, 1000, 2 ** 20 + 1, 2 ** 40]))
def test_hits_in_order_is_the_numpy_output(data, widths, n):
    """loop._output compiled (hitorder.hits_in_order: keys packed from each simplex's input
    ids, order, id rows gathered in order) is the numpy path's: ids through the rank
    map, sorted_rows, packed_keys, distinct_lex_order, take."""
    from predicates.compiled.hitorder import hits_in_order
    from predicates.registration.levels.complex import (
        distinct_lex_order, packed_keys, sorted_rows)

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    sides = []
    for w in widths:  # simplices: distinct rows of ranks; ranks -> input ids < n
        ranks = 40
        S = np.unique(np.sort(rng.integers(0, ranks, (60, w)), axis=1), axis=0)
        ids = rng.choice(min(n, 10 ** 6), ranks, replace=False) + (n - min(n, 10 ** 6))
        sides.append((S, ids.astype(np.int64)))
    m = data.draw(st.integers(1, 300))
    pairs = np.unique(np.stack([rng.integers(0, len(sides[0][0]), m),
                                rng.integers(0, len(sides[1][0]), m)], axis=1), axis=0)
    pairs = pairs[rng.permutation(len(pairs))]  # distinct pairs, in no order
    s, c = pairs[:, 0], pairs[:, 1]
    (S1, ids1), (S2, ids2) = sides
    sid, cid = ids1[S1[s]], ids2[S2[c]]
    want = distinct_lex_order(packed_keys(sorted_rows(sid), n)
                              + packed_keys(sorted_rows(cid), n))
    order, got1, got2 = hits_in_order((S1, ids1, s, n), (S2, ids2, c, n))
    assert np.array_equal(order, want)
    assert np.array_equal(got1, sid[want]) and np.array_equal(got2, cid[want])


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_compiled_scaling_is_numpys(dtype):
    """scale_points with the compiled pass (cellsums.scale_exact: the scaling and both
    checks at once) returns the numpy pass's points bit for bit and refuses what it
    refuses with the same message — an overflow, a bit lost to underflow, the overflow
    first when both occur — and every accepted value is exactly x·2^-e (Fractions)."""
    from predicates.registration.plan.inputs import scale_points

    rng = np.random.default_rng(11)
    fi = np.finfo(dtype)
    big, tiny = fi.max / 4, fi.smallest_subnormal
    base = rng.uniform(-1, 1, (3000, 3)).astype(dtype) * dtype(2.0) ** rng.integers(
        -20, 20, (3000, 1)).astype(dtype)
    base[0], base[1, 0] = 0.0, -0.0

    def outcome(points, e, fast):
        try:
            return "ok", scale_points(points, e, "simulation", accelerate=fast).tobytes()
        except ValueError as err:
            return "refused", str(err)

    cases = [(e, {}) for e in (-8, 0, 7, fi.maxexp + 3)] + [
        (-8, {5: big}), (1, {6: tiny}), (-8, {7: tiny, 2999: big}), (2, {3: big})]
    seen = set()
    for e, bad in cases:
        pts = base.copy()
        for row, value in bad.items():
            pts[row, 1] = value
        want, got = outcome(pts, e, False), outcome(pts, e, True)
        assert want == got
        seen.add(want[0] if want[0] == "ok" else
                 "overflow" if "too large" in want[1] else
                 "underflow" if "cannot be scaled exactly" in want[1] else want[1])
        if want[0] == "ok":
            out = np.frombuffer(got[1], dtype=dtype).reshape(pts.shape)
            for i in (0, 1, 3, 7, 2999):
                assert all(Fraction(float(y)) == Fraction(float(x)) * Fraction(2) ** -e
                           for x, y in zip(pts[i], out[i]))
    assert seen == {"ok", "overflow", "underflow"}  # both refusals are exercised


@_SLOW
@given(data=st.data(), d=st.sampled_from([2, 3]))
def test_compiled_estimate_grid_is_numpys(data, d):
    """The pair estimate's grid by the compiled passes (resolution._compiled_grid:
    padded boxes never stored) gives _estimate_grid's indices (equal values: a hull's
    signed zero may differ, as for the broad phase's origin) and budget, on boxes from
    adversarial values with point-like, small and huge widths (the loop coarsens the
    grid), pads from 0 up; and the estimate is the same integer both ways."""
    from predicates.registration.plan import resolution as R

    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    sides = []
    for _ in range(2):
        n = data.draw(st.integers(1, 300))
        lo = rng.choice(_VALUES, size=(n, d)) + rng.random((n, d)) * rng.choice([0, 1], n)[:, None]
        width = rng.choice([0.0, 2.0 ** -30, 0.01, 0.5, 1e3], size=(n, 1),
                           p=[0.3, 0.2, 0.3, 0.15, 0.05])
        sides += [lo, lo + width * rng.random((n, d))]
    pad = data.draw(st.sampled_from([0.0, 2.0 ** -20, 0.1, 30.0]))
    want, got = R._estimate_grid(*sides, pad), R._compiled_grid(*sides, pad)
    assert want[4] == got[4]
    for a, b in zip(want[:4], got[:4]):
        assert a.shape == b.shape and np.array_equal(a, b)
    assert R.estimate_cell_pairs(*sides, pad) == \
        R.estimate_cell_pairs(*sides, pad, Blocks(accelerate=True))
    # the fused dense count (paircount.compiled_count, indices never stored) runs
    # exactly where the dense count does, with its integer
    from predicates.registration.plan.paircount import compiled_count

    dense = R._dense_pair_count(*want)
    assert compiled_count(*sides, pad) == dense
    if dense is not None:
        assert dense == R.estimate_cell_pairs(*sides, pad)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("flip", [0, 1])
def test_pad_corners_runs_are_each_box(seed, flip):
    """estimate.pad_corners adds a run of consecutive 3D boxes with equal ranges once
    (±run at its corners): the difference grid and the total are those of each box
    added alone, on runs of repeated boxes, of boxes that differ below a cell (the same
    range) and of boxes that differ in one range bound only."""
    from predicates.compiled.estimate import pad_corners
    from predicates.registration.spatial.gridsums import _stride

    rng = np.random.default_rng(seed)
    base = rng.random((40, 3)) * 4
    lo = np.repeat(base, rng.integers(1, 6, 40), axis=0)
    lo = lo + rng.choice([0.0, 1e-9, 0.3], size=lo.shape, p=[0.6, 0.3, 0.1])
    hi = lo + rng.random((len(lo), 1)) * 0.7
    G = np.array([9, 9, 9])  # ranges within [0, 7]: every corner inside the grid
    h, origin, g = 0.05, np.full(3, -0.5), 0.75
    diff = np.zeros(int(np.prod(G + 1)), np.int64)
    total = pad_corners(lo, hi, h, origin, g, _stride(G), diff, flip)
    want, each = np.zeros_like(diff), 0.0
    for r in range(len(lo)):
        each += pad_corners(lo[r:r + 1], hi[r:r + 1], h, origin, g, _stride(G), want, flip)
    assert total == each and np.array_equal(diff, want) and np.any(diff)


@pytest.mark.parametrize("d", [2, 3])
def test_pair_bits_are_the_blocks_occupancy(d):
    """flagpass.pair_bits (d = 3 written out, d = 2 the generic loop): the bit of cell c is
    set exactly when a cell of the 2^d block [c, c + 1] (inside the grid) is occupied —
    brute force over every cell of random grids, the grid's last rows included."""
    from predicates.compiled.flagpass import pair_bits
    from predicates.registration.spatial.gridsums import _stride

    rng = np.random.default_rng(d)
    for _ in range(5):
        G = rng.integers(1, 7, size=d).astype(np.int64)
        occ = np.zeros(tuple((G + 1)[::-1]), np.int32)
        occ[tuple(slice(None, -1) for _ in range(d))] = rng.random(tuple(G[::-1])) < 0.15
        S = np.zeros_like(occ)
        S[tuple(slice(1, None) for _ in range(d))] = occ[tuple(slice(None, -1) for _ in range(d))]
        for ax in range(d):
            np.cumsum(S, axis=ax, out=S)
        bits = np.zeros(S.size // 8 + 1, np.uint8)
        pair_bits(S.ravel(), G, _stride(G), bits)
        got = np.unpackbits(bits, bitorder="little")[:S.size]
        want = np.zeros(S.size, np.uint8)
        for c in np.ndindex(*G[::-1]):  # c reversed: axis 0 last, as occ's shape
            block = occ[tuple(slice(i, min(i + 2, g)) for i, g in zip(c, G[::-1]))]
            key = sum(int(i) * int(s) for i, s in zip(c[::-1], _stride(G)))
            want[key] = block.any()
        assert np.array_equal(got, want)


def test_plan_float_kernels_have_no_fma():
    """The plan's kernels whose floating-point values must be numpy's (the exact sums'
    Veltkamp split, the scaling, the estimate grid's floor((x − o)/g), the shortest
    edge, the cells' boxes, grid indices and first-round flags): no fma or fmuladd intrinsic and no fast-math flag in their LLVM IR, no FMA
    instruction in their machine code (docs/design.md, "Compiled candidate chain").
    Each is compiled here again from its Python source with the declared options but
    without the disk cache: numba does not inspect a kernel loaded from its cache (it
    warns and returns no code), which would make the check pass on anything."""
    import re

    from numba import njit

    from predicates.compiled import cellsums as K
    from predicates.compiled import cells, cutgrid, edgesquares, estimate, flagpack, flagpass
    from predicates.compiled import tetsums as T
    from predicates.compiled.build import JIT_OPTIONS
    from predicates.compiled.edgerows import least_square_rows
    from predicates.registration.spatial import exactsum as xs
    from predicates.registration.spatial.gridsums import _stride

    fma_asm = re.compile(r"\bv?f(n)?m(add|sub)\d|\bvfmaddsub|\bvfmsubadd", re.I)
    fma_ir = re.compile(r"@llvm\.(fma|fmuladd)|\bf(add|sub|mul|div|neg|cmp)\s+(fast|"
                        r"contract|reassoc|afn|arcp|nnan|ninf|nsz)\b")
    P, C = np.random.default_rng(0).random((8, 3)), np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    calls = [
        (K.summary_block, (P, C, np.full(3, np.inf), np.full(3, -np.inf),
                           np.zeros(2048, np.int64))),
        (K.narrow_sums, (P[:, 0].copy(), xs._BIG, xs._TINY, xs._SPREAD, xs._SPLIT)),
        (K._scale_rows, (P, np.empty_like(P), 0.5, 2.0, 1e300)),
        (K.pad_extents, (P, P + 1, 0.1, np.empty(8), np.full(3, np.inf),
                         np.full(3, -np.inf))),
        (K.pad_index, (P, P + 1, 0.1, np.zeros(3), 0.25, np.empty((8, 3)),
                       np.empty((8, 3)))),
        (edgesquares.least_square_edge, (P, C.T.copy(), 0, 2)),
        (edgesquares.least_square_tetrahedra, (P, C.T.copy(), 0, 2)),
        (edgesquares.least_square_triangles, (P, C[:, :3].T.copy(), 0, 2)),
        (least_square_rows, (P, C, 0.5)),
        (least_square_rows, (P, C[:, :3].copy(), 0.5)),
        (T.summary_tetrahedra, (P, C, np.full(3, np.inf), np.full(3, -np.inf),
                                np.zeros(2048, np.int64))),
        (T.checked_summary_tetrahedra, (P, C, np.zeros(8, bool), np.full(3, np.inf),
                                        np.full(3, -np.inf), np.zeros(2048, np.int64))),
        (T.swept_tetrahedra, (P, C, np.zeros(8, bool), np.full(3, np.inf),
                              np.full(3, -np.inf), np.zeros(2048, np.int64),
                              (np.zeros(3), 4.0, np.full(3, 3, np.int64),
                               np.array([1, 5, 25], np.int64), np.zeros(125, np.int32),
                               np.zeros(64, np.uint8), 2.0 ** 48,
                               np.full(8, 255, np.uint8), np.zeros(2, bool),
                               np.empty((2, 3), np.int32), np.empty((2, 3), np.int32),
                               np.empty((2, 3)), np.empty((2, 3)), np.empty_like(C)))),
        (T.all_finite, (P,)),
        (T.quiet_cells, (np.zeros(125, np.int32), np.full(3, 4, np.int64),
                         np.array([1, 5, 25], np.int64), np.zeros(64, np.uint8))),
        (K.widened, (P, P + 1, np.full(8, 0.5), 2.0 ** -1000, np.empty_like(P),
                     np.empty_like(P))),
    ]
    # the boxes (every branch of fill_boxes: one function), grid indices and the first
    # round's flags (cells.py, flagpass.py): their floats decide which cells can meet,
    # as numpy's floor((x − o)/h) and min/max do
    G = np.array([4, 4, 4], np.int64)
    stride, S, o = _stride(G), np.zeros(125, np.int32), np.zeros(3)
    index, m = np.empty((8, 3), np.int32), len(C)
    ranges = (np.zeros((m, 3), np.int32), np.zeros((m, 3), np.int32), np.zeros(m, bool))
    calls += [
        (cells.fill_boxes, (P, C, np.empty((3, m)), np.empty((3, m)))),
        (cells.cell_index, (P, o, 0.25, G, np.empty((8, 3), np.int32))),
        (cells.point_index, (P, o, 0.25, G, index)),
        (flagpass.flag_block, (P, C, o, 0.25, G, stride, S, True, *ranges)),
        (flagpass.flag_block_indexed, (P, index, C, stride, S, True, *ranges,
                                       np.empty((m, 3)), np.empty((m, 3)),
                                       np.zeros(0, np.uint8), np.empty_like(C))),
        (estimate.pad_total, (P, P + 1, 0.1, np.zeros(3), 0.25)),
        # (origin: the padded boxes' least lo − h, the kernel's premise — below it a
        # corner's unsigned key wraps and the write lands outside ``diff``)
        (estimate.pad_corners, (P, P + 1, 0.1, P.min(axis=0) - 0.1, 0.25,
                                np.array([1, 11, 121], np.int64), np.zeros(1331, np.int64),
                                1)),
        (flagpack.pack_index, (P, o, 0.25, G, np.empty(8, np.int64))),
        (flagpack.flag_tetrahedra_packed, (P, np.zeros(8, np.int64), C, stride, S, True,
                                           *ranges, np.empty((m, 3)), np.empty((m, 3)),
                                           np.zeros(0, np.uint8), np.empty_like(C))),
        # the first round's cutting grid: enlarge's roundings, then the cell index's
        (cutgrid.enlarged_ranges, (P, P + 1, 0.1, o, 0.25, G, np.empty((8, 3), np.int32),
                                   np.empty((8, 3), np.int32))),
    ]
    for kernel, args in calls:
        assert kernel.targetoptions.get("fastmath") in (False, None)
        f = njit(**dict(JIT_OPTIONS, cache=False))(kernel.py_func)
        f(*args)
        for sig in f.signatures:
            ir, asm = f.inspect_llvm(sig), f.inspect_asm(sig)
            assert "define " in ir and ".globl" in asm, kernel.__name__  # not a stub
            assert not fma_ir.search(ir) and not fma_asm.search(asm), kernel.__name__


def test_occupied_table_is_the_cumulative_sums():
    """cellsums.occupied_table (one pass, inclusion–exclusion) equals lean._table of the
    occupied cells (a shifted copy and three cumulative sums) on random coverage counts,
    sparse and dense, the grid's unused last rows included; and lean._occupied's table
    is the numpy path's for random boxes."""
    from predicates.compiled.cellsums import occupied_table
    from predicates.registration.plan.lean import _occupied, _table

    rng = np.random.default_rng(5)
    for shape, p in (((2, 2, 2), 0.5), ((5, 7, 3), 0.1), ((9, 4, 6), 0.9), ((3, 8, 8), 0.0),
                     ((1, 1, 1), 1.0), ((1, 3, 2), 0.5), ((4, 1, 5), 0.5), ((6, 5, 1), 0.5),
                     ((40, 33, 52), 0.05)):
        cover = (rng.random(shape) < p) * rng.integers(1, 4, size=shape)
        cover = cover.astype(np.int32)
        S = np.empty(shape, np.int32)
        occupied_table(cover, S)
        assert np.array_equal(S.ravel(), _table(cover > 0))
    G = np.array([6, 4, 5], dtype=np.int64)
    i0 = rng.integers(0, 4, size=(40, 3))
    i1 = np.minimum(i0 + rng.integers(0, 3, size=(40, 3)), G - 1)
    assert np.array_equal(_occupied(i0, i1, G, Blocks(accelerate=True)),
                          _occupied(i0, i1, G, SERIAL))


def test_bucketed_renumbering_is_searchsorted():
    """inputs.renumbered with ``fast`` (compiled.renumber: each id searched within its
    bucket) gives np.searchsorted's positions as int32, for run vertices spread evenly,
    clustered (most buckets empty, one crowded), a single vertex and huge ids; ids
    absent from the vertices (below, between, above them) get numpy's left insertion
    point too."""
    from predicates.registration.plan.inputs import renumbered

    rng = np.random.default_rng(13)
    cases = [np.unique(rng.integers(0, 10 ** 6, size=5000)),
             np.unique(np.concatenate([rng.integers(0, 50, size=400), [10 ** 9, 2 ** 40]])),
             np.array([7]), np.unique(rng.integers(2 ** 60, 2 ** 62, size=300))]
    for vertices in cases:
        vertices = vertices.astype(np.int64)
        present = rng.choice(vertices, size=(200, 4))
        absent = np.concatenate([vertices - 1, vertices + 1, [0, vertices[-1] + 5]])
        for cells in (present, rng.choice(absent, size=(100, 4))):
            got = renumbered(cells, vertices, fast=True)
            assert got.dtype == np.int32
            assert np.array_equal(got, np.searchsorted(vertices, cells))
            assert np.array_equal(got, renumbered(cells, vertices))


def test_prefix_sums_are_the_box_sums():
    """compiled.prefix.prefix_sums: every cell the sum of the grid's cells at or below it
    on every axis (Python integers, from the definition), for 2D and 3D grids of int32
    and int64 with negative entries, a non-contiguous grid (numpy's path) included; and
    gridsums.coverage compiled counts, per cell, the boxes covering it (brute force)."""
    from predicates.compiled.prefix import prefix_sums
    from predicates.registration.spatial.gridsums import coverage

    rng = np.random.default_rng(11)
    for shape in ((1, 1), (4, 7), (1, 5, 1), (3, 4, 5), (6, 2, 9)):
        for dtype in (np.int32, np.int64):
            a = rng.integers(-5, 6, size=shape).astype(dtype)
            want = np.empty(shape, dtype=object)
            for idx in np.ndindex(*shape):
                want[idx] = int(a[tuple(slice(0, i + 1) for i in idx)].astype(object).sum())
            got = prefix_sums(a.copy())
            assert got.dtype == dtype and got.tolist() == want.tolist()
            strided = np.zeros(shape[:-1] + (2 * shape[-1],), dtype)[..., ::2]
            strided[...] = a
            assert prefix_sums(strided).tolist() == want.tolist()
    for d in (2, 3):
        G = rng.integers(1, 6, size=d)
        i0 = rng.integers(0, G, size=(30, d))
        i1 = np.minimum(i0 + rng.integers(0, 3, size=(30, d)), G - 1)
        cover = coverage(i0, i1, G, Blocks(accelerate=True), np.int32)
        assert np.array_equal(cover, coverage(i0, i1, G, SERIAL))
        for cell in np.ndindex(*(G + 1)):  # cover's axes reversed; last rows unused
            c = np.array(cell[::-1])
            if np.all(c < G):
                assert cover[cell] == int(np.all((i0 <= c) & (c <= i1), axis=1).sum())


@_SLOW
@given(st.data(), st.sampled_from([2, 3]))
def test_compiled_edge_summary_is_numpys_and_the_definition(data, d):
    """edges.edge_summary compiled (cellsums.used_renumbered, least_square_edge on (n, d)
    rows) equals its numpy path; the renumbering keeps exactly the used vertices in
    ascending order and maps every cell back to its own ids; the least squared edge is
    the definition's float expression (differences and squares summed from axis 0) on
    the coordinates scaled by 2^-shift; and the shortest edge scaled back is a root of
    it: no neighbouring float's square is closer to it (exact Fractions)."""
    from predicates.compiled.cellsums import used_renumbered
    from predicates.registration.plan.edges import edge_from, edge_summary

    P, cells, rng = _mesh(data, d)
    cells = cells[[len(set(c)) == d + 1 for c in cells.tolist()]]
    if not len(cells):
        return
    P = P * P.dtype.type(2.0 ** int(rng.integers(-60, 60)))
    ids, C = used_renumbered(np.ascontiguousarray(cells, dtype=np.int64), len(P))
    assert np.array_equal(ids, np.unique(cells)) and np.array_equal(ids[C], cells.T)
    fast = edge_summary(P, cells, Blocks(accelerate=True))
    assert fast == edge_summary(P, cells, SERIAL)
    top, shift, least = fast
    assert top == float(np.abs(P[ids]).max())
    X = np.ldexp(P.astype(np.float64), -shift)
    ref = np.inf
    for c in cells.tolist():
        for u in range(d + 1):
            for v in range(u + 1, d + 1):
                sq = 0.0
                for ax in range(d):
                    t = float(X[c[u], ax]) - float(X[c[v], ax])
                    sq = t * t if ax == 0 else sq + t * t
                ref = min(ref, sq)
    assert least == ref
    if least > 0:  # the root (the scaling by 2^shift is exact)
        h = Fraction(edge_from(least, shift)) / Fraction(2) ** shift
        lower, upper = np.nextafter(float(h), 0), np.nextafter(float(h), np.inf)
        off = [abs(Fraction(x) ** 2 - Fraction(least)) for x in (lower, upper)]
        assert abs(h * h - Fraction(least)) <= min(off)


@_SLOW
@given(st.data(), st.sampled_from([3, 4]))
def test_unrolled_least_square_is_the_general_kernel(data, k):
    """edgesquares.least_square_tetrahedra and least_square_triangles (3D, each vertex read
    once) give least_square_edge's value on adversarial coordinates (signed zeros,
    infinities, NaN, ties, repeated vertices) for every span [a, b) of cells, and
    least_square_kernel picks them exactly for 3D cells of 4 and 3 vertices."""
    from predicates.compiled.edgesquares import (
        least_square_edge, least_square_kernel, least_square_tetrahedra,
        least_square_triangles)

    P, cells, rng = _mesh(data, 3)
    P = P.astype(np.float64)
    special = rng.random(P.shape) < 0.05
    P[special] = rng.choice([np.nan, np.inf, -np.inf, -0.0], size=int(special.sum()))
    C = np.ascontiguousarray(cells[:, :k].T.astype(np.int64))
    fast = least_square_tetrahedra if k == 4 else least_square_triangles
    assert least_square_kernel(3, k) is fast
    assert least_square_kernel(2, k - 1) is least_square_edge
    m = C.shape[1]
    for a, b in ((0, m), (0, 0), (m // 2, m), (m - 1, m)):
        want, got = least_square_edge(P, C, a, b), fast(P, C, a, b)
        assert want == got or (np.isnan(want) and np.isnan(got)), (a, b, want, got)


def test_scale_exact_is_the_row_by_row_scaling():
    """The scaling kernel's one-row call (cellsums.scale_exact on C-ordered points)
    gives the row-by-row values and refusals."""
    from predicates.compiled.cellsums import _scale_rows, scale_exact

    rng = np.random.default_rng(11)
    P = rng.choice(_VALUES, size=(300, 3))
    P = P[np.isfinite(P).all(axis=1)]
    for factor, back in ((0.5, 2.0), (2.0 ** -1000, 2.0 ** 1000), (2.0 ** 600, 2.0 ** -600)):
        a, b = np.empty_like(P), np.empty_like(P)
        assert scale_exact(P, a, factor, back, 1e300) == _scale_rows(P, b, factor, back, 1e300)
        assert np.array_equal(a, b, equal_nan=True)
