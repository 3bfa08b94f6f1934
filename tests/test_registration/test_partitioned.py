"""Partitioned registration on Dask (predicates.registration.partition.assign*): the result is
identical to the serial run — same pairs in every kind, bit-identical weights — for
every number of partitions and every scheduler (docs/partitioned.md)."""
from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import predicates
from predicates.registration.examples import example
from predicates.registration.partition.assign import assign, split
from same_result import assert_identical, rotated_case as case

dask = pytest.importorskip("dask")
ROOT = Path(__file__).resolve().parents[2]
KS = (1, 2, 3, 7, 16)




CASES = {
    "diagonal": lambda r=None: case("diagonal", 6, r),  # through grid vertices
    "zigzag": lambda r=None: case("zigzag", 6, r),
    "circle": lambda r=None: case("circle", 8, r, segments=24),
    "plane": lambda r=None: case("plane", 4, r),  # grid-aligned, through vertices
    "plane_offset": lambda r=None: case("plane_offset", 4, r),
    "sphere": lambda r=None: case("sphere", 4, r, subdivisions=1),
}


@pytest.fixture(scope="module")
def process_pool():
    """One pool for every "processes" run (Dask would start one per compute)."""
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        yield pool


@pytest.mark.parametrize("scheduler", ["synchronous", "threads", "processes"])
@pytest.mark.parametrize("name", list(CASES))
def test_identical_for_every_k(name, scheduler, request):
    # (the pool lives in dask's config only during the test: a LocalCluster pickles the
    # config for its workers, and a pool cannot be pickled)
    pool = request.getfixturevalue("process_pool") if scheduler == "processes" else None
    with dask.config.set(pool=pool):
        _every_k(name, scheduler)


def _every_k(name, scheduler):
    for rotate in (None, 7):
        args = CASES[name](rotate)
        ref = predicates.intersect(*args)
        assert ref.total > 0
        for k in KS:
            assert_identical(ref, predicates.intersect(*args, partitions=k,
                                                       scheduler=scheduler))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(list(CASES)), k=st.integers(1, 40), seed=st.integers(0, 10**6),
       dtype=st.sampled_from([np.float64, np.float32]), ts=st.sampled_from([1.0, 0.0]))
def test_identical_random_partitionings(name, k, seed, dtype, ts):
    args = CASES[name](seed)
    ref = predicates.intersect(*args, dtype=dtype, tolerance_scale=ts)
    res = predicates.intersect(*args, dtype=dtype, tolerance_scale=ts, partitions=k,
                               scheduler="synchronous")
    assert_identical(ref, res)
    # per-run statistics: every partition proposes its halo pairs too
    for kind in ref.kinds:
        assert res[kind].candidates >= len(res[kind])


@pytest.mark.parametrize("processes", [False, True])
def test_identical_on_local_cluster(processes):
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=processes,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        for name in ("diagonal", "plane", "sphere"):
            args = CASES[name](3)
            ref = predicates.intersect(*args)
            for k in KS:
                assert_identical(ref, predicates.intersect(*args, partitions=k,
                                                           scheduler=client))
            assert_identical(ref, predicates.intersect(*args, partitions="auto",
                                                       scheduler=client))
        if processes:  # a scheduler address: connected to, used, disconnected
            address = cluster.scheduler_address
            assert_identical(ref, predicates.intersect(*args, partitions=3, scheduler=address))


def test_partitions_cover_and_halos_hold_owned_stars():
    """The ownership lemma (docs/partitioned.md): cells are owned once; every cell
    containing a vertex owned by r is in r's halo; and the examples really put
    registered pairs on partition borders."""
    sp, sc, cp, cc = CASES["plane"]()
    ref = predicates.intersect(sp, sc, cp, cc)
    for k in (2, 3, 7):
        pos, owner = assign(sp, sc, k)
        parts = list(split(sp, sc, cp, cc, k, pad=0.5))
        assert sum(p.owned_cells for p in parts) == len(sc)
        assert [p.index for p in parts] == list(range(k))
        border = np.zeros(len(sp), dtype=bool)  # vertices of cells of 2+ partitions
        cell_part = pos * k // len(sc)
        for v in range(len(sp)):
            border[v] = len(set(cell_part[np.any(sc == v, axis=1)])) > 1
        for p in parts:
            halo = {tuple(sorted(c)) for c in p.sim_ids[p.sim_cells].tolist()}
            star = np.any(np.isin(sc, np.flatnonzero(owner == p.index)), axis=1)
            assert {tuple(sorted(c)) for c in sc[star].tolist()} <= halo
            assert np.array_equal(p.own_vertex, owner[p.sim_ids] == p.index)
        assert border[ref["vertex_vertex"].sim[:, 0]].any()


@pytest.mark.parametrize("k", [2, 5])
def test_partitions_get_every_cutting_cell_within_reach(k):
    """Each partition holds every cutting cell whose box is within pad of one of its
    cells' boxes (the same float test as the broad phase, checked by brute force)."""
    from predicates.registration.spatial.broadphase import box_pairs_bruteforce

    sp, sc, cp, cc = CASES["sphere"](11)
    pad = 0.05
    Y = cp[cc]
    for p in split(sp, sc, cp, cc, k, pad=pad):
        Xp = p.P_sim[p.sim_cells]
        _, ib = box_pairs_bruteforce(Xp.min(axis=1), Xp.max(axis=1), Y.min(axis=1),
                                     Y.max(axis=1), pad)
        held = {tuple(sorted(c)) for c in p.cut_ids[p.cut_cells].tolist()}
        need = {tuple(sorted(c)) for c in cc[np.unique(ib)].tolist()}
        assert need and need <= held


def test_dask_arrays_and_auto():
    da = pytest.importorskip("dask.array")
    sp, sc, cp, cc = CASES["sphere"](5)
    ref = predicates.intersect(sp, sc, cp, cc)
    dsp, dsc = da.from_array(sp, chunks=(50, 3)), da.from_array(sc, chunks=(100, 4))
    assert_identical(ref, predicates.intersect(dsp, dsc, cp, cc))
    assert_identical(ref, predicates.intersect(dsp, dsc, cp, cc, partitions="auto",
                                               scheduler="threads"))
    assert_identical(ref, predicates.intersect(sp, sc, cp, cc, partitions=3))


def _by_coordinates(res):
    """{(sim vertex coords, cut vertex coords): weights bytes}: a result independent of
    the vertex numbering."""
    out = {}
    for kind in res.kinds:
        p = res[kind]
        for s, c, ws, wc in zip(p.sim, p.cut, p.sim_weights, p.cut_weights):
            key = (kind, res.sim_points[s].tobytes(), res.cut_points[c].tobytes())
            assert key not in out
            out[key] = ws.tobytes() + wc.tobytes()
    return out


