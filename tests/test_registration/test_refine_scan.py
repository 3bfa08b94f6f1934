"""predicates.registration.plan.refine_scan (issue 12): the refinement's one pass over the
simulation cells. Its near set is a superset of the cells meeting a reach box and its
statistics are those of every cell (exact references: pairwise box tests, np.median);
the marks built on it equal the marks defined over ALL cells and over bins of ALL
cells (a plain reference written here); and the pass allocates nothing the size of
the mesh (tracemalloc)."""
from __future__ import annotations

import math
import tracemalloc
from collections import defaultdict
from fractions import Fraction

import numpy as np
import pytest

from predicates.registration.plan import refine as refine_mod
from predicates.registration.plan import refine_scan
from predicates.registration.spatial.boxes import box_extent, boxes_of
from predicates.registration.examples import cube_grid
from predicates.portable import power, rotate, rotation
from predicates.registration.plan.refine_scan import points_near, scan_cells


def _meets_any(lo, hi, rlo, rhi):
    """Per box: does it meet one of the boxes (rlo, rhi) (closed)? Pairwise."""
    out = np.zeros(len(lo), dtype=bool)
    for i in range(len(rlo)):
        out |= np.all((lo <= rhi[i]) & (rlo[i] <= hi), axis=1)
    return out


def _graded_mesh(n, p, seed):
    """A Kuhn grid graded towards the origin and rotated: box edges over decades."""
    sp, sc = cube_grid(n)
    return rotate(power(sp, p), rotation(3, seed)), sc


def _reach_of(rng, m, centre, size):
    c = centre + rng.uniform(-size, size, (m, 3))
    e = rng.choice([0.0, 0.01, 0.05, 0.3], size=(m, 3)) * size
    return c - e, c + e


@pytest.mark.parametrize("seed", range(4))
def test_scan_near_superset_and_statistics_exact(seed):
    rng = np.random.default_rng(seed)
    sp, sc = _graded_mesh(7, [1.0, 2.0, 3.0, 1.5][seed], seed)
    lo, hi = boxes_of(sp, sc)
    rlo, rhi = _reach_of(rng, 40, sp.mean(axis=0), 0.3)
    s = scan_cells(lo, hi, (rlo, rhi))
    ext = box_extent(lo, hi)
    assert (s.ext_min, s.ext_max) == (ext.min(), ext.max())
    assert s.mag == np.abs(np.concatenate([lo, hi])).max()
    med = float(np.median(ext))
    assert math.frexp(s.fine)[1] == math.frexp(med)[1]  # the same binade
    want = _meets_any(lo, hi, rlo, rhi)
    got = np.zeros(len(lo), dtype=bool)
    got[s.near] = True
    assert not (want & ~got).any()  # a superset ...
    assert np.all(np.diff(s.near) > 0)
    assert got.sum() < len(lo)  # ... that leaves cells out (not everything)


@pytest.mark.parametrize("seed", range(3))
def test_scan_gathers_the_near_set_only_when_a_query_can_be_long_enough(seed, monkeypatch):
    """``longest`` (the largest box edge of any query): the near set is the full one as
    soon as longest exceeds the smallest cell box edge — also when the running minimum
    only falls below it in a late block (the earlier blocks are read again) — and
    empty when it does not (no edge would be queried)."""
    monkeypatch.setattr(refine_scan, "BLOCK", 37)
    rng = np.random.default_rng(seed)
    sp, sc = _graded_mesh(7, [2.0, 3.0, 1.5][seed], seed)
    lo, hi = boxes_of(sp, sc)
    order = np.argsort(-box_extent(lo, hi), kind="stable")  # the smallest cells last
    lo, hi = lo[order], hi[order]
    reach = _reach_of(rng, 40, sp.mean(axis=0), 0.3)
    full = scan_cells(lo, hi, reach)
    ext = box_extent(lo, hi)
    for longest in (float(np.nextafter(ext.min(), np.inf)), float(np.median(ext)), math.inf):
        s = scan_cells(lo, hi, reach, longest)
        assert np.array_equal(s.near, full.near)
        assert (s.ext_min, s.ext_max, s.fine, s.mag) == (full.ext_min, full.ext_max,
                                                         full.fine, full.mag)
    assert len(full.near) and len(scan_cells(lo, hi, reach, float(ext.min())).near) == 0


