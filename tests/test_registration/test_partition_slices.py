"""The cutting slices (docs/partitioned.md 3, :func:`predicates.registration.partition.
slices.cut_near`) against the serial result: every partition's task holds every cutting
cell containing the cutting primitive of a pair it owns, on the client's split and on
the split where the cells are (each task cutting its slice from the ``CutSide``)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import predicates
from same_result import assert_identical, chunked_cells, rotated_case as case

dask = pytest.importorskip("dask")

CASES = {
    "sphere": lambda r: case("sphere", 4, r, subdivisions=1),
    "circle": lambda r: case("circle", 8, r, segments=24),
    "plane_offset": lambda r: case("plane_offset", 4, r),
}


def _recorded_parts(monkeypatch, sp, sc, cp, cc, k: int, remote: bool):
    """The Parts the k tasks ran (their cutting slices cut) and the result."""
    from predicates.registration.partition import run, split_remote, task

    parts = []

    def recording(part, *args, **kw):
        got = task.run_part(part, *args, **kw)
        parts.append(part if not part.cut_pending else None)
        return got

    monkeypatch.setattr(run, "run_part", recording)
    monkeypatch.setattr(split_remote, "run_part", recording)
    cells = chunked_cells(sc, np.random.default_rng(k), 3) if remote else sc
    res = predicates.intersect(sp, cells, cp, cc, partitions=k, scheduler="synchronous")
    assert parts and all(p is not None for p in parts)  # each slice cut before the run
    return parts, res


def _cells_holding(cells: np.ndarray, prims: np.ndarray) -> np.ndarray:
    """Per cell of ``cells``: does it contain one of the primitives ``prims`` (rows of
    vertex ids)? Brute force over the (small) case."""
    hold = np.zeros(len(cells), dtype=bool)
    for prim in np.unique(np.sort(prims, axis=1), axis=0):
        hold |= np.all([np.any(cells == v, axis=1) for v in prim], axis=0)
    return hold


@settings(max_examples=20, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(list(CASES)), seed=st.integers(0, 10**6), k=st.integers(2, 24),
       remote=st.booleans())
def test_each_slice_holds_the_cutting_cells_of_its_owned_pairs(monkeypatch, name, seed, k,
                                                              remote):
    """For every pair of the serial result, the partition owning its smallest
    simulation vertex ran a slice holding every cutting cell that contains the pair's
    cutting primitive (each such cell's box is within reach of the pair's simulation
    cell: docs/partitioned.md 4), and the partitioned result is the serial one."""
    sp, sc, cp, cc = CASES[name](seed)
    ref = predicates.intersect(sp, sc, cp, cc)
    parts, res = _recorded_parts(monkeypatch, sp, sc, cp, cc, k, remote)
    cut_cells = np.asarray(ref.cut_cells)  # the refined cutting mesh the ids refer to
    owner = np.full(len(sp), -1)
    for p in parts:
        owner[p.sim_ids[p.own_vertex]] = p.index
    checked = 0
    for kind in ref.kinds:
        pairs = ref[kind]
        if not len(pairs):
            continue
        first = pairs.sim.min(axis=1)
        assert np.all(owner[first] >= 0)  # every pair's vertex is owned by a task run
        for p in parts:
            mine = owner[first] == p.index
            if not mine.any():
                continue
            need = cut_cells[_cells_holding(cut_cells, pairs.cut[mine])]
            held = {tuple(c) for c in np.sort(p.cut_ids[p.cut_cells], axis=1).tolist()}
            assert {tuple(c) for c in np.sort(need, axis=1).tolist()} <= held
            checked += int(mine.sum())
    assert checked == sum(len(ref[kind]) for kind in ref.kinds) > 0
    assert_identical(ref, res)
