"""The lean plan (predicates.registration.plan.cellboxes, .lean, .first_round;
docs/partitioned.md, section 2): the simulation boxes computed block by block give the
numbers the stored boxes gave — the first round's flags, L over the cells that can
meet, the refinement's scan — for any blocking, the flags computed in validation's
sweep are those of a pass of their own, they hold every pair within the pad, and the
run's peak memory stays below the boxes' bytes."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from predicates.registration.plan import refine_scan
from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.plan.first_round import near_fixed
from predicates.registration.plan.resolution import consistent_scale
from predicates.registration.spatial import blocks as B
from predicates.registration.spatial.boxes import box_extent, boxes_of


def _mesh(seed: int, n: int, dim: int = 3, spread: float = 1.0):
    rng = np.random.default_rng(seed)
    P = rng.random((max(n, dim + 1) * 2, dim))
    P *= 2.0 ** (spread * rng.standard_normal((len(P), 1)))
    C = np.array([rng.choice(len(P), dim + 1, replace=False) for _ in range(n)])
    return P, C


def _cut(seed: int, m: int, dim: int = 3, size: float = 0.05):
    rng = np.random.default_rng(seed + 1)
    lo = rng.random((m, dim))
    return lo, lo + size * rng.random((m, dim))


def _within(lo, hi, lo_b, hi_b, pad):
    """(n, m) bool: box i of (lo, hi) within ``pad`` of box j of (lo_b, hi_b) (every
    axis's gap ≤ pad, exact: Fractions)."""
    from fractions import Fraction as F

    out = np.zeros((len(lo), len(lo_b)), dtype=bool)
    for i in range(len(lo)):
        for j in range(len(lo_b)):
            out[i, j] = all(F(float(lo_b[j, a])) - F(float(hi[i, a])) <= F(pad)
                            and F(float(lo[i, a])) - F(float(hi_b[j, a])) <= F(pad)
                            for a in range(lo.shape[1]))
    return out


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 120), st.sampled_from([2, 3]),
       st.sampled_from([0.0, 1e-3, 0.05, 0.3]), st.sampled_from([1, 7, 64, None]),
       st.booleans())
def test_first_round_is_the_arrays_and_holds_every_pair_within_the_pad(
        seed, n, dim, pad, block, fast):
    """near_fixed on the cells' boxes computed block by block (numpy or compiled) is
    near_fixed on the stored boxes, and flags both cells of every pair within the pad
    (exact reference)."""
    P, C = _mesh(seed, n, dim, spread=0.0 if seed % 2 else 2.0)
    lo_b, hi_b = _cut(seed, 1 + seed % 40, dim)
    lo, hi = boxes_of(P, C)
    ref_a, ref_b, ref_ext = near_fixed((lo, hi), lo_b, hi_b, pad)
    boxes = CellBoxes(P, C, B.Blocks(block=block, accelerate=fast))
    got_a, got_b, ext = near_fixed(boxes, lo_b, hi_b, pad)
    assert np.array_equal(got_a, ref_a) and np.array_equal(got_b, ref_b)
    assert ext == ref_ext == (float(box_extent(lo[ref_a], hi[ref_a]).max())
                              if ref_a.any() else 0.0)
    near = _within(lo, hi, lo_b, hi_b, pad)
    assert not (near.any(axis=1) & ~ref_a).any() and not (near.any(axis=0) & ~ref_b).any()


@pytest.mark.parametrize("pad", [0.0, 1e-9, 0.3])
@pytest.mark.parametrize("block", [64, None])
def test_the_sweep_flags_are_the_pass_flags(pad, block):
    """The first round's flags computed in validation's sweep (compiled tetrahedra,
    ``validate_pair`` with a first-round grid: first_round.py) are those of a flag
    pass of their own at the same grid, kept rows included; a pad beyond the
    sweep's margin (0.3) makes a grid of its own, and a pass."""
    from predicates.registration.examples import cube_grid, icosphere
    from predicates.registration.plan import first_round
    from predicates.registration.plan.inputs import validate_pair

    sp, sc = cube_grid(9)
    cp, cc = icosphere(2)
    cp = cp * 0.9 + 0.5
    blocks = B.Blocks(block=block, accelerate=True)
    _, sim, cut = validate_pair(sp, sc, cp, cc, np.float64, blocks,
                                first_round.from_cut(boxes_of, blocks))
    swept = CellBoxes(sim.points, sim.cells, blocks, sim.summary, checked=True)
    assert swept.first_grid is not None
    cut_box = first_round.cut_boxes(swept, cut, boxes_of)
    holds = swept.first_grid.holds(*cut_box, len(sc), pad)
    assert holds == (pad < 0.3)
    got = near_fixed(swept, *cut_box, pad)
    assert swept.first_grid is None  # used (or dropped) once
    plain = CellBoxes(sim.points, sim.cells, blocks)
    ref = near_fixed(plain, *cut_box, pad)
    assert all(np.array_equal(a, b) for a, b in zip(got[:2], ref[:2])) and got[2] == ref[2]
    assert 0 < got[0].sum() < len(sc)
    for sel in (got[0], np.flatnonzero(got[0])[::2]):
        assert np.array_equal(swept.cells_of(sel), sc[sel])
        assert all(np.array_equal(a, b) for a, b in zip(swept.rows(sel),
                                                         boxes_of(sp, sc[sel])))


