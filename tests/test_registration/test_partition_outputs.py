"""Per-partition files written by the workers (predicates.registration.partition.outputs;
docs/partitioned.md 6): each partition's task writes its own file, byte for byte the
file the client writes from the merged serial result (``write_parts``), the run's result
stays the serial one, and a refused or failed run leaves no file (staged names removed)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from predicates.registration.partition.files import write_parts
from predicates.registration.partition.outputs import PartFiles

from same_result import assert_identical, rotated_case

dask = pytest.importorskip("dask")
ROOT = Path(__file__).resolve().parents[2]


def coarse_cut():
    """A 6^3 grid cut by a tilted plane of two triangles much larger than its cells:
    the cutting mesh is refined, so the files carry ``cut_input_*`` data too."""
    sp, sc = example("plane", 6)["sim"]
    cp = np.array([[-0.1, -0.1, 0.37], [1.1, -0.1, 0.41], [-0.1, 1.1, 0.39],
                   [1.1, 1.1, 0.43]])
    return sp, np.asarray(sc), cp, np.array([[0, 1, 2], [1, 3, 2]])


CASES = {
    "sphere": lambda: rotated_case("sphere", 4, 3, subdivisions=1),
    "circle": lambda: rotated_case("circle", 8, 5, segments=24),
    "plane": lambda: rotated_case("plane", 4),  # through grid vertices
    "coarse_cut": coarse_cut,
}


def same_files(ref, k: int, pattern: Path) -> None:
    """Files ``pattern`` (with {part}) are byte for byte what ``write_parts`` writes for
    the serial result ``ref``; no staged (hidden) file is left beside them."""
    want = write_parts(ref, k, str(pattern.parent / ("client_" + pattern.name)))
    for r, path in enumerate(want):
        got = Path(str(pattern).format(part=r))
        assert got.read_bytes() == Path(path).read_bytes(), (r, got)
    assert not [f.name for f in pattern.parent.iterdir() if f.name.startswith(".")]


@pytest.mark.parametrize("sched", ["synchronous", "threads", "processes"])
@pytest.mark.parametrize("name,k", [("sphere", 1), ("sphere", 5), ("circle", 3),
                                    ("plane", 7), ("coarse_cut", 4)])
def test_worker_files_are_the_clients_files(tmp_path, name, k, sched):
    args = CASES[name]()
    ref = predicates.intersect(*args)
    assert name != "coarse_cut" or ref.cut_refined
    pattern = tmp_path / "hits_{part}.vtu"
    res = predicates.intersect(*args, partitions=PartFiles(str(pattern), k),
                               scheduler=sched)
    assert_identical(ref, res)
    assert res.timings["files"] == [str(pattern).format(part=r) for r in range(k)]
    same_files(ref, k, pattern)
    written = [p for p in res.timings["partitions"] if "file_bytes" in p]
    assert written and all(p["file_bytes"] > 0 for p in written)


@pytest.mark.parametrize("chunked", [False, True])
@pytest.mark.parametrize("cut", ["empty", "far"])
def test_runs_without_pairs_write_every_file(tmp_path, cut, chunked):
    """An empty cutting mesh, or one far from the simulation mesh (no cell can meet):
    no task runs, and the client writes the k files with the legend only — the same
    bytes as write_parts."""
    import dask.array as da

    sp, sc, cp, cc = CASES["sphere"]()
    cp, cc = (cp, cc[:0]) if cut == "empty" else (cp + 10.0, cc)
    ref = predicates.intersect(sp, sc, cp, cc)
    assert ref.total == 0
    cells = da.from_array(sc, chunks=(100, 4)) if chunked else sc
    pattern = tmp_path / "h_{part}.vtu"
    res = predicates.intersect(sp, cells, cp, cc, partitions=PartFiles(str(pattern), 3),
                               scheduler="threads")
    assert res.timings["partitions"] == []
    same_files(ref, 3, pattern)


@pytest.mark.filterwarnings("ignore::fperr.ResolutionWarning")  # float32 is coarse here
def test_random_partitionings_float32_and_naive(tmp_path):
    rng = np.random.default_rng(7)
    for trial in range(4):
        name = ["sphere", "circle", "plane"][trial % 3]
        args, k = CASES[name](), int(rng.integers(1, 12))
        options = dict(dtype=np.float32) if trial % 2 else dict(tolerance_scale=0.0)
        ref = predicates.intersect(*args, **options)
        out = tmp_path / str(trial)
        out.mkdir()
        res = predicates.intersect(*args, partitions=PartFiles(str(out / "h_{part}.vtu"), k),
                                   scheduler="threads", **options)
        assert_identical(ref, res)
        same_files(ref, k, out / "h_{part}.vtu")


def test_cells_on_the_workers_of_a_cluster(tmp_path):
    """Cells as a dask array on a distributed cluster: the files' owners are computed
    chunk by chunk there and each task writes its file; the spec is scattered once."""
    import dask.array as da
    from distributed import Client, LocalCluster

    sp, sc, cp, cc = CASES["sphere"]()
    ref = predicates.intersect(sp, sc, cp, cc)
    pattern = tmp_path / "hits_{part}.vtu"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        cells = da.from_array(sc, chunks=(len(sc) // 3 + 1, 4))
        res = predicates.intersect(sp, cells, cp, cc, scheduler=client,
                                   partitions=PartFiles(str(pattern), 4))
        assert_identical(ref, res)
    same_files(ref, 4, pattern)


@pytest.mark.parametrize("seed", range(6))
def test_owners_of_the_run_vertices_are_assigns(seed):
    """The files' owners of some vertices, ranked chunk by chunk where the cells are
    (no sort of all cells on the client), equal assign's on the whole array; -1 for the
    vertices not asked for. Grid meshes: many cells share a first vertex (equal Morton
    codes), so the (code, index) ties are exercised."""
    import dask.array as da

    from predicates.registration.partition.assign import assign
    from predicates.registration.partition.files import owners_of

    rng = np.random.default_rng(seed)
    name = ["sphere", "circle", "plane", "coarse_cut"][seed % 4]
    sp, sc = CASES[name]()[:2]
    sc = sc[rng.permutation(len(sc))]
    sizes = np.diff(np.concatenate([[0], np.sort(rng.integers(0, len(sc), 4)), [len(sc)]]))
    cells = da.from_array(sc, chunks=(tuple(sizes.tolist()), sc.shape[1]))  # some empty
    wanted = rng.random(len(sp)) < [0.05, 0.5, 1.0][seed % 3]
    for k in (1, 2, 5, 13):
        ref = np.where(wanted, assign(sp, sc, k)[1], -1)
        for given in (cells, sc):
            got = owners_of(sp, given, k, wanted, "synchronous")
            assert got.dtype == ref.dtype and np.array_equal(got, ref), (k, type(given))


def test_a_failed_partition_leaves_no_file(tmp_path, monkeypatch):
    """Partition 0 writes its staged file, partition 1 fails: the error propagates and
    no file — final or staged — is left."""
    from predicates.registration.partition import run as partition_run

    args = CASES["sphere"]()
    real = partition_run.run_part

    def fail_second(part, *a):
        if part.index == 1:
            raise RuntimeError("partition 1 failed")
        return real(part, *a)

    monkeypatch.setattr(partition_run, "run_part", fail_second)
    with pytest.raises(RuntimeError, match="partition 1 failed"):
        predicates.intersect(*args, partitions=PartFiles(str(tmp_path / "h_{part}.vtu"), 3),
                             scheduler="synchronous")
    assert list(tmp_path.iterdir()) == []


def test_a_task_that_outlives_its_run_removes_its_file(tmp_path, monkeypatch):
    """A task cannot be stopped once it runs: without the run's marker it writes
    nothing, and when the marker goes while it writes (the client abandoned the run:
    a timeout) it removes its own file."""
    from dataclasses import replace

    from predicates.registration.io import write
    from predicates.registration.partition import outputs
    from predicates.registration.partition.outputs import Staged

    args = CASES["sphere"]()
    plan_of = {}
    real_staged = outputs.Staged

    class Keep(real_staged):
        def __init__(self, *a):
            super().__init__(*a)
            plan_of["staged"] = self

    monkeypatch.setattr("predicates.registration.partition.run.Staged", Keep)
    predicates.intersect(*args, partitions=PartFiles(str(tmp_path / "h_{part}.vtu"), 2),
                         scheduler="synchronous")
    staged: Staged = plan_of["staged"]
    assert not os.path.exists(staged.spec.live)  # committed: the marker is gone too
    late = str(tmp_path / ".late.vtu")
    assert outputs.write_part(late, staged.spec, None, {}) == 0  # no marker: no file
    assert not os.path.exists(late)
    live = tmp_path / ".live"
    live.touch()
    spec = replace(staged.spec, live=str(live))
    assert outputs.write_part(late, spec, None, {}) > 0 and os.path.exists(late)
    real = write.write_meshio

    def abandoned_meanwhile(path, mesh):
        real(path, mesh)
        live.unlink()

    monkeypatch.setattr(write, "write_meshio", abandoned_meanwhile)
    os.remove(late)
    live.touch()
    assert outputs.write_part(late, spec, None, {}) == 0 and not os.path.exists(late)


def test_paths_are_checked_before_any_task(tmp_path, monkeypatch):
    from predicates.registration.partition import run as partition_run

    args = CASES["sphere"]()
    monkeypatch.setattr(partition_run, "run_part", None)  # a task would fail at once
    sim = tmp_path / "mesh_1.vtu"
    sim.write_text("the user's mesh")
    for files, text in (
            (PartFiles(str(tmp_path / "h.vtu"), 2), "must contain '{part}'"),
            (PartFiles(str(tmp_path / "h_{part}.txt"), 2), "written as"),
            (PartFiles(str(tmp_path / "no" / "h_{part}.vtu"), 2), "does not exist"),
            (PartFiles(str(tmp_path / "mesh_{part}.vtu"), 2, {"SIM": sim}),
             "refusing to overwrite"),
            (PartFiles(str(tmp_path / "h_{part}.vtu"), 2,
                       others={("--sim-output", "mesh"): tmp_path / "h_1.vtu"}), "given to both")):
        with pytest.raises(ValueError, match=text):
            predicates.intersect(*args, partitions=files, scheduler="threads")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["mesh_1.vtu"]
    assert sim.read_text() == "the user's mesh"


def _cli(*argv):
    code = "import sys; from proofs.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *argv], capture_output=True,
                          text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_cli_files_from_the_workers_equal_the_clients(tmp_path):
    """fperr intersect --workers 2 -o 'hits_{part}.vtu' on a 2D mesh stored in the plane
    z = 0.75 (the files' points go back into it) with --sim-output: exit 0, the files
    byte for byte those write_parts writes from the serial result of the same files;
    a run whose tasks cannot finish (--timeout): exit 1, no file and no staged file."""
    from predicates.registration import intersect_files

    sp, sc, cp, cc = CASES["circle"]()
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(np.column_stack([sp, np.full(len(sp), 0.75)]), [("triangle", sc)]).write(sim)
    meshio.Mesh(np.column_stack([cp, np.full(len(cp), 0.75)]), [("line", cc)]).write(cut)
    ref = intersect_files(str(sim), str(cut))
    assert ref.plane == 0.75 and ref.total > 0
    out = tmp_path / "out"
    out.mkdir()
    r = _cli("intersect", str(sim), str(cut), "-o", str(out / "hits_{part}.vtu"),
             "--sim-output", str(out / "cells.vtu"), "--workers", "2", "--partitions", "3",
             "--quiet")
    assert r.returncode == 0, r.stderr
    assert f"{ref.total} points in 3 files" in r.stdout
    assert np.all(meshio.read(out / "hits_0.vtu").points[:, 2] == 0.75)
    (out / "cells.vtu").unlink()
    same_files(ref, 3, out / "hits_{part}.vtu")

    failed = tmp_path / "failed"
    failed.mkdir()
    r = _cli("intersect", str(sim), str(cut), "-o", str(failed / "hits_{part}.vtu"),
             "--workers", "1", "--timeout", "0.001")
    assert r.returncode == 1 and "not finished after the timeout" in r.stderr, r.stderr
    assert list(failed.iterdir()) == []


@pytest.mark.parametrize("seed", range(5))
def test_owner_halos_hold_every_cell_of_an_owned_vertex(seed):
    """owner_halos against its definition: partition r's cells are exactly the cells
    with a vertex r owns, ascending — so r holds every cell containing a vertex it owns
    (section 4's lemma) whatever the owners."""
    from predicates.registration.partition.slices import owner_halos

    rng = np.random.default_rng(seed)
    sp, sc = CASES[["sphere", "circle", "plane"][seed % 3]]()[:2]
    k = int(rng.integers(1, 9))
    owner = rng.integers(0, k, len(sp))
    ids, starts = owner_halos(sc, owner, k)
    for r in range(k):
        want = np.flatnonzero((owner[sc] == r).any(axis=1))
        assert np.array_equal(ids[starts[r]:starts[r + 1]], want)
