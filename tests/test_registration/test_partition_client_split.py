"""The split's boundary keys selected on the client (partition/split_remote.
local_boundaries, compiled/mortoncodes.py): the Morton codes and the keys the rounds
of tasks over the chunks find (benchmarks/README.md "The 2-worker W4 client, seventh
pass")."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates import compiled

pytestmark = pytest.mark.skipif(not compiled.available(), reason="numba not installed")


def _points(rng, n: int, d: int, dtype, repeats: bool):
    P = rng.standard_normal((n, d)) * float(rng.choice([1.0, 1e-3, 1e5]))
    if repeats:  # coincident points and equal coordinates: equal codes
        P[rng.random(n) < 0.3] = P[0]
        P[rng.random((n, d)) < 0.2] = 0.0
    return P.astype(dtype)


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]),
       st.sampled_from([np.float64, np.float32]), st.integers(-30, 30),
       st.sampled_from(["hull", "inside", "wide", "flat"]), st.booleans())
def test_first_codes_are_morton_codes(seed, d, dtype, e, box, repeats):
    """first_codes = assign.morton_codes of the scaled first vertices (times_pow2, then
    binary64), for the run's box, a box inside it (codes clipped at both ends), a wider
    one and a flat axis (span 1), int32 and int64 ids."""
    from predicates.compiled.mortoncodes import first_codes
    from predicates.registration.partition.assign import morton_codes
    from predicates.registration.plan.scaling import times_pow2

    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 200)), int(rng.integers(1, 300))
    P = _points(rng, n, d, dtype, repeats)
    run = rng.integers(0, n, size=(m, d + 1)).astype(rng.choice([np.int32, np.int64]))
    first = np.ascontiguousarray(times_pow2(P[run[:, 0]], -e).astype(np.float64).T)
    lo, hi = first.min(axis=1), first.max(axis=1)
    if box == "inside":
        lo, hi = lo + (hi - lo) * 0.3, hi - (hi - lo) * 0.2
    elif box == "wide":
        lo, hi = lo - 1.0, hi * 3 + 1.0
    elif box == "flat":
        hi = hi.copy()
        hi[0] = lo[0]
    want = morton_codes(first, lo[:, None], hi[:, None])
    got = np.empty(m, dtype=np.uint64)
    first_codes(P, run, P.dtype.type(2.0 ** -e), lo, np.where(hi > lo, hi - lo, 1.0), got)
    np.testing.assert_array_equal(got, want)


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]), st.integers(1, 9),
       st.integers(1, 6), st.sampled_from([np.float64, np.float32]), st.booleans())
def test_local_boundaries_are_the_selected_keys(seed, d, k, chunks, dtype, repeats):
    """local_boundaries = select_boundaries over the chunks' codes (the rounds of
    tasks' keys, None past the last run cell), with ties of equal codes broken by the
    global cell index, k up to more than the run cells."""
    from predicates.registration.partition.assign import morton_codes
    from predicates.registration.partition.run_arrays import DeferredRun
    from predicates.registration.partition.split_keys import (
        ChunkRun, answer, select_boundaries)
    from predicates.registration.partition.split_remote import local_boundaries, run_hull
    from predicates.registration.plan.scaling import times_pow2

    rng = np.random.default_rng(seed)
    n, cells = int(rng.integers(1, 120)), int(rng.integers(1, 400))
    P = _points(rng, n, d, dtype, repeats)
    C = rng.integers(0, n, size=(cells, d + 1))
    mask = rng.random(cells) < float(rng.choice([0.05, 0.5, 1.0]))
    mask[rng.integers(0, cells)] = True
    e = int(rng.integers(-5, 5))
    deferred = DeferredRun(P, C[mask], e, True)
    lo, hi, m = run_hull(deferred)
    bits = 63 if d == 3 else 62
    rows = np.flatnonzero(mask)
    first = times_pow2(P[C[rows, 0]], -e).astype(np.float64).T
    codes = morton_codes(first, lo[:, None], hi[:, None])
    cut = np.sort(rng.integers(0, m + 1, size=chunks - 1))
    runs = [ChunkRun(rows[a:b], None, None, None, None, None, codes[a:b])
            for a, b in zip([0, *cut], [*cut, m])]
    want = select_boundaries(lambda q: [answer(r, bits, q) for r in runs], m, k, bits)
    assert local_boundaries(deferred, mask, lo, hi, k) == want


def test_local_boundaries_decline_without_a_compiled_deferred_run():
    """The numpy path and plans without a DeferredRun keep the rounds (None)."""
    from predicates.registration.partition.run_arrays import DeferredRun
    from predicates.registration.partition.split_remote import local_boundaries

    P, C = np.zeros((4, 3)), np.zeros((2, 4), dtype=np.int64)
    lo, hi, mask = np.zeros(3), np.ones(3), np.ones(2, bool)
    assert local_boundaries(DeferredRun(P, C, 0, False), mask, lo, hi, 2) is None
    assert local_boundaries(None, mask, lo, hi, 2) is None
    assert local_boundaries(DeferredRun(P, C, 0, True), mask, lo, hi, 2) is not None


def test_the_split_on_a_cluster_with_either_selection():
    """On a LocalCluster with the cells on the workers: compiled, the client selects
    the boundaries (no selection round); numpy, the rounds do; the serial result
    either way, k from 1 to more than the partitions with cells."""
    distributed = pytest.importorskip("distributed")
    import predicates
    from same_result import assert_identical, chunked_cells, rotated_case

    sp, sc, cp, cc = rotated_case("sphere", 6, angle=3, subdivisions=2)
    cells = chunked_cells(sc, np.random.default_rng(3), 3)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        for accelerate in (True, False):
            ref = predicates.intersect(sp, sc, cp, cc, accelerate=accelerate)
            for k in (1, 3, 40):
                res = predicates.intersect(sp, cells, cp, cc, partitions=k,
                                           scheduler=client, accelerate=accelerate)
                assert_identical(ref, res)
                split = res.timings["split"]
                assert split["hull"] == "client"
                assert split["boundaries"] == ("client" if accelerate else "workers")
                assert (split["rounds"] == 0) == (accelerate or k == 1)


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.integers(0, 200),
       st.sampled_from([1, 3, 10, 4096]), st.booleans(), st.floats(0, 1))
def test_compiled_merge_runs_are_the_runs(seed, k, n, limit, shared, blocky):
    """assign.merge_runs compiled (``fast``: the keys joined, one loop) gives the
    Python loop's runs, its None past ``limit`` runs and its refusal of a key two
    partitions hold; int32 and int64 keys (beyond int32's range), empty partitions,
    keys in long blocks of one partition (few runs) or interleaved."""
    from predicates.registration.partition.assign import merge_runs

    rng = np.random.default_rng(seed)
    values = np.sort(rng.choice(2**40 if rng.random() < 0.3 else 10**6, size=n,
                                replace=False))
    owner = (np.repeat(rng.integers(0, k, size=max(1, n // 20 + 1)), 20)[:n]
             if rng.random() < blocky else rng.integers(0, k, size=n))
    keys = [values[owner == r] for r in range(k)]
    keys = [x.astype(np.int32) if x.size and x.max() < 2**31 and rng.random() < 0.5 else x
            for x in keys]
    if shared and k > 1 and n:  # a key held by a second partition too
        v = int(rng.choice(values))
        r = (int(owner[np.searchsorted(values, v)]) + 1) % k
        keys[r] = np.sort(np.append(keys[r], v).astype(keys[r].dtype))

    def runs(fast):
        try:
            return merge_runs(keys, limit, "pairs", fast)
        except RuntimeError as e:
            return str(e)

    want = runs(False)
    assert runs(True) == want
    if shared and k > 1 and n and limit == 4096:  # (a smaller limit may come first)
        assert isinstance(want, str) and "ownership bug" in want
