"""Out of memory in the serial registration after the plan (rank space, broad phase,
levels, after :func:`predicates.registration.pipeline._ranked`) is a clear refusal naming
the stage and what to do, not a bare MemoryError (docs/partitioned.md, section 2)."""
from __future__ import annotations

import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest
from capped_registration import CAPPED, capped_env

ROOT = pathlib.Path(__file__).resolve().parents[2]

LIBRARY = CAPPED + """\
import predicates
from predicates.registration.examples import cube_grid, icosphere
try:
    predicates.intersect(*cube_grid(30), *icosphere(3))
except MemoryError as e:
    print(type(e).__name__, e)
"""


def _stages() -> str:
    from predicates.catalogue import kinds

    return "|".join(["rank space", "broad phase"] + [k.name for k in kinds(3)])


def test_an_address_space_limit_in_the_registration_is_a_clear_refusal():
    """With the address space capped once the plan is done, the run ends in
    RegistrationMemoryError (a MemoryError) naming a stage of the registration, the
    cells near the cut and what to do — measured: the registration of cube 30 ×
    icosphere 3 needs tens of MiB beyond the 2 MiB left, with glibc's freed blocks
    unmapped (tests/support/capped_registration.py)."""
    r = subprocess.run([sys.executable, "-c", LIBRARY], cwd=ROOT, env=capped_env(ROOT),
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert re.fullmatch(
        rf"RegistrationMemoryError not enough memory for the registration \(({_stages()})\) "
        r"of meshes of 6 MiB, \d+ simulation and \d+ cutting cells near the cut: "
        r"partition the run .*--workers N --partitions K.* or run on a machine with more "
        r"memory \(MemoryError: .*\)\n", r.stdout), (r.stdout, r.stderr)


@pytest.mark.parametrize("where, stage", [
    (("pipeline", "Registration"), "rank space"),
    (("loop", "cell_pairs"), "broad phase"),
    (("loop.Registration", "_candidates"), "vertex_vertex"),
])
def test_out_of_memory_names_the_stage_of_the_registration(monkeypatch, where, stage):
    """The stage named is the one that ran out: the rank space, the cells' broad phase,
    or the kind being registered (accelerate=False: the numpy chain, whose kinds gather
    their candidates through ``_candidates``, vertex_vertex first). The cells near the
    plane z = 1/2: the two layers of 4² × 6 tetrahedra touching it, and the plane's 32
    triangles."""
    import predicates
    from predicates.registration import pipeline
    from predicates.registration.examples import cube_grid, grid_plane
    from predicates.registration.levels import loop

    def boom(*a, **k):
        raise MemoryError()

    owner = {"pipeline": pipeline, "loop": loop, "loop.Registration": loop.Registration}
    monkeypatch.setattr(owner[where[0]], where[1], boom)
    with pytest.raises(pipeline.RegistrationMemoryError,
                       match=rf"registration \({stage}\) of meshes of 0 MiB, 192 "
                             r"simulation and 32 cutting cells near the cut: .*"
                             r"\(MemoryError: no detail\)$"):
        predicates.intersect(*cube_grid(4), *grid_plane(4, k=2), accelerate=False)


@pytest.mark.parametrize("accelerate", [False, True])
def test_the_levels_release_what_no_later_kind_reads(monkeypatch, accelerate):
    """After each kind the face pairs keep only the boxes of the levels a later kind
    reads (and the cutting cells' while a simulation level's stage 1 is still to come)
    and no simulation owned table once no stage 1 is left; the kinds' pairs are those
    of a run that releases nothing, and no box is computed twice (none was dropped
    while a later kind needed it)."""
    from predicates import compiled
    from predicates.catalogue import kinds
    from predicates.registration.examples import cube_grid, icosphere
    from predicates.registration.levels import facepairs, loop
    from predicates.registration.pipeline import intersect

    if accelerate and not compiled.available():
        pytest.skip("the compiled chain is not installed")
    mesh = (*cube_grid(6), *icosphere(2))
    with monkeypatch.context() as m:
        m.setattr(facepairs.FacePairs, "_release", lambda self: None)
        kept = intersect(*mesh, accelerate=accelerate)
    seen, computed = [], []
    real_box = facepairs.FacePairs._box

    def box(self, side, k):
        if (side, k) not in self._boxes:
            computed.append((side, k))
        return real_box(self, side, k)
    real_level = loop.Registration._level

    def level(self, k):
        out = real_level(self, k)
        left = [q for q in kinds(3)][[q.name for q in kinds(3)].index(k.name) + 1:]
        f = self.faces
        sim_levels = {q.i for q in left}
        stage1_left = {q.i for q in left if q.i != 3 and q.i not in f._first_done}
        cut_levels = {q.j for q in left} | ({2} if stage1_left else set())
        assert {lv for side, lv in f._boxes if side == "sim"} <= sim_levels, k.name
        assert {lv for side, lv in f._boxes if side == "cut"} <= cut_levels, k.name
        assert {key[1] for key in f._tables if key[0] == "sim"} <= stage1_left, k.name
        seen.append((k.name, len(f._boxes), len(f._tables)))
        return out

    monkeypatch.setattr(loop.Registration, "_level", level)
    monkeypatch.setattr(facepairs.FacePairs, "_box", box)
    released = intersect(*mesh, accelerate=accelerate)
    assert [s[0] for s in seen] == [k.name for k in kinds(3)]
    assert seen[-1][1:] == (0, 0)  # nothing left after the last kind
    assert len(computed) == len(set(computed)), computed  # none dropped while needed
    for k in kept.kinds:
        for name in ("sim", "cut", "sim_weights", "cut_weights"):
            assert np.array_equal(getattr(kept[k], name), getattr(released[k], name)), k


def test_joined_is_concatenate_without_holding_the_blocks_twice():
    """The same values, dtype and shape as np.concatenate (also for blocks of mixed
    dtypes, 2D and empty blocks), the list emptied; ``empty`` when there is none."""
    from predicates.registration.levels.facepairs import joined

    rng = np.random.default_rng(7)
    cases = [[rng.integers(-9, 9, size=n) for n in (3, 0, 5)],
             [rng.integers(0, 5, size=4).astype(np.int32), rng.integers(0, 5, size=2)],
             [rng.random((n, 3)) for n in (2, 4, 1)]]
    for parts in cases:
        want = np.concatenate(parts)
        got = joined(list_ := list(parts), np.zeros(0))
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.array_equal(got, want) and list_ == []
    empty = np.zeros((0, 2))
    assert joined([], empty) is empty


def test_stage1_slices_are_the_blocks_of_the_concatenation():
    """facepairs._slices gives the blocks ``step`` by ``step`` of the parts'
    concatenation (the blocks the kinds read before stage 1 was kept in parts): the
    same values, dtypes and boundaries, for steps below, at and above the parts'
    lengths and empty parts; ``consume`` empties the lists as it goes."""
    from predicates.registration.levels.facepairs import _slices

    rng = np.random.default_rng(11)
    lengths = [5, 0, 3, 12, 1, 0, 7]
    fs = [rng.integers(0, 99, n).astype(np.int32) for n in lengths]
    cs = [rng.integers(0, 99, n).astype(np.int32) for n in lengths]
    f_all, c_all = np.concatenate(fs), np.concatenate(cs)
    for step in (1, 2, 3, 5, 7, 28, 100):
        want = [(f_all[lo: lo + step], c_all[lo: lo + step])
                for lo in range(0, len(f_all), step)]
        for consume in (False, True):
            fl, cl = list(fs), list(cs)
            got = list(_slices(fl, cl, step, consume))
            assert len(got) == len(want), (step, consume)
            for (f, c), (wf, wc) in zip(got, want):
                assert f.dtype == np.int32 and c.dtype == np.int32
                assert np.array_equal(f, wf) and np.array_equal(c, wc), (step, consume)
            if consume:
                assert fl == [None] * len(fs) and cl == [None] * len(cs)
            else:  # the parts left as they were
                assert all(a is b for a, b in zip(fl + cl, fs + cs)) and len(fl) == len(fs)
    assert list(_slices([], [], 4)) == []


def test_suppression_keys_of_int32_ids_do_not_wrap():
    """Stage 1's ids are int32 (half its memory): the numpy suppression look-up's keys
    s * n_cut + c exceed 2^31 on large meshes and must be formed in int64 — here
    against the keys in Python integers, with a registered lower pair (a = i: the
    simplex itself, int32) whose key is above 2^31 and one whose int32 product wraps
    onto a registered key."""
    from types import SimpleNamespace

    from predicates.registration.levels.loop import Registration

    n_cut_vertices = 3_000_000  # s * n ≥ 2^31 for s ≥ 716
    face = np.array([[0, 1], [1, 2], [2, 3]] * 400, dtype=np.int64)  # edge -> vertices
    cut = SimpleNamespace(count=lambda b: n_cut_vertices if b == 0 else len(face),
                          cx=SimpleNamespace(face=lambda k, j: face))
    s = np.array([5, 800, 1000, 1100], dtype=np.int32)  # simulation edges
    c = np.array([0, 7, 2, 9], dtype=np.int32)  # cutting edges
    wrapped = int(np.array([1000 * n_cut_vertices]).astype(np.int32)[0])
    registered = [800 * n_cut_vertices + 2,  # (edge 800, vertex 2): c = 7 has it
                  wrapped + 3]  # (edge 1000, vertex 3) in int32: c = 2 has vertex 3
    sim = SimpleNamespace(cx=SimpleNamespace(face=lambda k, j: None))  # a = i: not read
    reg = SimpleNamespace(accelerate=False, sim=sim, cut=cut,
                          registered={(1, 0): np.array(sorted(registered), np.int64)})
    suspects = ([(1, 0)], np.ones(1200, bool), np.ones(1200, bool))
    got = Registration._blocked(reg, 1, 1, s, c, suspects)
    keys = set(registered)
    want = [any(int(a) * n_cut_vertices + int(b) in keys for b in face[g])
            for a, g in zip(s, c)]
    assert got.tolist() == want == [False, True, False, False]