def test_pieces_and_per_partition_files(tmp_path):
    from predicates.registration.partition.files import read_pieces, write_parts

    sp, sc, cp, cc = CASES["plane"]()
    ref = predicates.intersect(sp, sc, cp, cc)
    pieces = []
    for r, rows in enumerate(np.array_split(np.arange(len(sc)), 3)):
        ids, local = np.unique(sc[rows], return_inverse=True)  # each piece its own points
        path = tmp_path / f"piece{r}.vtu"
        meshio.Mesh(sp[ids], [("tetra", local.reshape(-1, 4))]).write(path)
        pieces.append(path)
    P, C = read_pieces(pieces)
    assert len(P) == len(sp) and len(C) == len(sc)  # shared boundary vertices merged
    res = predicates.intersect(P, C, cp, cc, partitions=3, scheduler="threads")
    assert _by_coordinates(res) == _by_coordinates(ref)

    paths = write_parts(ref, 3, str(tmp_path / "hits_{part}.vtu"))
    back = [meshio.read(p) for p in paths]
    assert sum(len(b.points) for b in back) == ref.total
    whole = ref.to_meshio()
    for key in whole.point_data:  # every pair in one file, with all its data
        got = np.concatenate([b.point_data[key] for b in back])
        assert sorted(map(repr, got.tolist())) == sorted(map(repr, whole.point_data[key].tolist()))
    for b in back:  # each file keeps the kind legend (field data) of the merged file
        assert {n: a.tolist() for n, a in b.field_data.items()} == \
            {n: np.asarray(a).tolist() for n, a in whole.field_data.items()}
    # written atomically (a hidden temporary file renamed): none left behind
    assert not [f.name for f in tmp_path.iterdir() if f.name.startswith(".")]
    for bad in ("hits.vtu", "hits_{part}_{x}.vtu", "hits_{part}.txt"):
        with pytest.raises(ValueError, match="part|braces|written as"):
            write_parts(ref, 3, str(tmp_path / bad))
    assert not (tmp_path / "hits_0.txt").exists()


def test_bad_arguments():
    args = CASES["diagonal"]()
    with pytest.raises(ValueError, match="scheduler must be one of"):
        predicates.intersect(*args, partitions=2, scheduler="gpu")
    with pytest.raises(ValueError, match="at least 1"):
        predicates.intersect(*args, partitions=0)
    with pytest.raises(TypeError, match="positive int or 'auto'"):
        predicates.intersect(*args, partitions=2.5)
    with pytest.raises(TypeError, match="scheduler must be"):
        predicates.intersect(*args, partitions=2, scheduler=3)


def test_without_dask(monkeypatch):
    from predicates.registration.partition.run import DaskMissingError

    monkeypatch.setitem(sys.modules, "dask", None)  # import dask now raises ImportError
    args = CASES["diagonal"]()
    ref = predicates.intersect(*args)  # the serial path needs no Dask
    assert ref.total > 0
    with pytest.raises(ImportError, match=r"pip install 'fperr\[dask\]'") as info:
        predicates.intersect(*args, partitions=2)
    assert isinstance(info.value, DaskMissingError)


def _cli(*argv, block_dask=False):
    pre = "import sys; sys.modules['dask'] = None; " if block_dask else "import sys; "
    code = pre + "from proofs.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *argv], capture_output=True,
                          text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_cli_workers(tmp_path):
    sp, sc, cp, cc = CASES["sphere"]()
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sp, [("tetra", sc)]).write(sim)
    meshio.Mesh(cp, [("triangle", cc)]).write(cut)
    serial, part = tmp_path / "serial.vtu", tmp_path / "part.vtu"
    r = _cli("intersect", str(sim), str(cut), "-o", str(serial), "--quiet")
    assert r.returncode == 0, r.stderr
    r = _cli("intersect", str(sim), str(cut), "-o", str(part), "--workers", "2")
    assert r.returncode == 0, r.stderr
    assert "peak memory per worker" in r.stdout and "partitions: " in r.stdout
    a, b = meshio.read(serial), meshio.read(part)
    assert a.points.tobytes() == b.points.tobytes()
    for key in a.point_data:
        assert a.point_data[key].tobytes() == b.point_data[key].tobytes()
    # refused before any work: nothing written
    out = tmp_path / "never.vtu"
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--workers", "0")
    assert r.returncode == 2 and "at least 1" in r.stderr
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--workers", "2",
             "--scheduler", "tcp://127.0.0.1:1")
    assert r.returncode == 2 and "give one of them" in r.stderr
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--workers", "2",
             block_dask=True)
    assert r.returncode == 2 and "pip install 'fperr[dask]'" in r.stderr
    assert "Traceback" not in r.stderr and not out.exists()


def _recording_bars(monkeypatch):
    """partition_run's bars, shown at once, each kept (with its count at close)."""
    import contextlib

    from predicates.registration.partition import run as partition_run

    monkeypatch.setattr(partition_run, "PROGRESS_DELAY", 0)
    bars, make = [], partition_run._bar

    @contextlib.contextmanager
    def keep(progress, k):
        with make(progress, k) as bar:
            yield bar
            bars.append((bar.n, bar.total, k))

    monkeypatch.setattr(partition_run, "_bar", keep)
    return bars


@pytest.mark.parametrize("scheduler", ["synchronous", "threads", "processes"])
def test_progress_bar_counts_the_partitions(scheduler, capsys, monkeypatch, request):
    """progress=True in a partitioned run: a bar of the partitions' tasks on stderr
    (the serial run's bar counts kinds) that counts every task as it ends, the same
    result; progress=False: nothing on stderr."""
    bars = _recording_bars(monkeypatch)
    pool = request.getfixturevalue("process_pool") if scheduler == "processes" else None
    args = CASES["sphere"]()
    ref = predicates.intersect(*args)
    capsys.readouterr()
    with dask.config.set(pool=pool):
        for k in (3, 7):
            res = predicates.intersect(*args, partitions=k, scheduler=scheduler,
                                       progress=True)
            assert_identical(ref, res)
            err = capsys.readouterr().err
            assert "registering" in err and f"0/{k}" in err and "partition" in err, err
            # every task counted; partitions with no cutting cell within reach run none
            ran = len(res.timings["partitions"])
            assert bars[-1] == (ran, ran, k) and 1 <= ran <= k
            predicates.intersect(*args, partitions=k, scheduler=scheduler)
            assert capsys.readouterr().err == ""


def test_progress_bar_on_a_local_cluster(capsys, monkeypatch):
    from distributed import Client, LocalCluster

    bars = _recording_bars(monkeypatch)
    args = CASES["plane"](5)
    ref = predicates.intersect(*args)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        capsys.readouterr()
        res = predicates.intersect(*args, partitions=4, scheduler=client, progress=True)
        assert_identical(ref, res)
        err = capsys.readouterr().err
        assert "registering" in err and "0/4" in err, err
        ran = len(res.timings["partitions"])
        assert bars[-1] == (ran, ran, 4)


def test_summary_reports_tasks_workers_and_their_peak_memory():
    """str(result) of a partitioned run says how many tasks ran on how many worker
    processes, each worker's peak memory and the bytes sent and returned (issue 13:
    "report peak memory per worker"); a serial run's summary has no such line."""
    args = CASES["sphere"]()
    serial = predicates.intersect(*args)
    assert "partitions:" not in str(serial)
    res = predicates.intersect(*args, partitions=3, scheduler="synchronous")
    parts = res.timings["partitions"]
    line = [x for x in str(res).splitlines() if x.startswith("partitions:")]
    peak = max(p["peak_rss_mib"] for p in parts)
    sent = sum(p["bytes_in"] for p in parts) / 1e6
    assert line == [f"partitions: {len(parts)} tasks on 1 worker process, peak memory per "
                    f"worker {peak:.0f} MiB; {sent:.3g} MB sent to them, "
                    f"{sum(p['bytes_out'] for p in parts) / 1e6:.3g} MB back (candidates, "
                    f"suppressed, tested: summed over the partitions)"]


