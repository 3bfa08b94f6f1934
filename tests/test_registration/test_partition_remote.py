"""The plan's per-cell passes on the workers (predicates.registration.partition.remote;
docs/partitioned.md, section 6): simulation cells given as a dask array stay on the
workers, the client combines per-chunk summaries — and the result is the serial one bit
for bit for any chunking and scheduler, also when the client process cannot hold the
mesh at all."""
from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import predicates
from limited_client import assert_pairs_equal_saved, run_client
from same_result import assert_identical, chunked_cells as _chunked, rotated_case as _case

da = pytest.importorskip("dask.array")




CASES = [("sphere", 5, dict(subdivisions=1)), ("plane", 4, {}), ("circle", 8,
                                                                   dict(segments=24))]


@pytest.mark.filterwarnings("ignore::fperr.ResolutionWarning")  # float32 is coarse here
@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.sampled_from(range(len(CASES))), st.integers(1, 9), st.integers(1, 12),
       st.sampled_from(["synchronous", "threads"]), st.integers(0, 2**32 - 1),
       st.sampled_from([np.float64, np.float32]))
def test_cells_on_the_workers_give_the_serial_result(case, parts, k, sched, seed, dtype):
    """The serial result bit for bit for any chunking, k and scheduler, with the plan's
    passes and the split on the workers (docs/partitioned.md 3 and 6)."""
    name, n, kw = CASES[case]
    sp, sc, cp, cc = _case(name, n, angle=seed % 7 or None, **kw)
    ref = predicates.intersect(sp, sc, cp, cc, dtype=dtype)
    cells = _chunked(sc, np.random.default_rng(seed), parts)
    res = predicates.intersect(sp, cells, cp, cc, dtype=dtype, partitions=k,
                               scheduler=sched)
    assert_identical(ref, res)
    remote = res.timings["plan_remote"]
    # validation and the first round: one task per chunk when the check's task made
    # the round's flags (the grid the round's: first_round.py; partition/swept.py)
    swept = remote["first_round"] == "check's sweep"
    assert remote["tasks"] >= (1 if swept else 2) * cells.numblocks[0]
    # (compiled: tetrahedra only; numpy: a flag pass after the check, any cells)
    assert not swept or not res.timings["accelerated"] or sc.shape[1] == 4
    assert res.timings["split"]["where"] == "workers"


