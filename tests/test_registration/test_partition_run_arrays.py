"""A cells-on-the-workers plan defers its run arrays (predicates.registration.partition.
run_arrays; docs/partitioned.md 5a): the arrays, once computed, are the partitioned
plan's bit for bit; every point is refused as ``scale_points`` refuses it; the cells
and boxes the flag pass keeps (the workers' kept rows, int32 row ids) are the serial
pass's, for any chunking, compiled or not."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from same_result import chunked_cells as _chunked, rotated_case as _case

from predicates import compiled
from predicates.registration import pipeline
from predicates.registration.partition import remote
from predicates.registration.partition.run_arrays import (
    DeferredRun, checked_scaling, materialised)
from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.plan.inputs import scale_points
from predicates.registration.plan.first_round import near_fixed
from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxes import boxes_of

pytest.importorskip("dask.array")

CASES = [("sphere", 5, dict(subdivisions=1)), ("plane", 4, {}), ("circle", 8,
                                                                   dict(segments=24))]
FAST = [False, True] if compiled.available() else [False]


def _args(sp, sc, cp, cc, dtype):
    return ((sp, sc, cp, cc), dtype, 1.0, False, pipeline.CHUNK, True, {}, None, None)


@settings(max_examples=10, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.sampled_from(range(len(CASES))), st.integers(1, 7), st.integers(0, 2**32 - 1),
       st.sampled_from([np.float64, np.float32]), st.sampled_from(FAST))
def test_deferred_run_arrays_are_the_partitioned_plans(case, parts, seed, dtype, fast):
    """The plan of dask-array cells holds a DeferredRun (no P_sim); materialised, its
    run arrays are those of the same partitioned plan with the cells on the client —
    the same bytes, dtypes and order — and every global quantity is the same."""
    name, n, kw = CASES[case]
    sp, sc, cp, cc = _case(name, n, angle=seed % 7 or None, **kw)
    ref = pipeline._plan(*_args(sp, sc, cp, cc, dtype), scheduler="synchronous",
                         accelerate=fast)
    cells = _chunked(sc, np.random.default_rng(seed), parts)
    got = pipeline._plan(*_args(sp, cells, cp, cc, dtype), scheduler="synchronous",
                         accelerate=fast)
    assert isinstance(got.sim_vertex_ids, DeferredRun) and got.P_sim is None
    assert len(got.sim_cells) == len(ref.sim_cells)
    done = materialised(got)
    assert materialised(done) is done  # computed once
    for field in ("P_sim", "sim_cells", "sim_vertex_ids", "P_cut", "cut_cells"):
        a, b = getattr(done, field), getattr(ref, field)
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), field
    assert (got.scale.L_a, got.scale.L_b, got.scale.e) == (ref.scale.L_a, ref.scale.L_b,
                                                           ref.scale.e)
    assert got.report.to_dict() == ref.report.to_dict()


def _refusal(f):
    """The message of the ValueError ``f()`` raises, or None."""
    try:
        f()
    except ValueError as err:
        return str(err)
    return None


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 2**32 - 1), st.integers(-1100, 1100),
       st.sampled_from([np.float64, np.float32]), st.sampled_from(FAST),
       st.integers(1, 3 * (1 << 16)), st.sampled_from(["none", "tiny", "huge", "both"]))
def test_checked_scaling_refuses_as_scale_points(seed, e, dtype, fast, n, bad):
    """Every point checked: the same refusal (overflow anywhere first, else a lost bit)
    and message as ``scale_points`` of every point, or none — across blocks of the
    compiled pass (n up to three of them), for exponents inside and beyond the
    dtype's normal range."""
    rng = np.random.default_rng(seed)
    fi = np.finfo(dtype)
    e = int(np.clip(e, fi.minexp - 30, fi.maxexp + 30))
    pts = (rng.standard_normal((n, 3)) * 2.0 ** rng.integers(-8, 8)).astype(dtype)
    where = rng.integers(0, n, size=2)
    if bad in ("tiny", "both"):
        pts[where[0], 0] = fi.smallest_subnormal * 3
    if bad in ("huge", "both"):
        pts[where[1], 2] = fi.max / 4
    want = _refusal(lambda: scale_points(pts, e, "simulation", accelerate=False))
    assert _refusal(lambda: checked_scaling(pts, e, fast)) == want


@pytest.mark.parametrize("fast", FAST)
@pytest.mark.parametrize("parts", [1, 3, 8])
def test_the_flagged_cells_from_the_workers_are_the_serial_ones(fast, parts):
    """The first flag round on the workers: the same flags and largest edge as on every
    cell here, and the kept cells (the kernel's kept rows there) and boxes are the
    flagged rows' own cells and ``boxes_of`` boxes, bit for bit."""
    sp, sc, cp, cc = _case("sphere", 7, angle=2, subdivisions=2)
    cells = _chunked(sc, np.random.default_rng(parts), parts)
    blocks = Blocks(accelerate=fast)
    sim, remote_cells = remote.validate_remote(sp, cells, 3, np.float64, "synchronous",
                                               blocks)
    lo_b, hi_b = boxes_of(cp, cc)
    pad = 0.05
    got = near_fixed(remote_cells, lo_b, hi_b, pad)
    ref = near_fixed(CellBoxes(sim.points, sc, blocks), lo_b, hi_b, pad)
    assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
    assert got[2] == ref[2] and got[0].any()
    lo, hi = remote_cells.rows(got[0])
    want = boxes_of(sim.points, sc[got[0]])
    assert lo.tobytes() == want[0].tobytes() and hi.tobytes() == want[1].tobytes()
    assert np.array_equal(remote_cells.cells_of(got[0]), sc[got[0]])


@pytest.mark.skipif(not compiled.available(), reason="the sweep is compiled")
@pytest.mark.parametrize("parts", [1, 3, 8])
@pytest.mark.parametrize("pad", [0.0, 1e-9, 0.3])
def test_the_check_sweeps_flags_are_the_serial_ones(parts, pad):
    """The workers' check flags the first round in its sweep (partition/swept.py) when
    the grid is fixed before it (validate_pair_remote, compiled): its flags, largest
    edge and kept cells are those of the serial plan at the same grid, for any
    chunking; a pad beyond the sweep's margin (0.3) runs the flags as a round of its
    own, with the same values as serially."""
    from predicates.registration.plan import first_round

    sp, sc, cp, cc = _case("sphere", 7, angle=2, subdivisions=2)
    cells = _chunked(sc, np.random.default_rng(parts), parts)
    blocks = Blocks(accelerate=True)
    _, sim, cut, remote_cells = remote.validate_pair_remote(sp, cells, cp, cc, np.float64,
                                                            "synchronous", blocks)
    assert remote_cells.first_grid is not None
    cut_box = first_round.cut_boxes(remote_cells, cut, boxes_of)
    got = near_fixed(remote_cells, *cut_box, pad)
    ref = near_fixed(CellBoxes(sim.points, sc, blocks), *cut_box, pad)
    assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
    assert got[2] == ref[2] and got[0].any()
    assert remote_cells.stats["first_round"] == ("a round of its own" if pad == 0.3
                                                 else "check's sweep")
    assert np.array_equal(remote_cells.cells_of(got[0]), sc[got[0]])