@pytest.mark.parametrize("seed", range(6))
def test_consistent_scale_lean_equals_stored_boxes(seed):
    P, C = _mesh(seed, 400, spread=1.0)
    cut = _cut(seed, 25, size=0.02)
    for block in (5, None):
        ref = consistent_scale(3, boxes_of(P, C), cut, np.float64)
        got = consistent_scale(3, CellBoxes(P, C, B.Blocks(block=block)), cut, np.float64)
        assert (got.L_a, got.L_b, got.e, got.pad, got.history) == \
            (ref.L_a, ref.L_b, ref.e, ref.pad, ref.history)
        assert all(np.array_equal(a, b) for a, b in zip(got.masks, ref.masks))


def test_cellboxes_behave_as_the_arrays():
    P, C = _mesh(11, 1000)
    lo, hi = boxes_of(P, C)
    cb = CellBoxes(P, C, B.Blocks(block=64))
    rng = np.random.default_rng(0)
    ids = rng.choice(1000, 50)  # unsorted, with repeats
    mask = rng.random(1000) < 0.3
    for side, ref in ((cb.lo, lo), (cb.hi, hi)):
        assert side.shape == ref.shape and len(side) == len(ref)
        assert np.array_equal(side[10:400], ref[10:400])
        assert np.array_equal(side[ids], ref[ids]) and np.array_equal(side[mask], ref[mask])
        assert np.array_equal(side[np.sort(ids)], ref[np.sort(ids)])
        assert np.array_equal(side[:, 2], ref[:, 2]) and np.array_equal(side[5:9, 1], ref[5:9, 1])
        assert np.array_equal(np.asarray(side), ref)
    lo_c, hi_c = cb
    # lo/hi are made when asked (no reference cycle back to the boxes): views of cb
    assert (lo_c.owner, lo_c.side, cb[1].owner, cb[1].side) == (cb, 0, cb, 1)
    S = cb.summary()
    assert S.ext_max == box_extent(lo, hi).max() and S.ext_min == box_extent(lo, hi).min()
    assert np.array_equal(S.lo_min, lo.min(0)) and np.array_equal(S.hi_max, hi.max(0))


@pytest.mark.parametrize("longest", [0.0, 0.05, np.inf])
def test_refine_scan_from_the_summary_is_the_scan(longest):
    P, C = _mesh(5, 3000, spread=0.5)
    lo, hi = boxes_of(P, C)
    reach = _cut(5, 20, size=0.1)
    ref = refine_scan.scan_cells(lo, hi, reach, longest)
    cb = CellBoxes(P, C, B.Blocks(block=97))
    got = refine_scan.scan_cells(cb.lo, cb.hi, reach, longest, cb.summary().scan_stats())
    assert (got.n, got.ext_min, got.ext_max, got.fine, got.mag) == \
        (ref.n, ref.ext_min, ref.ext_max, ref.fine, ref.mag)
    assert np.array_equal(got.near, ref.near)


