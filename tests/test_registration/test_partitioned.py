"""Partitioned registration on Dask (predicates.registration.partition*): the result is
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
from predicates.registration.partition import assign, split

dask = pytest.importorskip("dask")
ROOT = Path(__file__).resolve().parents[2]
KS = (1, 2, 3, 7, 16)


def assert_identical(ref, res):
    """Same kinds, same pairs in the same order, bit-identical weights, same counts."""
    assert res.kinds == ref.kinds and res.counts == ref.counts
    assert res.scale_exponent == ref.scale_exponent and res.L_a == ref.L_a
    for kind in ref.kinds:
        a, b = ref[kind], res[kind]
        for x, y in ((a.sim, b.sim), (a.cut, b.cut), (a.sim_weights, b.sim_weights),
                     (a.cut_weights, b.cut_weights)):
            assert x.dtype == y.dtype and x.shape == y.shape, kind
            assert x.tobytes() == y.tobytes(), kind


def _rotation(dim, seed):
    rng = np.random.default_rng(seed)
    if dim == 2:
        a = rng.uniform(0, 2 * np.pi)
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def case(name, n, rotate=None, **kw):
    ex = example(name, n, **kw)
    (sp, sc), (cp, cc) = ex["sim"], ex["cut"]
    if rotate is not None:
        R = _rotation(ex["dim"], rotate)
        sp, cp = sp @ R.T, cp @ R.T
    return sp, sc, cp, cc


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
    from predicates.registration.broadphase import box_pairs_bruteforce

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
    from predicates.registration.partition_run import read_pieces, write_parts

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
    ids = np.concatenate([b.point_data["sim_ids"] for b in back])
    whole = ref.to_meshio().point_data["sim_ids"]
    assert sorted(map(tuple, ids.tolist())) == sorted(map(tuple, whole.tolist()))
    with pytest.raises(ValueError, match="part"):
        write_parts(ref, 3, str(tmp_path / "hits.vtu"))


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
    from predicates.registration.partition_run import DaskMissingError

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