def test_timeout_arguments_are_checked_before_any_work():
    args = CASES["diagonal"]()
    bad = (args[0], args[1] + 10**6, args[2], args[3])  # cell ids the plan would refuse
    remote = {"partitions": 2, "scheduler": "tcp://127.0.0.1:1"}  # never connected to
    for kw, err, text in (({"timeout": 0, **remote}, ValueError, "more than 0 seconds"),
                          ({"timeout": -1.5, **remote}, ValueError, "more than 0 seconds"),
                          ({"timeout": True, **remote}, TypeError, "number of seconds"),
                          ({"timeout": "5", **remote}, TypeError, "number of seconds"),
                          ({"timeout": 5}, ValueError, "partitioned run"),
                          ({"timeout": 5, "partitions": 2}, ValueError, "local schedulers"),
                          ({"timeout": 5, "partitions": 2, "scheduler": "processes"},
                           ValueError, "local schedulers")):
        with pytest.raises(err, match=text):
            predicates.intersect(*bad, **kw)


def test_timeout_cancels_the_tasks_and_names_the_partitions(monkeypatch):
    """A partitioned run whose tasks outlast ``timeout``: PartitionError naming the
    unfinished partitions, raised at the timeout (not when the tasks end); the same
    cluster then runs the next run normally, identical to the serial one."""
    import time

    from distributed import Client, LocalCluster

    from predicates.registration.partition import run as partition_run
    from predicates.registration.partition.run import PartitionError

    args = CASES["sphere"]()
    ref = predicates.intersect(*args)
    run_part = partition_run.run_part

    def slow(*a):
        time.sleep(5)
        return run_part(*a)

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        monkeypatch.setattr(partition_run, "run_part", slow)
        t = time.perf_counter()
        with pytest.raises(PartitionError, match=r"3 of 3 partitions \(0, 1, 2\) not "
                                                 r"finished after the timeout of 0.5 s"):
            predicates.intersect(*args, partitions=3, scheduler=client, timeout=0.5)
        assert time.perf_counter() - t < 4
        monkeypatch.setattr(partition_run, "run_part", run_part)
        assert_identical(ref, predicates.intersect(*args, partitions=3, scheduler=client,
                                                   timeout=60))


def test_a_worker_that_dies_under_a_task_is_a_partition_error():
    """A worker process killed under a task (as the nanny kills one over its memory
    limit): Dask's KilledWorker becomes PartitionError, naming the partition and what
    to do, instead of a bare Dask exception."""
    from distributed import Client, LocalCluster

    from predicates.registration.partition.run import PartitionError, _gather

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster, Client(cluster) as client:
        futures = [client.submit(os._exit, 1, pure=False)]
        with pytest.raises(PartitionError, match=r"worker died.*1 of 1 partitions \(7\)"
                                                 r".*more memory or run with more partitions"):
            _gather(futures, parts=[7])


def test_cli_timeout(tmp_path):
    sp, sc, cp, cc = CASES["sphere"]()
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sp, [("tetra", sc)]).write(sim)
    meshio.Mesh(cp, [("triangle", cc)]).write(cut)
    out = tmp_path / "out.vtu"
    # the tasks cannot finish in a millisecond: exit 1, a one-line error, nothing written
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--workers", "1",
             "--timeout", "0.001")
    assert r.returncode == 1 and not out.exists(), r.stderr
    assert "not finished after the timeout of 0.001 s" in r.stderr
    assert "Traceback" not in r.stderr and "WARNING" not in r.stderr
    for argv, text in ((["--timeout", "5"], "give --workers or --scheduler"),
                       (["--workers", "1", "--timeout", "0"], "more than 0 seconds"),
                       (["--workers", "1", "--timeout", "soon"], "not a number of seconds")):
        r = _cli("intersect", str(sim), str(cut), "-o", str(out), *argv)
        assert r.returncode == 2 and text in r.stderr and not out.exists(), r.stderr
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--workers", "1",
             "--timeout", "120", "--quiet")
    assert r.returncode == 0 and out.exists() and r.stderr == "", r.stderr


# -- the split of the work: partitions without cutting cells, the cell that sets L,
#    the merge, and the plan's helpers the partitioned run relies on ----------------------

def _corner_cut():
    """An 8^3 grid cut by two small triangles near one corner only: most partitions of
    a Morton split of all its cells hold no cutting cell within reach."""
    sp, sc = example("plane", 8)["sim"]
    cp = np.array([[0.05, 0.05, 0.1], [0.1, 0.05, 0.1], [0.05, 0.1, 0.1], [0.1, 0.1, 0.1]])
    cc = np.array([[0, 1, 2], [1, 3, 2]])
    return sp, sc, cp, cc