@pytest.mark.parametrize("size", [0.02, 0.1, 0.16, 0.3, 1.0])
@pytest.mark.parametrize("accelerate", [False, True])
def test_refine_with_the_summarys_stats_is_refine_without(size, accelerate):
    """refine(sim_stats=the summary's) skips the reach boxes and the scan exactly when
    no cutting box edge exceeds the least simulation box edge (refine_scan.none_longer),
    and gives the refinement made without the statistics, bit for bit, either way."""
    from predicates import compiled
    from predicates.registration.examples import cube_grid
    from predicates.registration.plan.refine import refine

    if accelerate and not compiled.available():
        pytest.skip("numba not installed")
    sp, sc = cube_grid(6)  # box edges 1/6
    rng = np.random.default_rng(int(size * 100))
    corner = rng.random((40, 1, 3)) * 0.8
    cp = (corner + size * rng.random((40, 3, 3))).reshape(-1, 3)
    cc = np.arange(len(cp)).reshape(-1, 3)
    cb = CellBoxes(sp, sc, B.Blocks(accelerate=accelerate))
    stats, cut_box = cb.summary().scan_stats(), boxes_of(cp, cc)
    lo, hi = boxes_of(sp, sc)
    assert refine_scan.none_longer(cut_box, stats) == \
        (box_extent(*cut_box).max() <= box_extent(lo, hi).min())
    want = refine(cp, cc, lo, hi, accelerate=accelerate)
    got = refine(cp, cc, cb.lo, cb.hi, sim_stats=stats, accelerate=accelerate, boxes=cut_box)
    assert (got.rounds > 0) == (size > 0.16) and got.rounds == want.rounds
    for name in ("points", "cells", "cut_origin", "bary"):
        a, b = np.asarray(getattr(want, name)), np.asarray(getattr(got, name))
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name


def test_out_of_memory_in_the_plan_is_a_clear_refusal(monkeypatch):
    import predicates
    from predicates.registration import pipeline
    from predicates.registration.examples import example

    def boom(*a, **k):
        raise MemoryError()

    monkeypatch.setattr(pipeline, "consistent_scale", boom)
    ex = example("sphere", 4, subdivisions=1)
    with pytest.raises(pipeline.PlanMemoryError, match=r"plan \(scale\) of meshes of"
                                                       r".*\(MemoryError: no detail\)$"):
        predicates.intersect(*ex["sim"], *ex["cut"])
    with pytest.raises(MemoryError):  # still a MemoryError for callers that catch it
        predicates.intersect(*ex["sim"], *ex["cut"])


@pytest.mark.parametrize("seed", range(8))
def test_kept_rows_by_mask_give_the_gathered_boxes_and_cells(seed):
    """The compiled first round keeps its flagged rows by their mask, their ids found
    only when another selection is asked for (CellBoxes.keep(None, ..., mask=)): the
    boxes and cells of the mask itself, of subsets of it (later rounds), of a selection
    reaching outside it and of ascending ids are the gathered ones; and the whole
    fixed point on these boxes (L, e, pad, history, masks) is the stored boxes' one, on
    a grid of tetrahedra (more cells than points: the indexed pass, which keeps its
    rows) with a few large cells away from the cut, so that L shrinks between rounds."""
    from predicates.registration.examples import cube_grid

    rng = np.random.default_rng(seed)
    P, C = cube_grid(6)
    far = np.flatnonzero((P > 0.5).all(axis=1))
    C = np.concatenate([C, [rng.choice(far, 4, replace=False) for _ in range(1 + seed)]])
    lo, hi = boxes_of(P, C)
    cut_lo = rng.random((5 + 5 * seed, 3)) * 0.6
    cut = (cut_lo, cut_lo + rng.uniform(0.005, 0.1) * rng.random(cut_lo.shape))
    cb = CellBoxes(P, C, B.Blocks(block=64, accelerate=True))
    pad = [0.0, 1e-3, 0.05][seed % 3]
    near_a, near_b, _ = near_fixed(cb, *cut, pad)
    ref_a, ref_b, _ = near_fixed((lo, hi), *cut, pad)
    assert np.array_equal(near_a, ref_a) and np.array_equal(near_b, ref_b)
    assert 0 < near_a.sum() < len(C)
    assert cb._kept_mask is near_a and cb._kept[0] is None  # kept by mask, no ids yet
    sub = near_a & (rng.random(len(C)) < 0.5)
    wider = near_a | (rng.random(len(C)) < 0.1)
    for sel in (near_a, sub, np.flatnonzero(sub), wider, near_a.copy()):
        got_lo, got_hi = cb.rows(sel)
        assert np.array_equal(got_lo, lo[sel]) and np.array_equal(got_hi, hi[sel])
        assert np.array_equal(cb.cells_of(sel), C[sel])
    for block in (7, None):
        ref = consistent_scale(3, (lo, hi), cut, np.float64)
        got = consistent_scale(3, CellBoxes(P, C, B.Blocks(block=block, accelerate=True)),
                               cut, np.float64)
        assert len(ref.history) >= 3  # (L changed after round one)
        assert (got.L_a, got.L_b, got.e, got.pad, got.history) == \
            (ref.L_a, ref.L_b, ref.e, ref.pad, ref.history)
        assert all(np.array_equal(a, b) for a, b in zip(got.masks, ref.masks))


