"""The broad phase (predicates.registration.spatial.broadphase) against brute force: every pair within pad,
exactly once, including crowded grid cells (refined recursively) and degenerate boxes;
near_flags against its definition."""
from __future__ import annotations

import numpy as np
import pytest

from predicates.registration.spatial.broadphase import (
    box_pairs, box_pairs_bruteforce, near_flags)


def _pairs(la, ha, lb, hb, pad, chunk=1 << 22):
    got = [(int(a), int(b)) for ia, ib in box_pairs(la, ha, lb, hb, pad, chunk=chunk)
           for a, b in zip(ia, ib)]
    assert len(got) == len(set(got)), "a pair was reported twice"
    return set(got)


def _crowded(rng, n_tiny, n_big, dim, size=1e-3):
    """Tiny boxes clustered in a 0.4-wide cube plus large boxes elsewhere."""
    la = np.concatenate([rng.uniform(0, 0.4, (n_tiny, dim)),
                         2 + 3 * rng.integers(0, 6, (n_big, dim)).astype(float)])
    ha = la + np.concatenate([rng.uniform(0, size, (n_tiny, dim)), np.ones((n_big, dim))])
    lb = np.concatenate([rng.uniform(0, 0.4, (n_tiny, dim)), la[n_tiny:] + 0.25])
    hb = lb + np.concatenate([rng.uniform(0, size, (n_tiny, dim)), np.ones((n_big, dim))])
    return la, ha, lb, hb


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("pad", [0.0, 2e-3, 0.02])
def test_crowded_cell_matches_brute_force(dim, pad):
    rng = np.random.default_rng(dim + int(pad * 1e4))
    n_tiny = 1500 if dim == 2 else 1200
    la, ha, lb, hb = _crowded(rng, n_tiny, 300, dim)
    ref = set(zip(*(x.tolist() for x in box_pairs_bruteforce(la, ha, lb, hb, pad))))
    assert len(ref) > n_tiny // 10  # the case has pairs among the tiny boxes
    assert _pairs(la, ha, lb, hb, pad) == ref
    assert _pairs(la, ha, lb, hb, pad, chunk=777) == ref


def test_crowded_cell_nested_and_identical_boxes():
    """Clusters inside clusters (several refinement levels) and many identical boxes
    (a cell no grid can split: enumerated)."""
    rng = np.random.default_rng(5)
    la, ha, lb, hb = _crowded(rng, 800, 200, 3)
    inner = rng.uniform(0.1, 0.1 + 1e-3, (800, 3))
    same = np.full((300, 3), 0.3)
    la = np.concatenate([la, inner, same])
    ha = np.concatenate([ha, inner + 1e-6, same + 1e-4])
    lb = np.concatenate([lb, inner[::-1] + 1e-7, same])
    hb = np.concatenate([hb, inner[::-1] + 2e-6, same + 1e-4])
    pad = 1e-6
    ref = set(zip(*(x.tolist() for x in box_pairs_bruteforce(la, ha, lb, hb, pad))))
    assert len(ref) > 300 * 300
    assert _pairs(la, ha, lb, hb, pad, chunk=5000) == ref


def test_near_flags_definition():
    """near_flags is a superset of the boxes with a partner within pad."""
    rng = np.random.default_rng(1)
    for trial in range(20):
        la, ha, lb, hb = _crowded(rng, int(rng.integers(1, 400)), int(rng.integers(0, 50)), 3)
        pad = float(rng.choice([0, 1e-3, 0.1]))
        ia, ib = box_pairs_bruteforce(la, ha, lb, hb, pad)
        na, nb = near_flags(la, ha, lb, hb, pad)
        assert na[ia].all() and nb[ib].all()
    with pytest.raises(ValueError, match="pad"):
        near_flags(la, ha, lb, hb, -1.0)
    with pytest.raises(ValueError, match="sides"):
        near_flags(la, ha, lb, hb, 0.0, sides="c")