def test_partitions_without_cutting_cells_are_skipped():
    """Partitions of every simulation cell (a superset of the run's cells, which gives
    the same pairs): those with an empty cutting slice run no task, and the merged
    result is still the serial one."""
    from predicates.registration import pipeline
    from predicates.registration.partition.run import run_partitioned

    sp, sc, cp, cc = _corner_cut()
    ref = predicates.intersect(sp, sc, cp, cc)
    assert ref.total > 0
    plan = pipeline._plan((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True,
                          {}, None, None)
    plan = plan._replace(sim_cells=sc)  # every cell, not only those that can meet
    pad = max(plan.scale.reach.values())
    for k in (3, 7, 16):
        parts = list(split(plan.P_sim, sc, plan.P_cut, plan.cut_cells, k, pad))
        assert sum(len(p.cut_cells) == 0 for p in parts) >= k // 2  # what it claims
        timings = {}
        pairs = run_partitioned(plan, k, "synchronous", pipeline.CHUNK, timings)
        assert 0 < len(timings["partitions"]) < k  # no task for an empty slice
        for kind in ref.kinds:
            for name in ("sim", "cut", "sim_weights", "cut_weights"):
                assert getattr(pairs[kind], name).tobytes() == getattr(ref[kind], name).tobytes()


def test_one_partition_holds_the_cell_that_sets_L():
    """One stretched cell near the cut sets L_a (the largest box edge of the cells
    that can meet): every partitioning gives the serial L_a, tolerances and pairs."""
    sp, sc, cp, cc = CASES["plane_offset"](None)
    sp = sp.copy()
    v = np.argmin(np.linalg.norm(sp - cp.mean(axis=0), axis=1))  # a vertex by the cut
    sp[v, 0] += 0.1  # its cells get a larger box
    ref = predicates.intersect(sp, sc, cp, cc)
    X = sp[sc]
    edge = (X.max(axis=1) - X.min(axis=1)).max(axis=1)
    assert ref.L_a >= edge.max() > 1.3 * np.median(edge)  # L_a is the stretched cell's
    for k in KS:
        assert_identical(ref, predicates.intersect(sp, sc, cp, cc, partitions=k,
                                                   scheduler="synchronous"))


def _kp(kind, sim, cut):
    from predicates.registration.result.intersection import KindPairs

    sim, cut = np.asarray(sim, np.int64), np.asarray(cut, np.int64)
    return KindPairs(kind, sim, cut, sim.astype(float) / 7, cut.astype(float) / 3)


def test_merge_restores_the_serial_order_and_refuses_a_shared_vertex():
    from predicates.catalogue import kinds
    from predicates.registration.partition.assign import merge

    kind = kinds(2)[3]  # edge_edge: (2, 2) ids per pair
    serial = _kp(kind.name, [[0, 3], [0, 4], [1, 2], [2, 5], [2, 6], [4, 5]],
                 [[1, 2], [0, 1], [3, 4], [0, 2], [1, 3], [5, 6]])
    owner = np.array([1, 0, 1, 0, 1, 0, 0])  # per vertex: the partition keeping it
    first = serial.sim.min(axis=1)
    parts = []
    for r in (0, 1):  # each partition's pairs in the serial order (a subsequence)
        keep = owner[first] == r
        parts.append({kind.name: _kp(kind.name, serial.sim[keep], serial.cut[keep])})
    got = merge([kind], parts, np.float64)[kind.name]
    for a, b in ((got.sim, serial.sim), (got.cut, serial.cut),
                 (got.sim_weights, serial.sim_weights), (got.cut_weights, serial.cut_weights)):
        assert a.tobytes() == b.tobytes()
    parts[1] = {kind.name: _kp(kind.name, [[2, 7]], [[0, 1]])}  # vertex 2 is part 0's
    parts[0] = {kind.name: _kp(kind.name, [[2, 5]], [[0, 2]])}
    with pytest.raises(RuntimeError, match="ownership bug"):
        merge([kind], parts, np.float64)


def test_merge_runs_of_int32_and_int64_keys():
    """merge_runs on one partition's int32 keys and another's int64 keys beyond int32's
    range (each partition sends int32 ids when they fit): the runs of the stable merge,
    and a key in both refused."""
    from predicates.registration.partition.assign import merge_runs

    a, b = np.array([1, 5, 9, 11], np.int32), np.array([3, 7, 2**40], np.int64)
    assert merge_runs([a, b], 100) == [(0, 0, 1), (1, 0, 1), (0, 1, 2), (1, 1, 2),
                                       (0, 2, 4), (1, 2, 3)]
    with pytest.raises(RuntimeError, match="ownership bug"):
        merge_runs([a, np.array([5], np.int64)], 100)


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 10**6), k=st.integers(1, 9), pairs=st.integers(0, 120),
       blocks=st.integers(1, 40), runs=st.sampled_from([0, 2, 4096]),
       wide=st.booleans())
def test_merge_by_runs_is_the_stable_sort(seed, k, pairs, blocks, runs, wide):
    """The merge (runs copied as slices, or the sort-and-gather fallback when there are
    more runs than ``MERGE_RUNS`` allows) gives the arrays of the definition: every
    partition's pairs concatenated, then a stable sort by the smallest sim id — the
    same bytes, int64 ids from int32 or int64 parts, the weights' dtype kept; a vertex
    whose pairs two partitions kept is refused (random owners, some in blocks of
    consecutive vertices: few runs)."""
    from predicates.registration.partition import assign as assign_mod

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(assign_mod, "MERGE_RUNS", runs)
        _merge_case(assign_mod.merge, np.random.default_rng(seed), k, pairs, blocks, wide)


def _merge_case(merge, rng, k, pairs, blocks, wide):
    from predicates.catalogue import kinds
    from predicates.registration.result.intersection import KindPairs

    kind = kinds(3)[4]  # (i + 1, j + 1) ids per pair, i != j: the widths differ
    n_vertices = 200
    owner = np.repeat(rng.integers(0, k, size=blocks), -(-n_vertices // blocks))[
        :n_vertices] if rng.random() < 0.5 else rng.integers(0, k, size=n_vertices)
    sim = np.sort(rng.integers(0, n_vertices, size=(pairs, kind.i + 1)), axis=1)
    cut = rng.integers(0, 500, size=(pairs, kind.j + 1))
    order = np.lexsort((*cut.T[::-1], *sim.T[::-1]))  # the serial order: sim, then cut
    sim, cut = sim[order], cut[order]
    ids = np.int32 if wide else np.int64
    sw = rng.random((pairs, kind.i + 1)).astype(np.float32)
    cw = rng.random((pairs, kind.j + 1)).astype(np.float32)
    first = sim.min(axis=1)

    def part(keep):
        return KindPairs(kind.name, sim[keep].astype(ids), cut[keep].astype(ids),
                         sw[keep], cw[keep], candidates=1, suppressed=2)

    turn = rng.permutation(k)  # the partitions' results in any order
    results = [{kind.name: part(owner[first] == r)} for r in turn]
    parts = [res[kind.name] for res in results]
    cat = [np.concatenate([getattr(p, a) for p in parts]) for a in
           ("sim", "cut", "sim_weights", "cut_weights")]
    ref = np.argsort(cat[0].min(axis=1), kind="stable")
    got = merge([kind], results, np.float32)[kind.name]
    for a, b in zip((got.sim, got.cut, got.sim_weights, got.cut_weights), cat):
        assert a.dtype == (np.int64 if b.dtype.kind == "i" else np.float32)
        assert a.shape == b.shape and a.tobytes() == b[ref].astype(a.dtype).tobytes()
    assert (got.candidates, got.suppressed) == (k, 2 * k)
    # every row of the serial order is kept by exactly one partition: it is that order
    assert np.array_equal(got.sim, sim) and np.array_equal(got.cut, cut)
    if pairs and k > 1:  # some vertex's pair kept by a second partition too
        row = int(rng.integers(0, pairs))
        other = (int(owner[first[row]]) + 1) % k
        keep = owner[first] == other
        keep[row] = True  # still in the serial order (a subsequence)
        results[int(np.flatnonzero(turn == other)[0])] = {kind.name: part(keep)}
        with pytest.raises(RuntimeError, match="ownership bug"):
            merge([kind], results, np.float32)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]))
def test_plan_counts_match_their_reference_forms(seed, dim):
    """The plan's faster forms give the same numbers: the dense cell-pair count against
    the keyed one, the shortest edge against the (n, k, d) gather."""
    from predicates.registration.plan import resolution as R

    rng = np.random.default_rng(seed)
    sc_ = 10.0 ** rng.uniform(-3, 3)

    def boxes(n):
        lo = rng.normal(size=(n, dim)) * sc_
        return lo, lo + np.abs(rng.normal(size=(n, dim))) * sc_ * rng.choice([0.01, 0.3])

    (la, ha), (lb, hb) = boxes(rng.integers(1, 200)), boxes(rng.integers(1, 200))
    pad = sc_ * rng.choice([0.0, 1e-3, 0.2])
    fast = R.estimate_cell_pairs(la, ha, lb, hb, pad)
    keyed = R._dense_pair_count
    try:
        R._dense_pair_count = lambda *a: None
        assert fast == R.estimate_cell_pairs(la, ha, lb, hb, pad)
    finally:
        R._dense_pair_count = keyed
    P = rng.normal(size=(50, dim)) * sc_
    C = np.array([rng.choice(50, dim + 1, replace=False) for _ in range(40)])
    mask = rng.random(40) < 0.5
    mask[0] = True
    X = P[C[mask]]
    d = [np.sqrt(((X[:, a] - X[:, b]) ** 2).sum(1)) for a in range(dim + 1)
         for b in range(a + 1, dim + 1)]
    assert R.shortest_edge(P, C, mask) == float(np.min(d))


