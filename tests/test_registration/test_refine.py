"""predicates.registration.plan.refine: conforming refinement of coarse cutting meshes
(issue 10): conformity, orientation, map back (cut_origin, barycentric rows,
input_weights), geometry-only (order/orientation invariance), the cell budget."""
from __future__ import annotations

import itertools
from collections import Counter

import numpy as np
import pytest

import fperr
import predicates
from predicates.registration.examples import cube_grid, square_grid
from predicates.portable import cos_sin, power, rotate, rotation, unit_rows
from predicates.registration.plan.refine import refine
from predicates.registration.plan.resolution import cell_boxes
from shared_cases import plane_case


def _edge_use(cells):
    cnt = Counter()
    for t in cells.tolist():
        for a, b in itertools.combinations(t, 2):
            cnt[tuple(sorted((a, b)))] += 1
    return cnt


@pytest.fixture(scope="module")
def refined():
    sp, sc, cp, cc = plane_case(n=6, half=1e3)
    return cp, cc, refine(cp, cc, *cell_boxes(sp, sc)), cell_boxes(sp, sc)


def test_conforming_oriented_and_mapped_back(refined):
    cp, cc, R, _ = refined
    assert R.refined and R.rounds > 5
    assert np.array_equal(R.points[: len(cp)], cp)  # input points keep their ids
    use = _edge_use(R.cells)
    assert set(use.values()) <= {1, 2}
    # boundary edges (used once) lie on the input's boundary: no hanging vertex anywhere
    bnd = [e for e, k in use.items() if k == 1]
    cut_bnd = {(0, 1), (1, 2), (2, 3), (0, 3)}
    for a, b in bnd:
        o = set(R.cut_origin[[i for i, t in enumerate(R.cells.tolist()) if a in t and b in t]])
        assert len(o) == 1
        Bi = R.bary[[i for i, t in enumerate(R.cells.tolist()) if a in t and b in t][0]]
        # both endpoints have a zero weight on the same input vertex: on an input edge
        cell_in = cc[o.pop()]
        t = R.cells[[i for i, t_ in enumerate(R.cells.tolist()) if a in t_ and b in t_][0]]
        rows = Bi[[list(t).index(a), list(t).index(b)]]
        zero = np.flatnonzero((rows == 0).all(axis=0))
        assert len(zero) == 1
        e = tuple(sorted(np.delete(cell_in, zero[0])))
        assert e in cut_bnd
    n0 = np.cross(cp[1] - cp[0], cp[2] - cp[0])
    P, T = R.points, R.cells
    assert (np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]) @ n0 > 0).all()
    assert (R.bary >= 0).all() and np.allclose(R.bary.sum(axis=2), 1, rtol=0, atol=1e-15)
    rec = np.einsum("mkj,mjd->mkd", R.bary, cp[cc[R.cut_origin]])
    assert np.abs(rec - P[T]).max() < 1e-9 * 1e3  # midpoint roundings only


def test_refined_near_the_simulation_mesh_only(refined):
    cp, cc, R, (lo, hi) = refined
    X = R.points[R.cells]
    ext = (X.max(1) - X.min(1)).max(1)
    near = np.all((X.min(1) < hi.max(0) + 0.1) & (X.max(1) > lo.min(0) - 0.1), axis=1)
    assert ext[near].max() <= (hi - lo).max() * (1 + 1e-12)
    assert ext.max() > 100  # far away the cut stays coarse


def test_input_weights_give_back_the_same_point():
    sp, sc, cp, cc = plane_case(n=4, half=100.0)
    res = predicates.intersect(sp, sc, cp, cc)
    R = res.refinement
    for kind in ("edge_triangle", "tetrahedron_vertex", "edge_edge"):
        p = res[kind]
        assert len(p)
        cell, w = R.input_weights(p.cut, p.cut_weights)
        x_ref = p.points(res.cut_points, "cut")
        x_in = np.einsum("mk,mkd->md", w, cp[cc[cell]])
        assert np.abs(x_ref - x_in).max() < 1e-10 * 100
        assert np.allclose(w.sum(1), 1) and (w >= -1e-15).all()


