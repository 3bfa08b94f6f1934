"""The numpy flag pass's shortcut (predicates.registration.plan.quiet; docs/resolution.md,
"The first round"): the grid cells' distances are the brute-force Chebyshev distances
to the covered cells, and the pass with the shortcut gives the plain definition's flags,
flagged ranges and largest edge (boxes, cell_index, the table's look-ups on every row)
and keeps the flagged rows' boxes and cells — near grid lines, with points far away, in
float32 and float64, in blocks, on threads, and for a chunk whose ids span a part of
the points."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from predicates.registration.plan import first_round, lean, quiet
from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxes import box_extent, boxes_of
from predicates.registration.spatial.boxgrid import cell_index
from predicates.registration.spatial.gridsums import covered_in, occupancy


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([2, 3]), st.floats(0.0, 0.3))
def test_cell_distances_are_the_brute_force_ones(seed, d, fill):
    """Per grid cell: the least Chebyshev distance to a covered cell, capped at CAP
    (the grid's cells listed and compared with every covered one)."""
    rng = np.random.default_rng(seed)
    G = rng.integers(1, 9, size=d)
    m = rng.integers(0, 6)
    i0 = np.stack([rng.integers(0, g, size=m) for g in G], axis=1).astype(np.int32)
    i1 = np.minimum(i0 + rng.integers(0, 2, size=(m, d)), G - 1).astype(np.int32)
    table = lean._table(occupancy(i0, i1, G))
    got = quiet.cell_distances(table, G)
    cov = occupancy(i0, i1, G)[tuple(slice(0, -1) for _ in range(d))]  # (G reversed)
    occupied = np.argwhere(cov)[:, ::-1]  # (cell index per axis, axis 0 first)
    for key in range(int(np.prod(G))):
        c = np.array(np.unravel_index(key, tuple(G[::-1]))[::-1])
        far = np.abs(occupied - c).max(axis=1).min() if len(occupied) else quiet.CAP
        assert got[key] == min(int(far), quiet.CAP)



@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(0.0, 0.4))
def test_compiled_cell_levels_are_the_brute_force_ones(seed, fill):
    """The compiled sweep's levels (tetsums.quiet_cells, separable passes): 2 when no
    covered cell is within Chebyshev distance 2, 1 when none is within 1, else 0 —
    from the brute-force distances, on grids of 1 to 8 cells per axis."""
    try:
        from predicates.compiled.tetsums import quiet_cells
    except ImportError:
        pytest.skip("numba not installed")
    from predicates.registration.spatial.gridsums import _stride

    rng = np.random.default_rng(seed)
    G = rng.integers(1, 9, size=3)
    m = int(rng.integers(0, 2 + fill * 20))
    i0 = np.stack([rng.integers(0, g, size=m) for g in G], axis=1).astype(np.int32)
    i1 = np.minimum(i0 + rng.integers(0, 2, size=(m, 3)), G - 1).astype(np.int32)
    levels = np.full(int(np.prod(G)), 7, np.uint8)
    quiet_cells(lean._table(occupancy(i0, i1, G)), G.astype(np.int64), _stride(G), levels)
    cov = occupancy(i0, i1, G)[:-1, :-1, :-1]
    occupied = np.argwhere(cov)[:, ::-1]
    for key in range(int(np.prod(G))):
        c = np.array(np.unravel_index(key, tuple(G[::-1]))[::-1])
        far = np.abs(occupied - c).max(axis=1).min() if len(occupied) else 9
        assert levels[key] == (0 if far <= 1 else 1 if far == 2 else 2)

def _mesh(seed: int, single: bool):
    """Tiny cutting triangles (a grid of cell size 2^-5), tetrahedra of edges 0.2 to 3.5
    cells around them, vertices on and one ulp off grid lines, a few far away."""
    rng = np.random.default_rng(seed)
    m = 30
    cp = np.repeat(rng.random((m, 3)), 3, axis=0) + 1e-4 * rng.random((3 * m, 3))
    cp[:3] = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    cc = np.arange(3 * m).reshape(m, 3)
    n, h = 1500, 2.0 ** -5
    first = rng.random((n, 3)) * 1.1 - 0.05
    on = rng.random(n) < 0.3  # on a grid line of the grid's cell size, or next to it
    first[on] = np.round(first[on] / h) * h + rng.choice([-1, 0, 1], size=(int(on.sum()), 3)) \
        * np.spacing(np.abs(first[on]) + 1.0)
    first[:20] = 1e13 + rng.random((20, 3))
    edge = h * rng.choice([0.2, 0.7, 1.7, 3.5], n)[:, None, None] * rng.random((n, 3, 3))
    sp = np.concatenate([first[:, None], first[:, None] + edge], axis=1).reshape(-1, 3)
    sc = np.arange(4 * n).reshape(n, 4)
    for r in rng.choice(n, n // 10):  # some cells' vertices in another order
        sc[r] = rng.permutation(sc[r])
    return sp.astype(np.float32 if single else np.float64), sc, cp, cc


def _plain(P, C, grid):
    """The pass's definition on every row: (flags, flagged ranges, largest edge)."""
    lo, hi = boxes_of(P, C)
    i0, i1 = (cell_index(x, grid.origin, grid.h, grid.G) for x in (lo, hi))
    near = covered_in(grid.table, i0, i1, grid.G)
    ext = float(box_extent(lo[near], hi[near]).max()) if near.any() else 0.0
    return near, i0[near], i1[near], ext


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.booleans(), st.sampled_from([7, 64, None]),
       st.sampled_from([0.0, 2.0 ** -9, 0.05]), st.booleans(), st.booleans())