@pytest.mark.parametrize("dim", [2, 3])
def test_cell_pair_estimate_of_points_at_pad_zero(dim):
    """Point-like boxes at pad 0 (all extents 0): the estimate's grid stays within 2^20
    cells per axis (it used to take a cell of 1e-300 and fail on int64 overflow), and
    every coincident pair shares a grid cell, so each is counted."""
    from predicates.registration.plan import resolution as R

    rng = np.random.default_rng(dim)
    a = rng.random((300, dim))
    b = np.concatenate([a[:40], rng.random((200, dim)) + 2.0])
    count = R.estimate_cell_pairs(a, a, b, b, 0.0)
    assert isinstance(count, int) and 40 <= count <= 40 + 5


def test_partitioned_result_to_dict_is_json():
    import json

    res = predicates.intersect(*CASES["sphere"](), partitions=2, scheduler="synchronous")
    d = json.loads(json.dumps(res.to_dict()))
    assert len(d["timings"]["partitions"]) == 2
    for key in ("cpu_setup", "cpu_partition", "cpu_dask", "cpu_merge"):
        assert d["timings"][key] >= 0
    for p in d["timings"]["partitions"]:
        assert p["bytes_in"] > 0 and p["cpu_s"] >= 0 and p["cut_cells"] > 0


def test_memory_guard_counts_the_partitions_held_at_once():
    """The guard refuses before any work what would not fit; a partitioned run holds
    only the partitions running at once (one at a time under "synchronous")."""
    from fperr import ResolutionError
    from predicates.registration.plan.resolution import BYTES_PER_CELL_PAIR

    args = CASES["sphere"]()
    ref = predicates.intersect(*args)
    limit = ref.resolution.cell_pairs * BYTES_PER_CELL_PAIR // 2
    with pytest.raises(ResolutionError, match="refused before the work"):
        predicates.intersect(*args, memory_limit=limit)
    with pytest.raises(ResolutionError, match="refused before the work"):
        predicates.intersect(*args, memory_limit=limit, partitions=1, scheduler="synchronous")
    assert_identical(ref, predicates.intersect(*args, memory_limit=limit, partitions=4,
                                               scheduler="synchronous"))


def _assert_same_plan(a, b):
    """Two plans (pipeline.Plan) equal field by field, arrays bit for bit."""
    def same(x, y, where):
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, where
            assert x.tobytes() == y.tobytes(), where
        elif isinstance(x, (tuple, list)):
            assert len(x) == len(y), where
            for i, (u, v) in enumerate(zip(x, y)):
                same(u, v, f"{where}[{i}]")
        elif isinstance(x, dict):
            assert x.keys() == y.keys(), where
            for key in x:
                same(x[key], y[key], f"{where}.{key}")
        else:
            assert x == y, where

    for name in ("dim", "dtype", "P_sim", "P_cut", "sim_cells", "cut_cells", "ts", "kinds"):
        same(getattr(a, name), getattr(b, name), name)
    for name in ("L_a", "L_b", "e", "reach", "pad", "masks", "history"):
        same(getattr(a.scale, name), getattr(b.scale, name), f"scale.{name}")
    same(a.tol.values, b.tol.values, "tol.values")
    same(a.report.to_dict(), b.report.to_dict(), "report")
    same(a.sim.cells, b.sim.cells, "sim.cells")
    same(a.cut.points, b.cut.points, "cut.points")  # the refined cutting mesh
    same(a.cut.cells, b.cut.cells, "cut.cells")


@pytest.mark.parametrize("name,min_chunk,rotate", [
    ("diagonal", 3, None), ("diagonal", 3, 5), ("plane_offset", 5, 2),
    ("corner", 2, None), ("w1", None, None)])
def test_threaded_plan_equals_the_serial_plan(name, min_chunk, rotate, monkeypatch):
    """A partitioned run's plan runs its per-cell work in chunks on a thread pool
    (plan_threads): every field equals the serial plan's, bit for bit — with chunks of a
    few cells (MIN_CHUNK lowered: many chunks, uneven ends) on the small cases, and
    with the default chunking on a W1-like cube (82,944 tetrahedra × sphere)."""
    from predicates.registration.spatial import blocks
    from predicates.registration import pipeline
    from predicates.registration.examples import cube_grid, icosphere

    if name == "w1":
        (sp, sc), (cp, cc) = cube_grid(24), icosphere(4)
    elif name == "corner":
        sp, sc, cp, cc = _corner_cut()
    else:
        sp, sc, cp, cc = CASES[name](rotate)
    if min_chunk is not None:
        monkeypatch.setattr(blocks, "MIN_SPAN", min_chunk)
        monkeypatch.setattr(blocks, "BLOCK", 2 * min_chunk)
    assert len(blocks.Blocks(object(), 3).spans(len(sc))) > 1  # the threaded code runs
    args = ((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True)
    ref = pipeline._plan(*args, {}, None, None)
    for threads in (2, 3):
        _assert_same_plan(ref, pipeline._plan(*args, {}, None, None, threads=threads))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.integers(1, 5),
       st.floats(0, 0.3))
def test_threaded_boxes_and_flags_equal_the_serial_ones(seed, dim, parts, pad):
    """boxes_of / near_flags on random simplices in blocks of 3 rows, on one span or on
    a thread pool: bit-identical boxes and identical flags to the whole-array ones
    (one block), for any number of spans."""
    from concurrent.futures import ThreadPoolExecutor

    from predicates.registration.spatial import blocks
    from predicates.registration.spatial import broadphase

    rng = np.random.default_rng(seed)
    P = rng.uniform(-1, 1, size=(60, dim))
    A = rng.integers(0, 60, size=(rng.integers(1, 40), dim + 1))
    Bc = rng.integers(0, 60, size=(rng.integers(1, 20), dim))
    whole = blocks.Blocks(block=1 << 30)
    old = blocks.MIN_SPAN
    blocks.MIN_SPAN = 4
    try:
        with ThreadPoolExecutor(2) as pool:
            ra, rb = broadphase.boxes_of(P, A, whole), broadphase.boxes_of(P, Bc, whole)
            ref = broadphase.near_flags(*ra, *rb, pad, blocks=whole)
            for bl in (blocks.Blocks(block=3), blocks.Blocks(pool, parts, block=3)):
                ta = broadphase.boxes_of(P, A, bl)
                for x, y in zip(ra, ta):
                    assert x.tobytes() == y.tobytes() and x.strides == y.strides
                got = broadphase.near_flags(*ta, *rb, pad, blocks=bl)
                assert np.array_equal(ref[0], got[0]) and np.array_equal(ref[1], got[1])
    finally:
        blocks.MIN_SPAN = old