def test_geometry_only_not_numbering():
    sp, sc, cp, cc = plane_case(n=4, half=100.0)
    boxes = cell_boxes(sp, sc)
    a = refine(cp, cc, *boxes)
    perm = np.array([2, 0, 3, 1])
    inv = np.argsort(perm)
    b = refine(cp[perm], inv[cc][::-1][:, [1, 2, 0]], *boxes)

    def tris(R):
        return {tuple(sorted(map(tuple, R.points[t].tolist()))) for t in R.cells}
    assert tris(a) == tris(b)


def test_2d_segments_and_untouched_inputs():
    sp, sc = square_grid(8)
    boxes = cell_boxes(sp, sc)
    cp = np.array([[-100.0, 0.31], [100.0, 0.52], [5.0, 5.0], [6.0, 6.0]])
    cc = np.array([[0, 1], [2, 3]])
    R = refine(cp, cc, *boxes)
    assert set(R.cut_origin.tolist()) == {0, 1}
    assert (R.cut_origin == 1).sum() == 1  # the far segment is not refined
    use = Counter(R.cells.ravel().tolist())
    assert sorted(k for k, v in use.items() if v == 1) == [0, 1, 2, 3]  # a chain
    near = R.cells[R.cut_origin == 0]
    X = R.points[near]
    ext = (X.max(1) - X.min(1)).max(1)
    mid = np.all((X > -0.2) & (X < 1.2), axis=(1, 2))
    assert mid.any() and ext[mid].max() <= 0.125