def test_scan_wide_cells_are_tested_directly(monkeypatch):
    """Cells far wider than the grid (beyond the capped distances) go to the direct
    test: big cells crossing a small reach box are found, small far ones are not."""
    monkeypatch.setattr(refine_scan, "BLOCK", 7)  # many blocks, a partial last one
    direct = []
    near_flags = refine_scan.near_flags
    monkeypatch.setattr(refine_scan, "near_flags",
                        lambda a, *r, **k: direct.append(len(a)) or near_flags(a, *r, **k))
    lo = np.array([[0.49, 0.49, 0.49], [3.0, 3.0, 3.0],  # small: near, far
                   [0.0, 0, 0], [-50, -50, -50], [1000, 1000, 1000]])  # wide: 2 meet
    hi = np.array([[0.51, 0.51, 0.51], [3.02, 3.02, 3.02],
                   [1.0, 1, 1], [50, 50, 50], [1080, 1080, 1080]])
    lo, hi = np.repeat(lo, [100, 100, 5, 5, 5], axis=0), np.repeat(hi, [100, 100, 5, 5, 5], axis=0)
    rlo, rhi = np.array([[0.45, 0.45, 0.45]]), np.array([[0.55, 0.55, 0.55]])
    s = scan_cells(lo, hi, (rlo, rhi))
    assert direct == [15]  # the wide cells (grid cell 1/64), tested directly, once
    near = set(s.near.tolist())
    assert set(range(100)) | set(range(200, 210)) <= near
    assert not set(range(100, 200)) & near  # small and far: not near
    assert not set(range(210, 215)) & near  # wide and far: not near either


def test_scan_median_straddling_binades_is_exact():
    # even count, the two middle box edges in different binades: the exact median
    lo = np.zeros((4, 2))
    hi = np.array([[0.3, 0.1], [0.7, 0.2], [1.5, 0.0], [3.0, 0.0]])
    s = scan_cells(lo, hi, None)
    assert s.fine == np.median(box_extent(lo, hi)) == 1.1
    assert len(s.near) == 0  # no cutting cells: no cell is near
    # zero box edges in the middle: the exact median (0) too
    s = scan_cells(np.zeros((3, 2)), np.array([[0.0, 0], [0, 0], [2, 0]]), None)
    assert s.fine == 0.0


def test_scan_rejects_non_finite_boxes():
    lo, hi = np.zeros((3, 3)), np.ones((3, 3))
    hi[1, 2] = np.nan
    with pytest.raises(ValueError, match="finite"):
        scan_cells(lo, hi, (lo[:1], hi[:1]))
    with pytest.raises(ValueError, match="cutting mesh's coordinates"):
        scan_cells(np.zeros((3, 3)), np.ones((3, 3)), (lo[:1], hi[1:2]))


def test_points_near_superset_of_centres_in_boxes():
    rng = np.random.default_rng(7)
    sp, sc = _graded_mesh(6, 2.0, 3)
    lo, hi = boxes_of(sp, sc)
    blo, bhi = _reach_of(rng, 30, sp.mean(axis=0), 0.25)
    mid = 0.5 * (lo + hi)
    want = _meets_any(mid, mid, blo, bhi)
    got = np.zeros(len(lo), dtype=bool)
    got[points_near(lo, hi, (blo, bhi))] = True
    assert want.any() and not (want & ~got).any() and got.sum() < len(lo)


def test_scan_allocates_nothing_the_size_of_the_mesh(monkeypatch):
    """The pass works in blocks: with a few cells near the reach box, its peak
    allocation stays far below one float64 per cell (tracemalloc sees numpy's)."""
    monkeypatch.setattr(refine_scan, "BLOCK", 4096)
    sp, sc = cube_grid(40)  # 384,000 cells
    lo, hi = boxes_of(sp, sc)
    reach = (np.array([[0.02, 0.02, 0.02]]), np.array([[0.05, 0.05, 0.05]]))
    tracemalloc.start()
    try:
        s = scan_cells(lo, hi, reach)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert 0 < len(s.near) < 1000
    assert peak < 8 * len(lo) / 3  # a third of one float64 column of the mesh


# --- the marks on the scanned cells equal the marks over ALL cells ----------------------

def _reference_thr(lo, hi, ext, fine, g, qlo, qhi):
    """thr of :meth:`refine._SimScale.marks`, from its definition over all cells: the
    largest box edge of the cells (g <= median) or of the bins floor(centre/g) of all
    cells meeting each query box."""
    if g <= fine:
        blo, bhi, bval = lo, hi, ext
    else:
        groups = defaultdict(list)
        for i, k in enumerate(map(tuple, np.floor((0.5 * (lo + hi)) / g).tolist())):
            groups[k].append(i)
        ids = list(groups.values())
        blo = np.array([lo[i].min(axis=0) for i in ids])
        bhi = np.array([hi[i].max(axis=0) for i in ids])
        bval = np.array([ext[i].max() for i in ids])
    out = np.zeros(len(qlo))
    for q in range(len(qlo)):
        meet = np.all((blo <= qhi[q]) & (qlo[q] <= bhi), axis=1)
        out[q] = max(0.0, float(bval[meet].max())) if meet.any() else 0.0
    return out