# -- the split's and merge's fast forms against their reference forms, and the local
#    cluster's settings, submission and result order (issue 13's overheads) -------------

def _morton_reference(points, cells):
    """The Morton position of every cell by the definition: the first vertex quantised
    to 21 (3D) / 31 (2D) bits per axis over the first vertices' bounding box, the bits
    interleaved with Python ints (bit b of axis a at b·dim + a), cells ordered by code,
    ties by cell index."""
    dim = points.shape[1]
    bits = 21 if dim == 3 else 31
    first = points[cells[:, 0]].astype(np.float64)
    lo, hi = first.min(axis=0), first.max(axis=0)
    codes = []
    for x in first:
        code = 0
        for a in range(dim):
            span = hi[a] - lo[a] if hi[a] > lo[a] else 1.0
            q = int(min(max((x[a] - lo[a]) / span * (2 ** bits - 1), 0), 2 ** bits - 1))
            for b in range(bits):
                code |= ((q >> b) & 1) << (b * dim + a)
        codes.append(code)
    order = sorted(range(len(cells)), key=codes.__getitem__)  # stable: ties by index
    pos = np.empty(len(cells), dtype=np.int64)
    pos[order] = np.arange(len(cells))
    return pos


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]),
       scale=st.sampled_from([1e-6, 1.0, 1e5]), flat=st.booleans(), n=st.integers(1, 60))
def test_morton_order_is_the_reference(seed, dim, scale, flat, n):
    from predicates.registration.partition.assign import morton_order

    rng = np.random.default_rng(seed)
    P = rng.normal(size=(n, dim)) * scale
    P[rng.integers(0, n, size=n // 3)] = P[0]  # repeated points: equal codes, ties
    if flat:
        P[:, 0] = 0.25  # a zero-width axis (span 1)
    C = rng.integers(0, n, size=(int(rng.integers(1, 80)), dim + 1))
    assert np.array_equal(morton_order(P, C), _morton_reference(P, C))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), cols=st.integers(1, 4), rows=st.integers(0, 50))
def test_row_reductions_are_numpys(seed, cols, rows):
    """boxgrid.rowwise (the partitions' smallest vertex id, the cell-pair estimate's
    cell counts) gives numpy's row reductions: the same dtype and values."""
    from predicates.registration.spatial.boxgrid import rowwise

    rng = np.random.default_rng(seed)
    a = rng.integers(-(2**62), 2**62, size=(rows, cols))
    got = rowwise(np.minimum, a)
    assert got.dtype == a.dtype and np.array_equal(got, a.min(axis=1, initial=2**63 - 1))
    f = rng.integers(1, 2**21, size=(rows, cols)).astype(np.float64) * rng.choice([1, 1e100])
    prod = rowwise(np.multiply, f)
    assert prod.dtype == f.dtype and np.array_equal(prod, np.prod(f, axis=1))


def test_local_cluster_settings_submission_and_order(monkeypatch):
    """client_for's workers run with WORKER_ENV (whatever an earlier cluster left in
    os.environ, which it restores) and without the profiler; slices go
    inline with their task or, above INLINE_BYTES, scattered first — the same result
    either way; _gather returns results in submission order whatever order the tasks
    end in."""
    import time

    from predicates.registration.partition import run as pr

    args = CASES["sphere"](2)
    ref = predicates.intersect(*args)
    # a cluster with distributed's defaults first: its nannies leave
    # MALLOC_TRIM_THRESHOLD_=65536 in this process's os.environ, which would win
    from distributed import LocalCluster

    LocalCluster(n_workers=1, processes=True, dashboard_address=None).close()
    before = {k: os.environ.get(k) for k in pr.WORKER_ENV}
    assert before["MALLOC_TRIM_THRESHOLD_"] == "65536"
    with pr.client_for(2) as client:
        env = client.run(lambda: {k: os.environ.get(k) for k in pr.WORKER_ENV})
        assert all(e == pr.WORKER_ENV for e in env.values()) and len(env) == 2, env
        assert {k: os.environ.get(k) for k in pr.WORKER_ENV} == before  # restored
        assert not any(client.run(
            lambda: dask.config.get("distributed.worker.profile.enabled")).values())
        for inline in (pr.INLINE_BYTES, 0):  # 0: every slice is scattered first
            monkeypatch.setattr(pr, "INLINE_BYTES", inline)
            res = predicates.intersect(*args, partitions=3, scheduler=client)
            assert_identical(ref, res)
            assert [p["part"] for p in res.timings["partitions"]] == [0, 1, 2]
        futures = [client.submit(time.sleep, 0.4 - 0.15 * i, pure=False) for i in range(3)]
        futures = [client.submit(lambda _, i=i: i, f, pure=False)
                   for i, f in enumerate(futures)]
        assert pr._gather(futures) == [0, 1, 2]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10**6), dim=st.sampled_from([2, 3]), k=st.integers(1, 12),
       n=st.integers(1, 40), unused=st.integers(0, 5))
def test_halos_are_the_definition(seed, dim, k, n, unused):
    """partition_slices.halos: partition r's halo is every cell sharing a vertex with a
    cell of r (its own cells included), ascending — checked cell by cell with sets, on
    random cells (repeated vertices, points in no cell, partitions with no cell)."""
    from predicates.registration.partition.slices import halos

    rng = np.random.default_rng(seed)
    C = rng.integers(0, n, size=(int(rng.integers(1, 60)), dim + 1))
    part = rng.integers(0, k, size=len(C))
    ids, starts = halos(C, part, k, n + unused)
    assert starts[0] == 0 and starts[-1] == len(ids) and len(starts) == k + 1
    verts = [set(c) for c in C.tolist()]
    for r in range(k):
        mine = set().union(*(verts[i] for i in np.flatnonzero(part == r)))
        want = [i for i, v in enumerate(verts) if v & mine]
        assert ids[starts[r]: starts[r + 1]].tolist() == want


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10**6), k=st.integers(2, 40), pad=st.sampled_from([0.0, 0.02, 0.3]))
def test_every_partition_gets_the_cutting_cells_within_reach(seed, k, pad):
    """Each Part holds its owned cells' halo (the old per-partition definition: every
    cell with a vertex of an owned cell) and every cutting cell within pad of a halo
    cell (brute force, the broad phase's float test), for many partitions of a
    rotated sphere case."""
    from predicates.registration.spatial.broadphase import box_pairs_bruteforce
    from predicates.registration.levels.complex import any_flagged

    sp, sc, cp, cc = CASES["sphere"](seed)
    pos, _ = assign(sp, sc, k)
    Y = cp[cc]
    for p in split(sp, sc, cp, cc, k, pad=pad):
        own = np.flatnonzero(pos * k // len(sc) == p.index)
        touched = np.zeros(len(sp), dtype=bool)
        touched[sc[own].ravel()] = True
        halo = sc[any_flagged(touched, sc)]
        assert np.array_equal(p.sim_ids[p.sim_cells], halo)
        Xp = sp[halo]
        _, ib = box_pairs_bruteforce(Xp.min(axis=1), Xp.max(axis=1), Y.min(axis=1),
                                     Y.max(axis=1), pad)
        held = {tuple(c) for c in p.cut_ids[p.cut_cells].tolist()}
        assert {tuple(c) for c in cc[np.unique(ib)].tolist()} <= held
        assert np.all(np.diff(p.cut_ids) > 0) and np.all(np.diff(p.sim_ids) > 0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), k=st.integers(1, 40), pad=st.sampled_from([0.0, 0.02, 0.3]),
       dim=st.sampled_from([2, 3]))