@pytest.mark.parametrize("scale", [0.5, 1.0, 3.0])
def test_no_edge_list_when_every_cutting_cell_is_finer(monkeypatch, scale):
    """When no cutting cell's box edge exceeds the smallest simulation cell's, refine
    skips the edge list and the queries (refine._can_mark): the same result as the
    rounds run to their first, empty, marking; a coarser cutting mesh still refines."""
    from predicates.registration.plan import refine as R
    from predicates.registration.examples import icosphere

    sp, sc = cube_grid(6)
    cp, cc = icosphere(4 if scale <= 1 else 1)
    cp = 0.5 + 0.3 * scale * cp
    boxes = cell_boxes(sp, sc)
    calls = []
    monkeypatch.setattr(R, "_can_mark", lambda sim: calls.append(1) or True)
    want = refine(cp, cc, *boxes)
    monkeypatch.undo()
    got = refine(cp, cc, *boxes)
    for name in ("points", "cells", "cut_origin", "bary"):
        a, b = getattr(want, name), getattr(got, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    assert (want.rounds, want.input_cells) == (got.rounds, got.input_cells)
    cut_ext = (cell_boxes(cp, cc)[1] - cell_boxes(cp, cc)[0]).max(1).max()
    sim_ext = (boxes[1] - boxes[0]).max(1).min()
    if scale <= 1:  # the shortcut's case: every cutting cell finer, nothing refined
        assert cut_ext <= sim_ext and got.rounds == 0
    if scale == 3.0:
        assert got.rounds > 0  # coarse: refined as before


def test_cell_budget_refuses_with_a_clear_error():
    sp, sc = cube_grid(6)
    cp = np.array([[-1e6, -1e6, 0.51], [1e6, -1e6, 0.51], [0, 1e6, 0.51]])
    with pytest.raises(fperr.ResolutionError, match="refine_cut=False"):
        refine(cp, np.array([[0, 1, 2]]), *cell_boxes(sp, sc), max_cells=200)


# --- output pinned across the linear-time rewrite of the marking (benchmarks/README.md,
# "Refinement"): sha256 of (points, cells, cut_origin, bary, rounds) computed on main
# before the rewrite; any change of the refined mesh, its order or its map back fails.
# The rotated cases were re-pinned when their inputs became exact rational rotations
# (portable.rotation; a LAPACK QR gave other bits on other CPUs).

def _graded(points, p=2.5):
    """Grade a unit grid towards the origin (cells from ~n^-p to ~p/n)."""
    return power(points, p)


def _pinned_case(name):
    """(cut points, cut cells, simulation boxes) of one pinned case."""
    if name == "plane3d_issue":
        sp, sc, cp, cc = plane_case()
    elif name.startswith("plane3d"):
        sp, sc, cp, cc = plane_case(n=6, half=1e3)
        if name.endswith("f32"):
            cp = cp.astype(np.float32)
    elif name == "graded3d_rotated":
        sp, sc = cube_grid(5)
        Q = rotation(3, 1)
        sp = rotate(_graded(sp), Q)
        _, _, cp, cc = plane_case(n=6, half=50.0)
        cp = rotate(cp - 0.3, Q)
    elif name == "slab3d":
        sp, sc = cube_grid(8)
        sc = sc[(sp[sc][:, :, 2] <= 1.0 / 8 + 1e-12).all(axis=1)]
        nrm = unit_rows(np.array([[0.05, 0.08, 1.0]]))[0]
        u = unit_rows(np.cross(nrm, [1.0, 0, 0])[None])[0]
        v = np.cross(nrm, u)
        c = np.array([0.5, 0.5, 0.37 / 8])
        cp = np.array([c + 1e4 * (a * u + b * v) for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])
        cc = np.array([[0, 1, 2], [0, 2, 3]])
    elif name.startswith("segments2d"):
        sp, sc = square_grid(8)
        Q = rotation(2, 2)
        sp = rotate(sp, Q)
        cp = rotate(np.array([[-100.0, 0.31], [100.0, 0.52], [5.0, 5.0], [6.0, 6.0]]), Q)
        cc = np.array([[0, 1], [2, 3]])
        if name.endswith("f32"):
            cp = cp.astype(np.float32)
    elif name == "graded2d_polyline":
        sp, sc = square_grid(12)
        sp = rotate(_graded(sp, 3.0), rotation(2, 3))
        t = np.linspace(-1.0, 1.0, 7)
        cp = rotate(np.stack([300.0 * t, 0.2 + 0.3 * cos_sin(3 * t)[1]], axis=1), rotation(2, 3))
        cc = np.stack([np.arange(6), np.arange(1, 7)], axis=1)
    else:
        raise KeyError(name)
    return cp, cc, cell_boxes(sp, sc)


def _digest(R) -> str:
    import hashlib

    h = hashlib.sha256()
    h.update(str(R.points.dtype).encode() + np.ascontiguousarray(R.points).tobytes())
    for a in (R.cells.astype(np.int64), R.cut_origin.astype(np.int64),
              R.bary.astype(np.float64)):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(str(R.rounds).encode())
    return h.hexdigest()[:16]


PINNED = {
    "plane3d": "05ce1fce95a0b525",  # 2 -> 1226 cells, 14 rounds
    "plane3d_f32": "f7fcf62fe83a122a",  # 2 -> 1226 cells, 14 rounds
    "plane3d_issue": "2cd3d4c9c5f993f3",  # 2 -> 1944 cells, 18 rounds
    "graded3d_rotated": "ee09ea44e2be0041",  # 2 -> 550 cells, 9 rounds
    "slab3d": "766b572a235c31f6",  # 2 -> 1840 cells, 18 rounds
    "segments2d": "113cf1c0abe54ec0",  # 2 -> 40 cells, 10 rounds
    "segments2d_f32": "91bc980303c8c523",  # 2 -> 40 cells, 10 rounds
    "graded2d_polyline": "7e30ea659085b2db",  # 6 -> 49 cells, 10 rounds
}


@pytest.mark.parametrize("name", sorted(PINNED))
def test_refined_output_pinned(name):
    cp, cc, boxes = _pinned_case(name)
    R = refine(cp, cc, *boxes)
    assert R.refined
    assert _digest(R) == PINNED[name]


# --- the marks' index (refine_index.LevelIndex) against the pairwise definition -----------

def _random_boxes(rng, n, d, grid):
    """Boxes of mixed sizes (zero extent included) on a coarse lattice shifted by a
    non-dyadic offset: many exact touchings, and rounding in every cell index."""
    off = rng.uniform(-3, 3, d) + 0.1
    lo = rng.integers(0, grid, (n, d)) * 0.25 + off
    size = rng.choice([0.0, 0.25, 0.5, 1.0, 3.0, 8.0], size=(n, d), p=[.1, .3, .3, .15, .1, .05])
    val = np.where(rng.random(n) < 0.1, 0.0, (size.max(axis=1) + rng.random(n)))
    return lo, lo + size, val, off


def _check_index(lo, hi, val, qlo, qhi, qext):
    from predicates.registration.plan.refine_index import LevelIndex, max_over_bruteforce

    index = LevelIndex(lo, hi, val)
    ref = max_over_bruteforce(lo, hi, val, qlo, qhi)
    assert np.array_equal(index.max_over(qlo, qhi), ref)
    with np.errstate(invalid="ignore"):
        want = (ref > 0) & (qext > ref)
    assert np.array_equal(index.marks(qlo, qhi, qext), want)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("seed", range(4))
def test_level_index_equals_pairwise_maximum(d, seed):
    rng = np.random.default_rng(seed)
    lo, hi, val, off = _random_boxes(rng, 400, d, 40)
    m = 600
    qlo = rng.integers(-4, 44, (m, d)) * 0.25 + off
    qlo[: m // 3] += rng.uniform(-0.3, 0.3, (m // 3, d))  # off the lattice too
    qhi = qlo + rng.choice([0.0, 0.25, 1.0, 2.5, 12.0], size=(m, d))
    qext = rng.choice([0.0, 0.5, 1.0, 1.5, 3.0, 9.0], size=m)
    qext[:20] = val[:20]  # thresholds equal to values: ties decide "not marked"
    _check_index(lo, hi, val, qlo, qhi, qext)


try:
    from hypothesis import given, settings, strategies as st
except ImportError:  # pragma: no cover
    given = None

if given is not None:
    @settings(max_examples=60, deadline=None)
    @given(st.integers(0, 2 ** 32 - 1), st.sampled_from([2, 3]), st.integers(1, 60),
           st.floats(1e-6, 1e6))
    def test_level_index_random_scales(seed, d, n, scale):
        """Any scale and count (one box, all boxes equal, coarse grids)."""
        rng = np.random.default_rng(seed)
        lo, hi, val, off = _random_boxes(rng, n, d, int(rng.integers(1, 12)))
        lo, hi, val = lo * scale, hi * scale, val * scale
        qlo = (rng.integers(-4, 16, (50, d)) * 0.25 + off) * scale
        qhi = qlo + rng.choice([0.0, 0.25, 1.0, 4.0], size=(50, d)) * scale
        qext = rng.choice([0.0, 0.5, 1.0, 3.0], size=50) * scale
        _check_index(lo, hi, val, qlo, qhi, qext)


def test_level_index_nan_queries_and_bad_boxes():
    from predicates.registration.plan.refine_index import LevelIndex

    lo = np.zeros((3, 2))
    hi = np.ones((3, 2))
    val = np.array([1.0, 2.0, 0.5])
    index = LevelIndex(lo, hi, val)
    qlo = np.array([[np.nan, 0.0], [-1.0, -1.0], [-np.inf, 0.5]])
    qhi = np.array([[2.0, 2.0], [2.0, 2.0], [np.inf, 0.5]])
    assert index.max_over(qlo, qhi).tolist() == [0.0, 2.0, 2.0]
    assert index.marks(qlo, qhi, np.array([5.0, np.nan, 3.0])).tolist() == [False, False, True]
    with pytest.raises(ValueError, match="finite"):
        LevelIndex(lo, hi, np.array([1.0, np.nan, 0.5]))


def test_level_index_decides_from_counts_inside_a_uniform_mesh(monkeypatch):
    """Queries well inside a uniform mesh are decided by the summed-area counts alone:
    no box is listed (the constant-work path of the refinement's marks)."""
    from predicates.registration.plan import refine_index

    sp, sc = cube_grid(12)
    lo, hi = cell_boxes(sp, sc)
    ext = (hi - lo).max(axis=1)
    index = refine_index.LevelIndex(lo, hi, ext)
    rng = np.random.default_rng(5)
    c = rng.uniform(0.3, 0.7, (200, 3))
    e = rng.uniform(0.1, 0.2, 200)  # longer than every cell (1/12): all marked
    qlo, qhi = c - e[:, None], c + e[:, None]

    def listed(*a):
        raise AssertionError("a query inside the mesh was resolved box by box")
    monkeypatch.setattr(refine_index._Level, "max_over", listed)
    assert index.marks(qlo, qhi, e).all()
    # shorter than every cell near it: a box of value ≥ e certainly meets, not marked
    assert not index.marks(qlo, qhi, np.full(200, 0.05)).any()


if __name__ == "__main__":  # print the digests (to pin them)
    for n in ["plane3d", "plane3d_f32", "plane3d_issue", "graded3d_rotated", "slab3d", "segments2d",
              "segments2d_f32", "graded2d_polyline"]:
        cp, cc, boxes = _pinned_case(n)
        R = refine(cp, cc, *boxes)
        print(f'    "{n}": "{_digest(R)}",  # {len(cc)} -> {len(R.cells)} cells, '
              f'{R.rounds} rounds')