@pytest.mark.parametrize("dim", [2, 3])
def test_near_flags_dense_equals_expanded(dim, monkeypatch):
    """The summed-area path flags exactly the boxes sharing a grid cell with the other
    side, like the expanded-entries path it replaces on dense grids."""
    import predicates.registration.spatial.broadphase as B
    rng = np.random.default_rng(10 + dim)
    flagged = 0
    for trial in range(25):
        na, nb = rng.integers(1, 300, 2)
        la = rng.random((na, dim))
        ha = la + rng.random((na, dim)) * rng.choice([0, 0.01, 0.2])
        lb = rng.random((nb, dim))
        hb = lb + rng.random((nb, dim)) * rng.choice([0, 0.02, 0.3])
        pad = float(rng.choice([0, 1e-3, 0.05]))
        dense = near_flags(la, ha, lb, hb, pad)
        # one side alone: the same flags, the other side not computed
        assert np.array_equal(near_flags(la, ha, lb, hb, pad, sides="a")[0], dense[0])
        assert near_flags(la, ha, lb, hb, pad, sides="a")[1] is None
        assert np.array_equal(near_flags(la, ha, lb, hb, pad, sides="b")[1], dense[1])
        monkeypatch.setattr(B, "_DENSE", 0)
        expanded = near_flags(la, ha, lb, hb, pad)
        only_a = near_flags(la, ha, lb, hb, pad, sides="a")[0]
        only_b = near_flags(la, ha, lb, hb, pad, sides="b")[1]
        monkeypatch.undo()
        assert np.array_equal(dense[0], expanded[0]) and np.array_equal(dense[1], expanded[1])
        assert np.array_equal(only_a, expanded[0]) and np.array_equal(only_b, expanded[1])
        flagged += dense[0].sum() + dense[1].sum()
    assert flagged > 100


@pytest.mark.parametrize("dim", [2, 3])
def test_tighten_flags_superset_and_tighter(dim):
    """tighten_flags keeps every box with a partner within pad (also for flat inputs:
    one axis of zero extent), and on clustered inputs drops boxes near_flags kept."""
    from predicates.registration.spatial.broadphase import tighten_flags
    rng = np.random.default_rng(20 + dim)
    dropped = 0
    for trial in range(20):
        la, ha, lb, hb = _crowded(rng, int(rng.integers(1, 400)), int(rng.integers(0, 40)), dim,
                                  size=float(rng.choice([1e-3, 0.05])))
        if trial % 4 == 0:  # flat: every box in the plane x = 0.25
            for x in (la, ha, lb, hb):
                x[:, 0] = 0.25
        pad = float(rng.choice([0, 1e-3, 0.02]))
        ia, ib = box_pairs_bruteforce(la, ha, lb, hb, pad)
        na, nb = near_flags(la, ha, lb, hb, pad)
        ta, tb = tighten_flags(la, ha, lb, hb, pad)
        assert ta[ia].all() and tb[ib].all()
        dropped += int((na & ~ta).sum() + (nb & ~tb).sum())
    assert dropped > 0


@pytest.mark.parametrize("dim,k", [(2, 2), (2, 3), (3, 3), (3, 4)])
def test_boxes_of_equals_gathered_min_max(dim, k):
    from predicates.registration.spatial.broadphase import boxes_of
    rng = np.random.default_rng(dim * 10 + k)
    P = rng.normal(size=(500, dim)) * 10.0 ** rng.integers(-300, 300, size=(500, 1))
    rows = rng.integers(0, 500, size=(2000, k)).astype(np.int32)
    lo, hi = boxes_of(P, rows)
    assert np.array_equal(lo, P[rows].min(axis=1)) and np.array_equal(hi, P[rows].max(axis=1))
    P32 = rng.normal(size=(500, dim)).astype(np.float32)
    lo32, _ = boxes_of(P32, rows)
    assert lo32.dtype == np.float64 and np.array_equal(lo32, P32[rows].min(axis=1))