def test_cutting_slices_cut_in_the_tasks_are_the_clients(seed, k, pad, dim):
    """On a Client the tasks cut their own cutting slices from the cutting mesh sent
    once (CutSide, pickled as it travels to a worker): every Part equals, array by
    array, the one the client cuts; the parts the client leaves whole (no cutting
    cell's wide box meets the halo's bounding box) are exactly empty slices — also
    when the task cuts it with the compiled passes (a compiled run's task)."""
    import pickle

    from predicates import compiled
    from predicates.registration.partition.assign import CutSide, cut_slice
    from predicates.registration.spatial.blocks import SERIAL, Blocks

    sp, sc, cp, cc = CASES["sphere" if dim == 3 else "circle"](seed)
    want = list(split(sp, sc, cp, cc, k, pad=pad))
    got = list(split(sp, sc, cp, cc, k, pad=pad, cut_in_task=True))
    assert [p.index for p in got] == [p.index for p in want]
    ways = [SERIAL] + ([Blocks(accelerate=True)] if compiled.available() else [])
    for blocks in ways:
        side = pickle.loads(pickle.dumps(CutSide(cp, cc, pad)))
        for p, q in zip(got, want):
            if not p.cut_pending:
                assert len(q.cut_cells) == 0 and len(p.cut_cells) == 0
            p = cut_slice(p, side, blocks)
            assert not p.cut_pending
            for name in ("P_sim", "sim_cells", "sim_ids", "own_vertex", "P_cut",
                         "cut_cells", "cut_ids"):
                a, b = getattr(p, name), getattr(q, name)
                assert a.dtype == b.dtype and a.shape == b.shape and \
                    a.tobytes() == b.tobytes()


def test_parts_far_from_the_cut_run_no_task_on_a_client():
    """Partitions of every simulation cell with a cut in one corner (as
    test_partitions_without_cutting_cells_are_skipped): on a Client those whose halo
    misses the cutting cells' wide hull are left out before any task, the others cut
    their slices in the task; the merged pairs are the serial ones."""
    from predicates.registration import pipeline
    from predicates.registration.partition.run import client_for, run_partitioned

    sp, sc, cp, cc = _corner_cut()
    ref = predicates.intersect(sp, sc, cp, cc)
    plan = pipeline._plan((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True,
                          {}, None, None)
    plan = plan._replace(sim_cells=sc)  # every cell, not only those that can meet
    pad = max(plan.scale.reach.values())
    k = 16
    sent = [p.cut_pending for p in split(plan.P_sim, sc, plan.P_cut, plan.cut_cells, k, pad,
                                         cut_in_task=True)]
    assert any(sent) and not all(sent)
    with client_for(2) as client:
        timings = {}
        pairs = run_partitioned(plan, k, client, pipeline.CHUNK, timings)
    assert len(timings["partitions"]) == sum(sent)  # a task for each part sent
    # the cutting mesh went to the workers once, its ids as int32
    assert timings["cut_side_bytes"] == plan.P_cut.nbytes + 4 * plan.cut_cells.size
    for kind in ref.kinds:
        for name in ("sim", "cut", "sim_weights", "cut_weights"):
            assert getattr(pairs[kind], name).tobytes() == getattr(ref[kind], name).tobytes()


def test_cli_per_partition_files(tmp_path):
    """fperr intersect --workers N -o 'hits_{part}.vtu': one file per partition of the
    run, together the serial run's points with every data array and each with the kind
    legend; refused before any work without a partitioned run or with a bad name, and
    after the run (nothing written) when a file would overwrite an input."""
    sp, sc, cp, cc = CASES["sphere"]()
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sp, [("tetra", sc)]).write(sim)
    meshio.Mesh(cp, [("triangle", cc)]).write(cut)
    serial = tmp_path / "serial.vtu"
    assert _cli("intersect", str(sim), str(cut), "-o", str(serial), "--quiet").returncode == 0
    whole = meshio.read(serial)
    out = tmp_path / "out"
    out.mkdir()
    r = _cli("intersect", str(sim), str(cut), "-o", str(out / "hits_{part}.vtu"),
             "--workers", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    files = sorted(out.iterdir())
    assert [f.name for f in files] == ["hits_0.vtu", "hits_1.vtu"]  # auto: 2 partitions
    assert f"{len(whole.points)} points in 2 files" in r.stdout
    back = [meshio.read(f) for f in files]
    for key in whole.point_data:
        got = np.concatenate([b.point_data[key] for b in back])
        assert sorted(map(repr, got.tolist())) == \
            sorted(map(repr, whole.point_data[key].tolist())), key
    for b in back:
        assert set(b.field_data) == set(whole.field_data)
    # --partitions K: K files (each pair in exactly one), the same points in all
    three = tmp_path / "three"
    three.mkdir()
    r = _cli("intersect", str(sim), str(cut), "-o", str(three / "h_{part}.vtu"),
             "--workers", "2", "--partitions", "3", "--quiet")
    assert r.returncode == 0 and "partitions: 3 tasks" in r.stdout, r.stderr
    got = np.concatenate([meshio.read(three / f"h_{i}.vtu").points for i in range(3)])
    assert sorted(map(tuple, got.tolist())) == sorted(map(tuple, whole.points.tolist()))
    assert sorted(f.name for f in three.iterdir()) == ["h_0.vtu", "h_1.vtu", "h_2.vtu"]
    for argv, text in ((["--partitions", "3"], "--partitions is for a partitioned run"),
                       (["--workers", "2", "--partitions", "0"], "at least 1, got 0"),
                       (["--workers", "2", "--partitions", "many"], "not an integer")):
        r = _cli("intersect", str(sim), str(cut), *argv, "--quiet")
        assert r.returncode == 2 and text in r.stderr, r.stderr
    # refused before any work: no partitioned run, a name meshio would not keep data in
    for name, argv, text in (("new_{part}.vtu", [], "give --workers or --scheduler"),
                             ("new_{part}.txt", ["--workers", "2"], "written as"),
                             ("new_{part}_{y}.vtu", ["--workers", "2"], "braces")):
        r = _cli("intersect", str(sim), str(cut), "-o", str(out / name), *argv)
        assert r.returncode == 2 and text in r.stderr, r.stderr
    # partition 1's file would be the simulation mesh itself: refused, nothing written
    own = out / "mesh_1.vtu"
    own.write_bytes(sim.read_bytes())
    r = _cli("intersect", str(own), str(cut), "-o", str(out / "mesh_{part}.vtu"),
             "--workers", "2", "--quiet")
    assert r.returncode == 2 and "refusing to overwrite" in r.stderr, r.stderr
    assert own.read_bytes() == sim.read_bytes() and not (out / "mesh_0.vtu").exists()
    assert len(list(out.iterdir())) == 3


def _rows(path):
    """The intersection points of a written .vtu as sorted rows (kind, coordinates,
    weights): independent of the vertex numbering."""
    m = meshio.read(path)
    d = m.point_data
    cols = [d["kind"].reshape(len(m.points), -1), m.points, d["sim_weights"],
            d["cut_weights"]]
    return sorted(map(tuple, np.hstack([np.asarray(c, dtype=np.float64) for c in cols]).tolist()))


def test_cli_reads_a_mesh_in_pieces(tmp_path):
    """fperr intersect PIECE... CUT: the pieces of one simulation mesh (each with its
    own copy of the shared boundary points) read as that mesh — the same intersection
    points, kinds and weights as the whole file, serial and on workers; a piece of
    another dimension, a missing piece, or an output naming a piece: exit 2, nothing
    written."""
    sp, sc, cp, cc = CASES["sphere"](4)
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sp, [("tetra", sc)]).write(sim)
    meshio.Mesh(cp, [("triangle", cc)]).write(cut)
    pieces = []
    for r, rows in enumerate(np.array_split(np.arange(len(sc)), 3)):
        ids, local = np.unique(sc[rows], return_inverse=True)
        pieces.append(str(tmp_path / f"piece{r}.vtu"))
        meshio.Mesh(sp[ids], [("tetra", local.reshape(-1, 4))]).write(pieces[-1])
    whole = tmp_path / "whole.vtu"
    assert _cli("intersect", str(sim), str(cut), "-o", str(whole), "--quiet").returncode == 0
    for extra, name in (([], "p.vtu"), (["--workers", "2"], "pw.vtu")):
        r = _cli("intersect", *pieces, str(cut), "-o", str(tmp_path / name), "--quiet", *extra)
        assert r.returncode == 0, r.stderr
        assert "3 pieces read as one mesh" in r.stdout
        assert _rows(tmp_path / name) == _rows(whole)
    flat = tmp_path / "flat.vtu"  # a 2D triangle mesh among tetrahedral pieces
    meshio.Mesh(np.array([[0, 0], [1, 0], [0, 1.0]]), [("triangle", np.array([[0, 1, 2]]))]
                ).write(flat)
    out = tmp_path / "never.vtu"
    for argv, text in (([pieces[0], str(flat)], "flat.vtu: this piece is 2D"),
                       ([pieces[0], str(tmp_path / "gone.vtu")], "gone.vtu"),
                       (pieces[:2], "names the input SIM piece 2")):
        o = pieces[1] if "SIM piece" in text else str(out)
        r = _cli("intersect", *argv, str(cut), "-o", o, "--quiet")
        assert r.returncode == 2 and text in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert not out.exists()