@pytest.mark.parametrize("boxes", ["mesh", "random"])
@pytest.mark.parametrize("seed", range(3))
def test_marks_equal_the_definition_over_all_cells(seed, boxes):
    """Queries as refinement makes them (edges inside coarse cutting triangles, boxes
    widened by their box edge, one size class each), against a graded slab (box edges
    0.3 to 1.3, median in [1, 2)): the cells' class and bins of class 4 (edges of box
    edge 4 to 16), built from the cells near the triangles only."""
    rng = np.random.default_rng(seed)
    if boxes == "mesh":
        sp, sc = cube_grid(48)
        sc = sc[(sp[sc][:, :, 2] <= 2 / 48 + 1e-12).all(axis=1)]
        sp = sp ** 1.3 * 48
        lo, hi = boxes_of(sp, sc)
    else:  # boxes around a slab, 3% of them wide: a bin's box and maximum come from
        # cells far from the query (the mesh's boxes vary too slowly to show it)
        lo = rng.uniform(0, 1, (20000, 3)) * [48, 48, 2]
        wide = rng.random(20000) < 0.03
        size = np.where(wide[:, None], rng.uniform(0.5, 9.0, (20000, 3)),
                        rng.uniform(0.3, 1.3, (20000, 3)))
        lo, hi = lo - size / 2, lo + size / 2
    ext = box_extent(lo, hi)
    cp = rng.uniform(0, 1, (12, 3)) * [12, 12, 2] * rng.uniform(0.6, 1.0, (12, 1))
    cc = rng.permutation(12).reshape(4, 3)
    reach, cut_ext = refine_mod._reach(cp, cc)
    sim = refine_mod._SimScale(lo, hi, reach, cut_ext)
    fine = float(np.median(ext))
    # edges between random points of each triangle: their boxes lie in its box
    w = rng.dirichlet(np.ones(3), size=(len(cc), 80, 2))
    corner = rng.random((len(cc), 80, 2)) < 0.5  # half the ends at vertices: long edges
    w[corner] = np.eye(3)[rng.integers(0, 3, int(corner.sum()))]
    ends = np.einsum("mqek,mkd->mqed", w, cp[cc]).reshape(-1, 2, 3)
    elo, ehi = ends.min(axis=1), ends.max(axis=1)
    eext = box_extent(elo, ehi)
    qlo, qhi = elo - eext[:, None], ehi + eext[:, None]
    cls = refine_mod.size_classes(eext)  # as refine._too_long
    classes = []
    for k in np.unique(cls):
        sel = cls == k
        g = math.ldexp(1.0, 2 * int(k))
        ref = _reference_thr(lo, hi, ext, fine, g, qlo[sel], qhi[sel])
        want = (ref > 0) & (eext[sel] > ref)
        assert np.array_equal(sim.marks(g, qlo[sel], qhi[sel], eext[sel]), want)
        classes.append(g > fine)
    assert True in classes and False in classes  # cells and bins were compared
    assert len(sim._binned()[0]) < 0.75 * len(lo)  # bins built from part of the mesh


@pytest.mark.parametrize("seed", range(3))
def test_bins_hold_every_cell_of_every_bin_a_query_can_meet(seed):
    """The claim behind building bins from part of the mesh (refine._SimScale._binned):
    every bin of every class g above the median box edge (up to the input cutting
    cells' box edges) whose box meets a reach box R of a cutting cell of box edge >= g
    — a superset of the bins a query can meet — has ALL its cells in the set."""
    rng = np.random.default_rng(seed)
    n = 20000
    c = rng.uniform(0, 1, (n, 3)) * [48, 48, 2]
    wide = rng.random(n) < 0.01
    size = np.where(wide[:, None], rng.uniform(1.0, 5.0, (n, 3)), rng.uniform(0.3, 1.3, (n, 3)))
    lo, hi = c - size / 2, c + size / 2
    cp = rng.uniform(0, 1, (12, 3)) * [12, 12, 2] * rng.uniform(0.5, 1.0, (12, 1))
    cc = rng.permutation(12).reshape(4, 3)
    reach, cut_ext = refine_mod._reach(cp, cc)
    sim = refine_mod._SimScale(lo, hi, reach, cut_ext)
    blo, bhi = sim._binned()[:2]
    chosen = {tuple(r) for r in np.concatenate([blo, bhi], axis=1).tolist()}
    mid = 0.5 * (lo + hi)
    checked = 0
    for e in range(-2 * math.frexp(sim.fine)[1], 8):
        g = math.ldexp(1.0, e)
        if g <= sim.fine or g > cut_ext.max():
            continue
        groups = defaultdict(list)
        for i, k in enumerate(map(tuple, np.floor(mid / g).tolist())):
            groups[k].append(i)
        for ids in groups.values():
            ulo, uhi = lo[ids].min(axis=0), hi[ids].max(axis=0)
            can = (cut_ext >= g) & np.all((reach[0] <= uhi) & (ulo <= reach[1]), axis=1)
            if can.any():
                checked += 1
                assert all(tuple(r) in chosen for r in
                           np.concatenate([lo[ids], hi[ids]], axis=1).tolist())
    assert checked > 50 and len(blo) < n


