"""The split where the cells are (predicates.registration.partition.split_remote,
split_keys; docs/partitioned.md 3): with the simulation cells on the workers, the Morton
runs come from per-chunk summaries, the vertex owners from an exchange by ranges of
vertex ids, and each partition's Part is assembled by its task — the same partition per
cell as the client's Morton split, the owners of the definition, the halos of
``owner_halos``, and the serial result bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import predicates
from predicates.registration.partition import assign as assign_mod
from predicates.registration.partition.assign import Layout, assign
from predicates.registration.partition.slices import owner_halos
from predicates.registration.partition.split_keys import (
    answer, chunk_run, first_hull, partition_of, select_boundaries, with_codes)
from predicates.registration.partition import split_remote
from predicates.registration.partition.split_remote import (
    _destinations, _firsts, _owners, _route, assemble)
from predicates.registration.plan.inputs import renumbered, run_vertices, times_pow2
from same_result import assert_identical, chunked_cells as _chunked, rotated_case as _case

da = pytest.importorskip("dask.array")


def _steps(P, C, ms, cuts, e, k):
    """The split's per-chunk steps run in order here, without Dask: (each run cell's
    partition, each point's owner (−1: in no run cell), the k Parts or None)."""
    offsets = np.concatenate([[0], cuts, [len(C)]]).astype(np.int64)
    runs = [chunk_run(C[a:b], P, np.packbits(ms[a:b]), int(a), e, P.dtype, False)
            for a, b in zip(offsets[:-1], offsets[1:])]
    hulls = [first_hull(r) for r in runs]
    lo = np.min([h[0][0] for h in hulls if h[1]], axis=0)
    hi = np.max([h[0][1] for h in hulls if h[1]], axis=0)
    runs = [with_codes(r, lo, hi) for r in runs]
    bits = 63 if P.shape[1] == 3 else 62
    m = sum(h[1] for h in hulls)
    bounds_k = select_boundaries(lambda q: [answer(r, bits, q) for r in runs], m, k, bits)
    parts = [partition_of(r.codes, r.rows, bounds_k) for r in runs]
    n_chunks = len(runs)
    bounds = np.array([len(P) * j // n_chunks for j in range(n_chunks + 1)])
    firsts = [_firsts(r, p, bounds) for r, p in zip(runs, parts)]
    owners = [_owners(*[f[j] for f in firsts]) for j in range(n_chunks)]
    owner = np.full(len(P), -1, dtype=np.int64)
    for j in range(n_chunks):
        for i in range(n_chunks):
            owner[firsts[i][j][0]] = owners[j][i][0]
    routes = [_route(r, p, k, *[o[i] for o in owners]) for i, (r, p) in
              enumerate(zip(runs, parts))]
    return (np.concatenate(parts), owner,
            [assemble(r, *[g[r] for g in routes]) for r in range(k)])


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.integers(1, 40),
       st.integers(1, 6), st.sampled_from([np.float64, np.float32]))
def test_the_pieces_are_the_definitions(seed, dim, k, n_chunks, dtype):
    """Random cells (some points in none), a random run mask, random chunks and k (up
    to more than the run cells): each run cell's partition is ``assign``'s
    ``pos·k // m``; each vertex's owner is the partition of its smallest run cell;
    partition r's cells are ``owner_halos``' (every run cell with a vertex r owns) and
    its Part is the client's ``Layout.part`` with those owners, array for array."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(dim + 1, 60))
    P = (rng.normal(size=(n + 5, dim)) * 2.0 ** rng.integers(-3, 4)).astype(dtype)
    P[rng.integers(0, n + 5, size=3)] = P[0]  # repeated points: equal Morton codes
    m_all = int(rng.integers(1, 80))
    C = np.argsort(rng.random((m_all, n)), axis=1)[:, :dim + 1]
    ms = rng.random(m_all) < rng.uniform(0.2, 1.0)
    ms[rng.integers(m_all)] = True
    cuts = np.sort(rng.choice(np.arange(1, m_all), min(n_chunks, m_all) - 1,
                              replace=False)) if m_all > 1 else np.zeros(0, int)
    e = int(rng.integers(-3, 4))
    parts, owner, got = _steps(P, C, ms, cuts, e, k)
    run = C[ms]
    keep = run_vertices(run, len(P))
    P_sim, cells = times_pow2(P[keep], -e), renumbered(run, keep)
    pos, ref_owner = assign(P_sim, cells, k)
    m = len(run)
    assert np.array_equal(parts, pos * k // m)
    assert np.array_equal(owner[keep], ref_owner)
    assert np.all(owner[np.setdiff1d(np.arange(len(P)), keep)] == -1)
    halo, starts = owner_halos(cells, ref_owner, k)
    full = np.full(len(P), -1, dtype=np.int64)
    full[keep] = ref_owner
    layout = Layout(P_sim, cells, np.zeros((0, dim), dtype), np.zeros((0, dim + 1), int),
                    k, 0.0, owner=full, cut_in_task=True, vertex_ids=keep)
    owned = np.bincount(parts, minlength=k)
    for r in range(k):
        ids = halo[starts[r]:starts[r + 1]]
        if len(ids) == 0:  # owns no vertex (perhaps cells: none is its vertices' first)
            assert got[r] is None
            continue
        p, ref = got[r], layout.part(r)
        assert np.array_equal(p.sim_ids[p.sim_cells], run[ids])  # owner_halos' cells
        for name in ("P_sim", "sim_cells", "sim_ids", "own_vertex"):
            a, b = getattr(p, name), getattr(ref, name)
            assert a.dtype == b.dtype and np.array_equal(a, b), name
        assert p.owned_cells == owned[r] and p.cut_pending and p.index == r


def test_select_boundaries_takes_several_rounds_and_ties():
    """Codes that share their top bits (a prefix of more than FETCH cells) and equal
    codes with different cell indices: the boundaries are the keys at ⌈r·m/k⌉ of the
    stable order, as a sort of every key gives them."""
    rng = np.random.default_rng(7)
    m, bits = 20000, 63
    codes = (np.uint64(5) << np.uint64(58)) | rng.integers(0, 40, size=m).astype(np.uint64)
    codes[::3] = np.uint64(1) << np.uint64(40)
    rows = np.arange(m, dtype=np.int64) * 2 + 1

    class Run:  # two chunks' (codes, rows)
        def __init__(self, sl):
            self.codes, self.rows = codes[sl], rows[sl]

    runs, calls = [Run(slice(0, 7000)), Run(slice(7000, m))], []

    def ask(queries):
        calls.append(queries)
        return [answer(r, bits, queries) for r in runs]

    for k in (2, 7, 64):
        got = select_boundaries(ask, m, k, bits)
        order = np.lexsort((rows, codes))
        want = [(int(codes[order[-(-r * m // k)]]), int(rows[order[-(-r * m // k)]]))
                for r in range(1, k)]
        assert got == want
        parts = partition_of(codes, rows, got)
        pos = np.empty(m, np.int64)
        pos[order] = np.arange(m)
        assert np.array_equal(parts, pos * k // m)
    assert max(len(c) for c in calls) >= 1 and len(calls) >= 6  # several rounds each


def _no_client_split(monkeypatch):
    """The client-side split (Layout, its Parts) refused: the run must not use it."""
    def refuse(*a, **kw):
        raise AssertionError("the client built a Part")

    monkeypatch.setattr(assign_mod.Layout, "__init__", refuse)
    monkeypatch.setattr(assign_mod.Layout, "part", refuse)


def test_processes_and_a_cluster_send_no_part(monkeypatch):
    """On "processes" and a LocalCluster the client builds no Layout and no Part (both
    refused here), its graph's own bytes are the run mask's bits (1 per cell) plus
    O(k), and the result is the serial one; far partitions and k near the cell count
    included."""
    distributed = pytest.importorskip("distributed")
    _no_client_split(monkeypatch)
    sp, sc, cp, cc = _case("sphere", 6, angle=3, subdivisions=2)
    ref = predicates.intersect(sp, sc, cp, cc)
    cells = _chunked(sc, np.random.default_rng(1), 5)
    res = predicates.intersect(sp, cells, cp, cc, partitions=3, scheduler="processes")
    assert_identical(ref, res)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        for k in (1, 4, 40):
            res = predicates.intersect(sp, cells, cp, cc, partitions=k, scheduler=client)
            assert_identical(ref, res)
            split = res.timings["split"]
            mask_bytes = sum(-(-c // 8) for c in cells.chunks[0])
            assert split["where"] == "workers" and split["hull"] == "client"
            assert split["sent_bytes"] <= mask_bytes + 16 * k + 64 * (split["chunks"] + 1)


def _pieces(tmp_path, sp, sc, rng, count: int):
    """The mesh in ``count`` .vtu pieces of random cells with their global point ids
    (each piece's points in a random order); the cells in the pieces' order."""
    import meshio

    from predicates.registration.partition.pieces import GLOBAL_IDS

    order = rng.permutation(len(sc))
    cuts = np.sort(rng.choice(np.arange(1, len(sc)), count - 1, replace=False))
    paths = []
    for i, rows in enumerate(np.split(order, cuts)):
        ids = rng.permutation(np.unique(sc[rows])).astype(np.int64)
        local = np.empty(len(sp), dtype=np.int64)
        local[ids] = np.arange(len(ids))
        paths.append(tmp_path / f"piece{i}.vtu")
        meshio.Mesh(sp[ids], [("tetra", local[sc[rows]])],
                    point_data={GLOBAL_IDS: ids}).write(paths[-1])
    return paths, sc[order]


@pytest.mark.filterwarnings("ignore::fperr.ResolutionWarning")  # float32 is coarse here
def test_pieces_on_a_cluster_split_on_the_workers(tmp_path, monkeypatch):
    """Pieces read by the workers (their points on the workers too): the split runs
    where they are — no Layout, no Part from the client — and the result is the serial
    run's on the same mesh, in float64 and float32, for several k."""
    distributed = pytest.importorskip("distributed")
    from predicates.registration.partition.pieces import read_pieces_on_workers

    _no_client_split(monkeypatch)
    sp, sc, cp, cc = _case("sphere", 6, angle=2, subdivisions=2)
    paths, cells = _pieces(tmp_path, sp, sc, np.random.default_rng(3), 4)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        got = read_pieces_on_workers(paths, client)
        for dtype, k in ((np.float64, 3), (np.float32, 5), (np.float64, 1)):
            ref = predicates.intersect(sp, cells, cp, cc, dtype=dtype)
            res = predicates.intersect(got.points, got.cells, cp, cc, dtype=dtype,
                                       partitions=k, scheduler=client)
            assert_identical(ref, res)
            assert res.timings["split"]["where"] == "workers"


def test_timeout_covers_the_split_on_the_workers(monkeypatch):
    """A split whose selection rounds outlast ``timeout`` (its first round held up on
    the workers: since the Morton box comes from the client, ``split_remote.run_hull``,
    the first round is a selection round's answers): PartitionError naming the split,
    raised at the timeout, not when the round ends; the same cluster then runs
    normally, identical to the serial run."""
    import time

    distributed = pytest.importorskip("distributed")
    from predicates.registration.partition import split_remote
    from predicates.registration.partition.run import PartitionError

    sp, sc, cp, cc = _case("sphere", 6, angle=3, subdivisions=2)
    ref = predicates.intersect(sp, sc, cp, cc)
    cells = _chunked(sc, np.random.default_rng(2), 3)
    answer = split_remote.answer

    def slow(run, *args):
        time.sleep(5)
        return answer(run, *args)

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        monkeypatch.setattr(split_remote, "answer", slow)
        t = time.perf_counter()
        with pytest.raises(PartitionError, match=r"the split on the workers did not finish "
                                                 r"within the timeout of 0.5 s"):
            predicates.intersect(sp, cells, cp, cc, partitions=2, scheduler=client,
                                 timeout=0.5)
        assert time.perf_counter() - t < 4.5
        monkeypatch.setattr(split_remote, "answer", answer)
        res = predicates.intersect(sp, cells, cp, cc, partitions=2, scheduler=client,
                                   timeout=60)
        assert_identical(ref, res)
        assert res.timings["split"]["where"] == "workers"


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(0, 300),
       st.integers(2, 4), st.floats(0, 1))
def test_destinations_direct_and_sorted_agree(seed, k, m, width, mixed):
    """A partition's cells are those with a vertex it owns, ascending: the per-partition
    pass (k up to DIRECT_K) gives the sorted keys' ids and starts, against the
    definition, for cells with one owner and cells with several."""
    rng = np.random.default_rng(seed)
    owners = np.repeat(rng.integers(0, k, (m, 1)), width, axis=1)
    mix = rng.random(m) < mixed
    owners[mix] = rng.integers(0, k, (int(mix.sum()), width))
    direct = _destinations(owners, k) if k <= split_remote.DIRECT_K else None
    saved = split_remote.DIRECT_K
    split_remote.DIRECT_K = 0
    try:
        ids, starts = _destinations(owners, k)
    finally:
        split_remote.DIRECT_K = saved
    for r in range(k):
        want = np.flatnonzero((owners == r).any(axis=1))
        np.testing.assert_array_equal(ids[starts[r]:starts[r + 1]], want)
    if direct is not None:
        np.testing.assert_array_equal(direct[0], ids)
        np.testing.assert_array_equal(direct[1], starts)


def test_each_worker_computes_the_cutting_sides_boxes_once_before_its_tasks():
    """warm_side: a task per worker computes the scattered CutSide's wide boxes on that
    worker's copy (kept with it, where the partition tasks read them: cut_slice), equal
    to the boxes computed here; settled_side records each task's CPU seconds."""
    import operator

    distributed = pytest.importorskip("distributed")
    from predicates.registration.examples import icosphere
    from predicates.registration.partition.assign import CutSide

    cp, cc = icosphere(2)
    want = CutSide(cp, cc, 0.0625).boxes()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        client.wait_for_workers(2)  # (and the client's view of them refreshed)
        side = client.scatter(CutSide(cp, cc, 0.0625), hash=False, broadcast=True)
        kept = operator.attrgetter("_boxes")
        workers = list(client.scheduler_info()["workers"])
        assert all(client.submit(kept, side, workers=[w], pure=False).result() is None
                   for w in workers)  # not computed where they arrive
        timings = {"split": {"side_boxes": split_remote.warm_side(client, side, True)}}
        distributed.wait(timings["split"]["side_boxes"])
        split_remote.settled_side(timings)
        assert len(timings["split"]["side_boxes"]) == len(workers) == 2
        assert all(t >= 0 for t in timings["split"]["side_boxes"])
        # a worker's copy may be replaced by Dask after the task (seen once in eight
        # fresh clusters after the probe above: the object's id changed); its partition
        # task then computes the boxes itself, the same values — so: kept on some
        # worker, equal wherever
        got = [client.submit(kept, side, workers=[w], pure=False).result() for w in workers]
        assert any(g is not None for g in got)
        for g in got:
            for a, b in zip(g or want, want):
                np.testing.assert_array_equal(a, b)