def test_an_address_where_no_scheduler_listens_fails_at_once(tmp_path):
    """A tcp:// scheduler address with nothing listening (a free loopback port): an
    OSError naming the address and what to do within seconds (distributed alone retries
    for its 30 s connect timeout); the CLI: exit 2, one line, nothing written."""
    import socket
    import time

    with socket.socket() as s:  # a port nothing listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    args = CASES["diagonal"]()
    t = time.perf_counter()
    with pytest.raises(OSError, match="connection refused: no Dask scheduler listens"):
        predicates.intersect(*args, partitions=2, scheduler=address)
    assert time.perf_counter() - t < 10
    with pytest.raises(ValueError, match="needs a port"):
        predicates.intersect(*args, partitions=2, scheduler="tcp://127.0.0.1")
    sp, sc, cp, cc = CASES["sphere"]()
    sim, cut, out = tmp_path / "sim.vtu", tmp_path / "cut.vtu", tmp_path / "out.vtu"
    meshio.Mesh(sp, [("tetra", sc)]).write(sim)
    meshio.Mesh(cp, [("triangle", cc)]).write(cut)
    t = time.perf_counter()
    r = _cli("intersect", str(sim), str(cut), "-o", str(out), "--scheduler", address)
    assert r.returncode == 2 and "connection refused" in r.stderr and not out.exists()
    assert "Traceback" not in r.stderr and time.perf_counter() - t < 20


@pytest.mark.parametrize("name,rotate", [("corner", None), ("sphere", 3), ("circle", 2)])
def test_partitioned_plan_keeps_only_the_run_vertices(name, rotate):
    """A partitioned run's plan (a scheduler given) holds the scaled coordinates of the
    run cells' vertices only (docs/partitioned.md 6): ``sim_vertex_ids`` are exactly the
    vertices of the serial plan's run cells, ascending; its ``P_sim`` rows are the
    serial plan's rows of those vertices bit for bit, and its run cells map back to the
    serial run cells; every global quantity is the serial plan's."""
    from predicates.registration import pipeline

    sp, sc, cp, cc = _corner_cut() if name == "corner" else CASES[name](rotate)
    args = ((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True, {}, None, None)
    ref = pipeline._plan(*args)
    got = pipeline._plan(*args, scheduler="synchronous")
    assert ref.sim_vertex_ids is None
    ids = got.sim_vertex_ids
    assert np.array_equal(ids, np.unique(ref.sim_cells))  # ascending, no others
    assert got.P_sim.dtype == ref.P_sim.dtype and len(got.P_sim) == len(ids)
    assert got.P_sim.tobytes() == ref.P_sim[ids].tobytes()
    assert got.sim_cells.dtype == np.int32
    assert np.array_equal(ids[got.sim_cells], ref.sim_cells)
    if name == "corner":
        assert len(ids) < len(sp) // 4  # most points are not kept
    for field in ("L_a", "L_b", "e", "reach", "pad", "history"):
        assert getattr(got.scale, field) == getattr(ref.scale, field), field
    assert got.report.to_dict() == ref.report.to_dict()
    assert got.cut_cells.tobytes() == ref.cut_cells.tobytes()


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_scaling_only_kept_rows_refuses_as_every_point(dtype):
    """``scale_points(..., keep)`` (the partitioned plan's: only the run's vertices
    returned) refuses exactly what scaling every point refuses, with the same message —
    a point outside ``keep`` that overflows, or that loses bits to underflow, and the
    overflow first when both occur — and returns the rows ``keep`` bit for bit."""
    from predicates.registration.plan.inputs import scale_points

    rng = np.random.default_rng(7)
    big, tiny = np.finfo(dtype).max / 4, np.finfo(dtype).smallest_subnormal
    base = rng.uniform(-1, 1, (200_000, 3)).astype(dtype)  # several 65,536-row blocks
    keep = np.arange(0, len(base), 3)

    def refusal(points, e, rows):
        with pytest.raises(ValueError) as err:
            scale_points(points, e, "simulation", rows)
        return str(err.value)

    for e, bad in ((-8, {150_001: big}), (1, {100_000: tiny}),
                   (-8, {70_001: tiny, 199_999: big})):
        pts = base.copy()
        for row, value in bad.items():
            pts[row, 1] = value
        assert all(row not in set(keep.tolist()) for row in bad)
        whole = refusal(pts, e, None)
        assert refusal(pts, e, keep) == whole
        assert ("too large" in whole) == (big in bad.values())
    for e in (-3, 0, 5):
        out = scale_points(base, e, "simulation", keep)
        assert out.tobytes() == scale_points(base, e, "simulation")[keep].tobytes()
        assert np.array_equal(out.astype(np.float64) * 2.0 ** e, base[keep])