def test_a_wide_cell_far_outside_the_reach_keeps_its_bin():
    """The E in the bins' reach: a wide cell W (box edge 20) reaching the query from a
    centre 9.5 beyond the reach box holds the largest box edge of its bin; without it
    the query would see only a small cell near it and be marked."""
    far = np.array([100.0, 0, 0]) + np.arange(100)[:, None] * [0.1, 0, 0]
    c = np.concatenate([far, [[0.5, 0.5, 0.5], [13.5, 2, 2], [13.2, 2.2, 2.2]]])
    half = np.full((103, 1), 0.15)
    half[101] = 10.0  # W
    lo, hi = c - half, c + half
    cp = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 2]])
    reach, cut_ext = refine_mod._reach(cp, np.array([[0, 1, 2]]))
    sim = refine_mod._SimScale(lo, hi, reach, cut_ext)
    assert sim.fine < 1.0  # class 1 uses bins
    blo = sim._binned()[0]
    assert any(np.array_equal(r, lo[101]) for r in blo)  # W and its bin mate are in
    assert any(np.array_equal(r, lo[102]) for r in blo)
    qlo, qhi = np.array([[-2.0, -2, -2]]), np.array([[4.0, 2, 2]])  # edge (0,0,0)-(2,0,0)
    assert _reference_thr(lo, hi, box_extent(lo, hi), float(np.median(box_extent(lo, hi))),
                          1.0, qlo, qhi)[0] == 20.0
    assert not sim.marks(1.0, qlo, qhi, np.array([2.0]))[0]


try:
    from hypothesis import given, settings, strategies as st
except ImportError:  # pragma: no cover
    given = None

if given is not None:
    @settings(max_examples=40, deadline=None)
    @given(st.integers(0, 2 ** 32 - 1), st.sampled_from([2, 3]),
           st.floats(1e-6, 1e6), st.floats(-1e7, 1e7))
    def test_scan_and_points_supersets_at_any_scale(seed, d, scale, offset):
        """Touching and nearly touching boxes far from the origin, at any scale: the
        rounding margins of the grid (h >= 2^-40 of the coordinates) hold."""
        rng = np.random.default_rng(seed)
        n = int(rng.integers(1, 400))
        lo = rng.integers(0, 40, (n, d)) * 0.25
        size = rng.choice([0.0, 0.25, 0.5, 1.0, 6.0, 30.0], size=(n, d),
                          p=[.1, .3, .3, .2, .07, .03])
        m = int(rng.integers(1, 8))
        rlo = rng.integers(0, 40, (m, d)) * 0.25 + rng.choice([0.0, 1e-9], size=(m, d))
        rhi = rlo + rng.choice([0.0, 0.25, 2.0], size=(m, d))
        lo, hi, rlo, rhi = (x * scale + offset for x in (lo, lo + size, rlo, rhi))
        s = scan_cells(lo, hi, (rlo, rhi))
        got = np.zeros(n, dtype=bool)
        got[s.near] = True
        assert not (_meets_any(lo, hi, rlo, rhi) & ~got).any()
        mid = 0.5 * (lo + hi)
        got[:] = False
        got[points_near(lo, hi, (rlo, rhi))] = True
        assert not (_meets_any(mid, mid, rlo, rhi) & ~got).any()
        assert s.ext_max == box_extent(lo, hi).max()


def test_size_classes_are_exact_next_to_powers_of_four():
    """refine.size_classes: the largest c with 4^c ≤ x (Fractions), for x one ulp below,
    at and one ulp above every power of four from 1e-300 (below it, x counts as 1e-300)
    to the top of binary64, and for random x."""
    rng = np.random.default_rng(5)
    xs = [np.nextafter(4.0 ** c, d) for c in range(-498, 512) for d in (0, np.inf)]
    xs += [4.0 ** c for c in range(-498, 512)]
    xs += list(np.ldexp(rng.random(2000) + 0.5, rng.integers(-990, 1020, 2000)))
    got = refine_mod.size_classes(np.array(xs))
    for x, c in zip(xs, got.tolist()):
        q = Fraction(x)
        assert Fraction(4) ** c <= q < Fraction(4) ** (c + 1), (x, c)
    tiny = refine_mod.size_classes(np.array([0.0, 1e-310, 1e-300]))
    assert tiny.tolist() == [tiny[2]] * 3