def test_the_shortcut_gives_the_plain_pass(seed, single, block, pad, chunk, threads):
    """flag_pass with the shortcut (numpy) equals the plain pass bit for bit, on all
    the cells or on a chunk whose ids span a third of the points (its own points read
    from its least id); the flagged rows' boxes and cells are kept and are the
    gathered ones; many rows are decided by the shortcut."""
    P, C, cp, cc = _mesh(seed, single)
    if chunk:
        C = C[len(C) // 3: 2 * len(C) // 3]
    lo_b, hi_b = boxes_of(cp, cc)
    grid = first_round.fixed_grid(lo_b, hi_b, len(C), pad, Blocks())
    with ThreadPoolExecutor(2) as pool:
        blocks = Blocks(pool, 2, block=block) if threads else Blocks(block=block)
        boxes = CellBoxes(P, C, blocks, checked=not chunk)
        assert lean._quiet_cells(boxes, grid.origin, grid.h, grid.G, grid.table) \
            is not None
        count, (near, i0, i1, ext) = boxes.flag_pass(grid.origin, grid.h, grid.G,
                                                     grid.table)
    want = _plain(P, C, grid)
    assert count == 0 and np.array_equal(near, want[0])
    assert i0.dtype == want[1].dtype and np.array_equal(i0, want[1])
    assert np.array_equal(i1, want[2])
    assert np.float64(ext).tobytes() == np.float64(want[3]).tobytes()
    assert 0 < near.sum() < len(C)
    lo, hi = boxes.rows(near)
    ref = boxes_of(P, C[near])
    assert np.array_equal(lo, ref[0]) and np.array_equal(hi, ref[1])
    assert np.array_equal(boxes.cells_of(near), C[near])
    # the shortcut decides many rows (most at the smaller pads): distance > width
    pc, low = lean._quiet_cells(CellBoxes(P, C), grid.origin, grid.h, grid.G, grid.table)
    _, _, skip = pc.ranges(np.ascontiguousarray((C - low).T), "raise")
    assert skip.mean() > 0.2 and not (skip & near).any()


@pytest.mark.parametrize("fast", [False, True])
def test_the_workers_chunk_pass_is_the_serial_one(fast):
    """A chunk's flags as a worker computes them (partition.remote._flags: the numpy
    shortcut on the chunk's points, or the compiled pass) give the serial pass's
    flags of those rows, ranges' cover and largest edge."""
    from predicates import compiled
    from predicates.registration.partition.remote import _flags

    if fast and not compiled.available():
        pytest.skip("numba not installed")
    P, C, cp, cc = _mesh(7, False)
    lo_b, hi_b = boxes_of(cp, cc)
    grid = first_round.fixed_grid(lo_b, hi_b, len(C), 0.0, Blocks())
    want = _plain(P, C, grid)
    a, b = len(C) // 4, len(C) // 2
    _, (ids, cover, ext, cells, _, _) = _flags(C[a:b], P, grid.origin, grid.h, grid.G,
                                               grid.table, fast)
    assert np.array_equal(ids, np.flatnonzero(want[0][a:b]))
    assert np.array_equal(cells, C[a:b][ids])
    lo, hi = boxes_of(P, C[a:b][ids])
    assert ext == (float(box_extent(lo, hi).max()) if len(ids) else 0.0)
    i0, i1 = (cell_index(x, grid.origin, grid.h, grid.G) for x in (lo, hi))
    ref = (i0, i1) if isinstance(cover, tuple) else \
        np.packbits(occupancy(i0, i1, grid.G).ravel())
    assert all(np.array_equal(x, y) for x, y in zip(cover, ref)) \
        if isinstance(cover, tuple) else np.array_equal(cover, ref)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.booleans(), st.sampled_from([7, 64, None]),
       st.booleans(), st.booleans())
def test_the_summarys_pass_gives_the_plain_flags_and_summary(seed, single, block, chunk,
                                                             threads):
    """The numpy summary with the flags in its pass (quiet.swept_summary: the float
    shortcut of the compiled sweep, vertices far from the origin excluded) gives the
    plain summary and the plain pass's flags, ranges and edge, and keeps the flagged
    rows' boxes and cells; the speculative grid (pad 0)."""
    P, C, cp, cc = _mesh(seed, single)
    if chunk:
        C = C[len(C) // 3: 2 * len(C) // 3]
    grid = first_round.speculative(*boxes_of(cp, cc), len(C), Blocks())
    with ThreadPoolExecutor(2) as pool:
        blocks = Blocks(pool, 2, block=block) if threads else Blocks(block=block)
        boxes = CellBoxes(P, C, blocks, checked=not chunk)
        boxes.sweep_grid = grid
        got = boxes.summary()
        assert boxes.first_grid is grid
        count, (near, i0, i1, ext) = boxes.flag_pass(grid.origin, grid.h, grid.G,
                                                     grid.table)
    ref = CellBoxes(P, C).summary()
    assert np.array_equal(got.lo_min, ref.lo_min) and np.array_equal(got.hi_max, ref.hi_max)
    assert (got.n, got.ext_max, got.ext_min) == (ref.n, ref.ext_max, ref.ext_min)
    assert np.array_equal(got.hist, ref.hist)
    want = _plain(P, C, grid)
    assert count == 0 and np.array_equal(near, want[0]) and 0 < near.sum() < len(C)
    assert np.array_equal(i0, want[1]) and np.array_equal(i1, want[2])
    assert np.float64(ext).tobytes() == np.float64(want[3]).tobytes()
    lo, hi = boxes.rows(near)
    ref_boxes = boxes_of(P, C[near])
    assert np.array_equal(lo, ref_boxes[0]) and np.array_equal(hi, ref_boxes[1])
    assert np.array_equal(boxes.cells_of(near), C[near])