@pytest.mark.parametrize("fast", [False, True])
def test_the_simulation_meshs_error_still_comes_first(fast):
    """validate_pair checks the cutting mesh first when its boxes fix the first round's
    grid (compiled); with both meshes bad, the error is still the simulation mesh's, and
    a bad cutting mesh alone is still refused by name."""
    from predicates.registration.examples import cube_grid, icosphere
    from predicates.registration.plan import first_round
    from predicates.registration.plan.inputs import validate_pair

    sp, sc = cube_grid(3)
    cp, cc = icosphere(1)
    blocks = B.Blocks(accelerate=fast)
    grid = first_round.from_cut(boxes_of, blocks)
    bad_sc, bad_cc = sc.copy(), cc.copy()
    bad_sc[5, 1] = len(sp) + 7
    bad_cc[2, 0] = -1
    with pytest.raises(ValueError, match="simulation cells: vertex index out of range"):
        validate_pair(sp, bad_sc, cp, bad_cc, np.float64, blocks, grid)
    with pytest.raises(ValueError, match="cutting cells: negative vertex index in cell 2"):
        validate_pair(sp, sc, cp, bad_cc, np.float64, blocks, grid)



def _sweep_flags_and_pass(sp, sc, cp, cc, block, dtype=np.float64):
    """The first round's flags from validation's sweep and from a pass of their own at
    the same grid (compiled), the pad 0, in the working ``dtype``."""
    from predicates.registration.plan import first_round
    from predicates.registration.plan.inputs import validate_pair

    blocks = B.Blocks(block=block, accelerate=True)
    _, sim, cut = validate_pair(sp, sc, cp, cc, dtype, blocks,
                                first_round.from_cut(boxes_of, blocks))
    swept = CellBoxes(sim.points, sim.cells, blocks, sim.summary, checked=True)
    assert swept.first_grid is not None  # the sweep flagged
    cut_box = first_round.cut_boxes(swept, cut, boxes_of)
    got = near_fixed(swept, *cut_box, 0.0)
    ref = near_fixed(CellBoxes(sim.points, sim.cells, blocks), *cut_box, 0.0)
    return got, ref


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([64, None]), st.booleans())
def test_the_sweeps_quiet_vertices_give_the_pass_flags(seed, block, single):
    """The sweep's shortcut (first_round.SweptFlags: a tetrahedron whose largest box
    edge is below (R − 1/4)·h and whose first vertex has no occupied cell within R
    cells is not flagged) gives the pass's flags: tetrahedra whose edges are about 0.2,
    0.7, 1.7 and 3.5 grid cells, their first vertex anywhere around a few single occupied
    cells (tiny triangles), and a few far away (1e13); points given in float64 or
    float32 (the working dtype: the sweep reads the points as given)."""
    rng = np.random.default_rng(seed)
    m = 30  # tiny cutting triangles: each box in one or two cells
    cp = np.repeat(rng.random((m, 3)), 3, axis=0) + 1e-4 * rng.random((3 * m, 3))
    cp[:3] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]  # sets the mean extent: h ~ 1/32
    cc = np.arange(3 * m).reshape(m, 3)
    n, h = 3000, 2.0 ** -5
    first = rng.random((n, 3)) * 1.1 - 0.05
    first[:40] = 1e13 + rng.random((40, 3))
    edge = h * rng.choice([0.2, 0.7, 1.7, 3.5], n)[:, None, None] * rng.random((n, 3, 3))
    sp = np.concatenate([first[:, None], first[:, None] + edge], axis=1).reshape(-1, 3)
    sc = np.arange(4 * n).reshape(n, 4)
    dtype = np.float32 if single else np.float64
    got, ref = _sweep_flags_and_pass(sp.astype(dtype), sc, cp, cc, block, dtype)
    assert all(np.array_equal(a, b) for a, b in zip(got[:2], ref[:2])) and got[2] == ref[2]
    assert 0 < got[0].sum() < n