def test_near_flags_do_not_depend_on_the_order_of_the_boxes():
    """The grid size is a mean of the extents, summed in sorted order: permuting the
    boxes permutes the flags (resolution.consistent_scale relies on it for L)."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        n_a, n_b = rng.integers(50, 400, size=2)
        lo_a = rng.random((n_a, 3)) * 10
        hi_a = lo_a + rng.random((n_a, 3)) ** 3 * rng.choice([0.01, 0.1, 3.0])
        lo_b = rng.random((n_b, 3)) * 10
        hi_b = lo_b + rng.random((n_b, 3)) ** 3
        pad = float(rng.choice([0.0, 1e-3, 0.3]))
        fa, fb = near_flags(lo_a, hi_a, lo_b, hi_b, pad)
        pa, pb = rng.permutation(n_a), rng.permutation(n_b)
        ga, gb = near_flags(lo_a[pa], hi_a[pa], lo_b[pb], hi_b[pb], pad)
        assert np.array_equal(ga, fa[pa]) and np.array_equal(gb, fb[pb])


def test_the_grid_size_is_the_same_for_any_order_of_the_boxes():
    from predicates.registration.spatial.broadphase import _mean_extent
    rng = np.random.default_rng(3)
    # one huge extent among many small ones: a sum in another order rounds differently
    ext = np.concatenate([[2.0 ** 53], np.ones(4999), rng.random(5000)])
    lo = np.zeros((len(ext), 3))
    hi = np.repeat(ext[:, None], 3, axis=1)
    h = _mean_extent(lo, hi)
    for _ in range(5):
        p = rng.permutation(len(lo))
        assert _mean_extent(lo[p], hi[p]) == h  # bit for bit


def _random_side(rng, dim, k, n_cells, size):
    """A Side of ``n_cells`` random simplices (k vertices) of about ``size`` sharing
    vertices of a small pool, plus a repeated cell and a collapsed one; its complex
    of every cell."""
    from predicates.registration.levels.complex import Side

    P = rng.uniform(0, 1, (max(k, n_cells // 2), dim))
    P = np.concatenate([P, P[:5] + rng.uniform(-size, size, (5, dim))])
    cells = np.array([rng.choice(len(P), k, replace=False) for _ in range(n_cells)])
    near = np.argsort(((P[:, None] - P[None, cells[:, 0]]) ** 2).sum(-1), axis=0)
    cells[:, 1:] = near[1:k].T  # cells from near neighbours: small, overlapping
    P = np.concatenate([P, np.repeat(P[:1], k, axis=0)])  # a collapsed cell
    cells = np.concatenate([cells, cells[:1], np.arange(len(P) - k, len(P))[None]])
    side = Side(P, cells)
    side.build(np.ones(len(cells), dtype=bool))
    return side


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("chunk", [1 << 20, 37])
@pytest.mark.parametrize("accelerate", [False, True])
def test_face_pairs_from_cell_pairs_equal_box_pairs_per_kind(dim, chunk, accelerate):
    """cell_pairs + FacePairs (the complexes of the cells in some pair within σ+ only;
    faces' candidates derived from the cell pairs, each face proposed by its owner cell
    only) give, per kind, exactly the pairs of all the primitives' boxes within the
    kind's reach — each once; compiled (``accelerate``): the same pairs as numpy's (in
    another order: compiled stage 1 lists a cell's pairs face by face; the kinds sort
    their output), also when stage 1 is kept in many pieces (chunk 37)."""
    if accelerate:
        pytest.importorskip("numba")
    from predicates.catalogue import kinds
    from predicates.registration.spatial.broadphase import boxes_of
    from predicates.registration.levels.facepairs import FacePairs, cell_pairs

    rng = np.random.default_rng(dim * 100 + chunk % 7)
    sim = _random_side(rng, dim, dim + 1, 300, 0.05)
    cut = _random_side(rng, dim, dim, 200, 0.05)
    ks = kinds(dim)
    values = rng.permutation(np.resize([0.0, 0.004, 0.02, 0.05], len(ks)))
    reach = {k.name: float(r) for k, r in zip(ks, values)}
    full = {k: (sim.cx.S[k.i], cut.cx.S[k.j]) for k in ks}  # every cell's faces
    T, C, keep_s, keep_c = cell_pairs(sim.P, sim.cx.S[dim], cut.P, cut.cx.S[dim - 1],
                                      max(reach.values()), chunk)
    assert 0 < keep_s.sum() < len(keep_s)  # some cells have no partner: dropped
    sim.build_unique(sim.cx.S[dim][keep_s])
    cut.build_unique(cut.cx.S[dim - 1][keep_c])
    fp = FacePairs(sim, cut, T, C, reach, ks, chunk, accelerate=accelerate)
    ref = FacePairs(sim, cut, T, C, reach, ks, chunk)  # numpy: the order to match
    total = 0
    for k in ks:
        got = [(tuple(sim.cx.S[k.i][a]), tuple(cut.cx.S[k.j][b]))
               for s, c in fp.candidates(k.name, k.i, k.j) for a, b in zip(s, c)]
        assert sorted(got) == sorted(
            (tuple(sim.cx.S[k.i][a]), tuple(cut.cx.S[k.j][b]))
            for s, c in ref.candidates(k.name, k.i, k.j) for a, b in zip(s, c))
        assert len(got) == len(set(got)), f"{k.name}: a pair was proposed twice"
        S, Q = full[k]
        ia, ib = box_pairs_bruteforce(*boxes_of(sim.P, S), *boxes_of(cut.P, Q), reach[k.name])
        assert set(got) == {(tuple(S[a]), tuple(Q[b])) for a, b in zip(ia, ib)}, k.name
        total += len(got)
    assert total > 200  # the meshes do come close


@pytest.mark.parametrize("n", [7, 2 ** 20, 2 ** 31 - 1])
@pytest.mark.parametrize("w", [1, 2, 3, 4])
def test_unique_rows_equal_numpy_unique(n, w):
    """complex.unique_rows (ids packed into one or several int64 keys, lexsorted)
    gives np.unique(axis=0)'s rows and inverse, also when n^w overflows one key."""
    from predicates.registration.levels.complex import unique_rows

    rng = np.random.default_rng(n % 1000 + w)
    base = rng.integers(0, n, (300, w), dtype=np.int64)
    base[:, 0] = rng.integers(0, 3, 300)  # many rows share their first ids
    rows = base[rng.integers(0, 300, 2000)]  # repeated rows
    u, inv = unique_rows(rows, n)
    ref, ref_inv = np.unique(rows, axis=0, return_inverse=True)
    assert np.array_equal(u, ref) and np.array_equal(inv, ref_inv.ravel())
    assert np.array_equal(u[inv], rows)


@pytest.mark.parametrize("dim", [2, 3])
def test_complex_face_maps_are_the_faces(dim):
    """Complex.face(k, j)[t]: the ids of the j-faces of k-simplex t, ascending — by
    their definition (every (j+1)-subset of the simplex's vertices, looked up)."""
    from itertools import combinations

    rng = np.random.default_rng(dim)
    for k_top, side in ((dim, _random_side(rng, dim, dim + 1, 120, 0.1)),
                        (dim - 1, _random_side(rng, dim, dim, 80, 0.1))):
        cx = side.cx
        for k in range(1, k_top + 1):
            for j in range(k):
                ids = {tuple(r): n for n, r in enumerate(cx.S[j].tolist())}
                ref = [sorted(ids[f] for f in combinations(row, j + 1))
                       for row in cx.S[k].tolist()]
                assert cx.face(k, j).tolist() == ref, (k, j)