def test_processes_and_a_distributed_cluster():
    distributed = pytest.importorskip("distributed")
    sp, sc, cp, cc = _case("sphere", 6, angle=3, subdivisions=2)
    ref = predicates.intersect(sp, sc, cp, cc)
    cells = _chunked(sc, np.random.default_rng(1), 5)
    assert_identical(ref, predicates.intersect(sp, cells, cp, cc, partitions=3,
                                               scheduler="processes"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        res = predicates.intersect(sp, cells, cp, cc, partitions=4, scheduler=client)
    assert_identical(ref, res)


def test_a_scheduler_address_keeps_the_cells_on_the_workers():
    """``scheduler="tcp://..."`` (what ``fperr intersect --scheduler`` takes) connects
    once and runs the plan's per-chunk passes on that cluster's workers, as a Client
    does: the serial result, and the plan's tasks counted (the old path gathered the
    cells and ran the plan on the client: no "plan_remote")."""
    distributed = pytest.importorskip("distributed")
    sp, sc, cp, cc = _case("sphere", 6, angle=2, subdivisions=2)
    ref = predicates.intersect(sp, sc, cp, cc)
    cells = _chunked(sc, np.random.default_rng(5), 4)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        res = predicates.intersect(sp, cells, cp, cc, partitions=3,
                                   scheduler=cluster.scheduler_address)
    assert_identical(ref, res)
    remote = res.timings["plan_remote"]
    rounds = 1 if remote["first_round"] == "check's sweep" else 2  # (the check's sweep)
    assert remote["tasks"] >= rounds * cells.numblocks[0]
    assert len(res.timings["partitions"]) >= 1


@pytest.mark.parametrize("bad", ["negative", "range", "repeat"])
def test_bad_cells_on_the_workers_are_refused_as_serially(bad):
    sp, sc, cp, cc = _case("sphere", 4, subdivisions=1)
    sc = sc.copy()
    row = len(sc) - 3  # in the last chunk: the message names the global cell
    sc[row, 1] = {"negative": -1, "range": len(sp) + 5, "repeat": sc[row, 0]}[bad]
    with pytest.raises(ValueError) as serial:
        predicates.intersect(sp, sc, cp, cc)
    with pytest.raises(ValueError) as remote:
        predicates.intersect(sp, da.from_array(sc, chunks=(40, 4)), cp, cc, partitions=2,
                             scheduler="synchronous")
    assert str(remote.value) == str(serial.value) and f"cell {row}" in str(serial.value)


@pytest.mark.parametrize("bad", ["used nan", "unused nan", "float32 overflow"])
def test_points_on_the_client_are_checked_as_serially(bad):
    """The client's points are validated as serially whether or not the workers' sweep
    found every point finite (remote.validate_remote skips the finiteness test only
    then): a NaN in a used point and a float32 overflow refused with the serial message,
    a NaN in an unused point ignored — the serial result."""
    sp, sc, cp, cc = _case("sphere", 4, subdivisions=1)
    sp, dtype = sp.copy(), np.float32 if bad == "float32 overflow" else np.float64
    if bad == "unused nan":
        sp = np.vstack([sp, [np.nan] * 3])
    else:
        sp[sc[7, 2]] = 1e39 if bad == "float32 overflow" else np.nan
    cells = da.from_array(sc, chunks=(40, 4))
    if bad == "unused nan":
        assert_identical(predicates.intersect(sp, sc, cp, cc),
                         predicates.intersect(sp, cells, cp, cc, partitions=2,
                                              scheduler="synchronous"))
        return
    with pytest.raises(ValueError) as serial:
        predicates.intersect(sp, sc, cp, cc, dtype=dtype)
    with pytest.raises(ValueError) as remote:
        predicates.intersect(sp, cells, cp, cc, dtype=dtype, partitions=2,
                             scheduler="synchronous")
    assert str(remote.value) == str(serial.value)


CLIENT = textwrap.dedent("""
    import json, resource, sys
    import numpy as np
    import dask, dask.array as da
    from distributed import Client
    import predicates
    from predicates.registration.examples import cube_grid, grid_coordinates, icosphere

    n, address, headroom, result = int(sys.argv[1]), sys.argv[2], int(sys.argv[3]), sys.argv[4]

    def cells_chunk(n, a, b):  # rows [a, b) of cube_grid(n)[1], built on a worker
        from predicates.registration.examples import _KUHN
        r = np.arange(a, b, dtype=np.int64)
        path, q = r // n ** 3, r % n ** 3
        k, j, i = q // (n * n), (q // n) % n, q % n
        out = np.empty((len(r), 4), dtype=np.int64)
        for p, steps in enumerate(_KUHN):
            sel = path == p
            for v, (di, dj, dk) in enumerate(steps):
                out[sel, v] = (i[sel] + di) + (n + 1) * ((j[sel] + dj) + (n + 1) * (k[sel] + dk))
        return out

    def status(field):
        for line in open("/proc/self/status"):
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024

    x = grid_coordinates(n)
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    points = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    del X, Y, Z
    cp, cc = icosphere(6)
    cp = 0.5 + (cp - 0.5) * 0.5  # a small sphere: few cells can meet
    m = 6 * n ** 3
    cuts = np.linspace(0, m, 5).astype(int)
    cells = da.concatenate([da.from_delayed(dask.delayed(cells_chunk)(n, a, b),
                                            shape=(b - a, 4), dtype=np.int64)
                            for a, b in zip(cuts[:-1], cuts[1:])])
    mesh = points.nbytes + m * 4 * 8
    client = Client(address)
    # the code is loaded before the limit, which is on the data: a small run on the same
    # client imports and compiles what the large one runs (with FPERR_ACCELERATE=1 the
    # compiled chain's JIT takes about 0.3 x this mesh of address space)
    predicates.intersect(*cube_grid(4), cp, cc, partitions=2, scheduler=client)
    limit = status("VmSize") + headroom
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))  # soft: lifted again below
    try:  # the limit is real: the cells alone do not fit
        np.ones(m * 4 * 8, dtype=np.uint8)
        fits = True
    except MemoryError:
        fits = False
    res = predicates.intersect(points, cells, cp, cc, partitions=4, scheduler=client)
    hwm = status("VmHWM")
    # the limit is on the registration; writing its result for the test is not part of it
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    client.close()
    np.savez(result, **{f"{k}.{f}": getattr(res[k], f) for k in res.kinds
                        for f in ("sim", "cut", "sim_weights", "cut_weights")})
    print(json.dumps({"fits": fits, "mesh": mesh, "headroom": headroom,
                      "counts": res.counts, "L": [res.L_a, res.L_b],
                      "e": res.scale_exponent, "hwm": hwm}))
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc")
def test_a_client_that_cannot_hold_the_mesh_gets_the_serial_result(tmp_path):
    """The client's address space is limited to less than the simulation mesh's bytes
    (RLIMIT_AS, set after its imports, connection and a small warm-up run that loads
    the code, the compiled chain's JIT included); the workers, started outside it,
    build the cells' chunks themselves. The run completes with the serial result. (The
    cutting mesh is finer than the simulation cells: a coarse one's refinement gathers
    the boxes of the cells near it on the client, docs/partitioned.md section 6.) The
    client's address space (VmPeak − VmSize at the limit) was measured at 0.89 × the
    mesh with a sphere of radius 0.37 (most of it proportional to the cells that can
    meet: survivors, split, payloads, merge); with radius 0.185, 0.40 x the mesh with
    or without FPERR_ACCELERATE=1 (0.74 x when the JIT loaded under the limit)."""
    pytest.importorskip("distributed")
    from predicates.registration.examples import cube_grid, icosphere

    n = 140  # 16.5 M tetrahedra: 527 MB of cells, 66 MB of points
    sp, sc = cube_grid(n)
    cp, cc = icosphere(6)
    cp = 0.5 + (cp - 0.5) * 0.5  # as in the client
    ref = predicates.intersect(sp, sc, cp, cc)
    mesh = sp.nbytes + sc.nbytes
    del sp, sc
    headroom = int(mesh * 0.75)
    result = tmp_path / "result.npz"
    out = run_client(CLIENT, tmp_path, lambda address: [
        str(n), address, str(headroom), str(result)])
    assert not out["fits"] and out["headroom"] < out["mesh"]
    assert out["counts"] == ref.counts and out["L"] == [ref.L_a, ref.L_b]
    assert out["e"] == ref.scale_exponent
    assert_pairs_equal_saved(ref, result)


@pytest.mark.parametrize("parts, offset, path", [(1, 0.0, "workers"), (6, 0.0, "workers"),
                                                (6, -0.5, "client")])
def test_the_report_from_the_workers_chunks_is_the_serial_one(parts, offset, path):
    """The report's shortest simulation edge near the cut comes from the workers'
    per-chunk summaries of the flag pass (docs/partitioned.md 5a) when every chunk's
    flagged cells scale by the same power of two, else from the client (offset -0.5:
    these chunks' largest coordinates fall in different binades); both give every
    field of the serial report exactly (the path is asserted so both are exercised)."""
    sp, sc, cp, cc = _case("sphere", 7, angle=2, subdivisions=2)
    sp, cp = sp + offset, cp + offset
    ref = predicates.intersect(sp, sc, cp, cc)
    cells = _chunked(sc, np.random.default_rng(parts), parts)
    res = predicates.intersect(sp, cells, cp, cc, partitions=2, scheduler="threads")
    assert res.timings["plan_remote"]["report_edge"] == path
    assert res.resolution.to_dict() == ref.resolution.to_dict()
    assert res.resolution.h_sim == ref.resolution.h_sim is not None
    assert_identical(ref, res)


def test_meshes_that_cannot_meet_cost_one_flag_pass():
    """No round of L is kept when nothing can meet; the report then reuses round one's
    flags (at the same pad) instead of a second flag pass over every chunk: the
    serial report and result, with one flag task per chunk (the check's, when its
    sweep flagged them)."""
    sp, sc, cp, cc = _case("sphere", 5, subdivisions=1)
    cp = cp + 10.0  # far from every simulation cell
    ref = predicates.intersect(sp, sc, cp, cc)
    assert ref.resolution.rounds == 0 and ref.resolution.h_sim is None
    cells = _chunked(sc, np.random.default_rng(3), 3)
    res = predicates.intersect(sp, cells, cp, cc, partitions=2, scheduler="threads")
    assert res.resolution.to_dict() == ref.resolution.to_dict()
    assert_identical(ref, res)
    remote = res.timings["plan_remote"]
    names = [name for name, _ in remote["worker_cpu"]]  # (the check's sweep flags too)
    assert names.count("flags") + names.count("check_swept") == 1


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.integers(1, 5),
       st.booleans())
def test_the_chunks_covered_grid_cells_give_the_cutting_flags(seed, d, chunks, fast):
    """Each chunk's flagged cells sent as the grid cells they cover (packed bits) or as
    their ranges, whichever is smaller (swept.flagged_cover), OR-ed on the client
    (swept.covered): the occupancy of all the ranges, so the cutting flags near_fixed
    takes from it are cut_flags' from the ranges (docs/partitioned.md 6)."""
    from predicates import compiled
    from predicates.registration.partition.swept import covered, flagged_cover
    from predicates.registration.plan.lean import cut_flags
    from predicates.registration.spatial.blocks import Blocks
    from predicates.registration.spatial.gridsums import any_in, occupancy

    rng = np.random.default_rng(seed)
    blocks = Blocks(accelerate=fast and compiled.available())
    G = rng.integers(1, 12, size=d).astype(np.int64)

    def ranges(n):
        a, b = (rng.integers(0, G, size=(n, d)) for _ in range(2))
        return np.minimum(a, b).astype(np.int32), np.maximum(a, b).astype(np.int32)

    # chunk sizes from none to many flagged cells: both forms, alone and mixed
    parts = [ranges(int(rng.choice([0, 1, 3, 40, 400]))) for _ in range(chunks)]
    covers = [flagged_cover(i0, i1, G, blocks) for i0, i1 in parts]
    i0, i1 = (np.concatenate([p[s] for p in parts]) for s in (0, 1))
    got0, got1, occ = covered(covers, G, blocks)
    ib0, ib1 = ranges(60)
    want = cut_flags(i0, i1, ib0, ib1, G, blocks)
    if occ is None:  # every chunk sent its ranges: they come back as they were
        assert all(isinstance(c, tuple) for c in covers)
        np.testing.assert_array_equal(got0, i0)
        np.testing.assert_array_equal(got1, i1)
        return
    assert got0 is None and got1 is None
    np.testing.assert_array_equal(occ, occupancy(i0, i1, G, blocks))
    np.testing.assert_array_equal(any_in(occ, ib0, ib1, G, blocks), want)
