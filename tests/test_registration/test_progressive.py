"""Progressive cuts (predicates.registration.split.progressive, docs/split.md): a
conforming mesh cut again keeps the earlier cut, equals the one-shot split of both cuts
(same pieces, same material corners per original cell, no corner turned back from
virtual to material), and its pieces have the exact volumes."""
from __future__ import annotations

import warnings
from fractions import Fraction

import numpy as np
import pytest

import predicates
from fperr.warnings import ResolutionWarning
from conform_check import closed_surface_volume, incidence, orientation_signs
from cut_cases import axis_plane
from predicates.registration.examples import cube_grid, icosphere, square_grid
from predicates.registration.split.progressive import recut


def _line(axis: int, c: float):
    P = np.zeros((2, 2))
    P[:, axis] = c
    P[:, 1 - axis] = [-0.1, 1.1]
    return P, np.array([[0, 1]])



def _rows_of(keys) -> dict:
    """{key: [indices of its rows]} (one pass: the helpers below stay linear in the
    meshes' sizes)."""
    out: dict = {}
    for i, key in enumerate(keys):
        out.setdefault(key, []).append(i)
    return out


def _vertex_piece(cm, n: int) -> dict:
    """{original vertex: its piece} for the vertices all of whose simplices are in one
    piece (off every cut)."""
    pieces: dict = {}
    for row, p in zip(cm.cells.tolist(), cm.piece.tolist()):
        for v in row:
            if v < n:
                pieces.setdefault(v, set()).add(p)
    return {v: next(iter(ps)) for v, ps in sorted(pieces.items()) if len(ps) == 1}


def _materials_conforming(cm, cells, vp) -> dict:
    """{original cell: {(piece, frozenset of its material corners)}}."""
    by_cell = _rows_of(cm.cell_origin.tolist())
    piece = cm.piece.tolist()
    out = {}
    for c in range(len(cells)):
        ps = {piece[i] for i in by_cell.get(c, ())}
        out[c] = {(p, frozenset(v for v in cells[c].tolist() if vp.get(v) == p))
                  for p in ps}
    return out


def _partition(vp: dict) -> set:
    groups = {}
    for v, p in vp.items():
        groups.setdefault(p, set()).add(v)
    return {frozenset(g) for g in groups.values()}


def _assert_equals_one_shot(P, C, c1, c2, one, exempt=frozenset()):
    """c2 (c1 cut again) against the one-shot split ``one`` of both cuts: the same
    pieces (the same partition of the vertices off both cuts), the same material corners
    per original cell, and no corner turned back from virtual to material. ``exempt``:
    vertices left out of the comparison with ``one`` (the caller shows they lie within
    the registrations' tolerance of a cut, where the two decide independently)."""
    k = C.shape[1]
    vp2 = {v: p for v, p in _vertex_piece(c2, len(P)).items() if v not in exempt}
    vp1 = {}
    for f, row in enumerate(one.cells.tolist()):
        for j, node in enumerate(row):
            v = int(one.node_origin[node])
            if one.material[f, j] and not one.on_cut[v] and v not in exempt:
                vp1[v] = int(one.piece[f])
    assert set(vp1) == set(vp2) and _partition(vp1) == _partition(vp2)
    # the same material corners per original cell (pieces matched by their vertices)
    name2 = {p: min(v for v, q in vp2.items() if q == p) for p in set(vp2.values())}
    name1 = {p: min(v for v, q in vp1.items() if q == p) for p in set(vp1.values())}
    m2 = _materials_conforming(c2, C, vp2)
    frags_of = _rows_of(one.cell_origin.tolist())
    for c in range(len(C)):
        frags = frags_of.get(c, [])
        want = {(name1[int(one.piece[f])],
                 frozenset(int(one.node_origin[one.cells[f, j]]) for j in range(k)
                           if one.material[f, j] and not one.on_cut[one.node_origin[one.cells[f, j]]]
                           and int(one.node_origin[one.cells[f, j]]) not in exempt))
                for f in frags}
        got = {(name2[p], m - exempt) for p, m in m2[c] if m - exempt}
        assert got == {w for w in want if w[1]}, c
    # no corner turned back from virtual to material: each piece's corners in a cell
    # are among those of the piece it came from
    m1 = _materials_conforming(c1, C, _vertex_piece(c1, len(P)))
    parents_of: dict = {}
    for c, p, q in zip(c2.cell_origin.tolist(), c2.piece.tolist(), c2.previous_piece.tolist()):
        parents_of.setdefault((c, p), set()).add(q)
    turned = 0
    for c in range(len(C)):
        before = dict(m1[c])
        for p, m in m2[c]:
            parents = parents_of.get((c, p), set())
            turned += sum(len(m - before.get(q, frozenset())) for q in parents)
    assert turned == 0
    assert np.all(orientation_signs(c2.points, c2.cells) > 0)


def test_two_lines_progressively_equal_the_one_shot_split():
    P, C = square_grid(16)
    a, b = _line(0, 0.421875), _line(1, 0.546875)
    c1 = predicates.intersect(P, C, *a).split().triangulate()
    c2 = recut(c1, *b)
    assert c2.n_pieces == 4
    both = (np.concatenate([a[0], b[0]]), np.concatenate([a[1], b[1] + 2]))
    one = predicates.intersect(P, C, *both).split()
    assert one.n_pieces == 4
    _assert_equals_one_shot(P, C, c1, c2, one)
    area = c2.piece_volumes()
    assert sorted(area.round(12).tolist()) == sorted(
        [float(x * y) for x in (Fraction(27, 64), Fraction(37, 64))
         for y in (Fraction(35, 64), Fraction(29, 64))])


@pytest.fixture(scope="module")
def gmsh_two_planes():
    """The gmsh box cut by z = 0.546875, then by x = 0.421875 (``recut``)."""
    pytest.importorskip("gmsh")
    from cut_cases import gmsh_box_in_box

    P, C, _, _ = gmsh_box_in_box(0.1)
    a, b = axis_plane(2, 0.546875), axis_plane(0, 0.421875)
    c1 = predicates.intersect(P, C, *a).split().tetrahedralize()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResolutionWarning)  # coarse: slivers of c1
        c2 = recut(c1, *b)
    return P, C, [a, b], c1, c2


def _one_shot(P, C, planes):
    Q = np.concatenate([q for q, _ in planes])
    starts = np.cumsum([0] + [len(q) for q, _ in planes[:-1]])
    K = np.concatenate([k + s for (_, k), s in zip(planes, starts)])
    return predicates.intersect(P, C, Q, K).split()


def test_two_planes_on_the_gmsh_box_equal_the_one_shot_split(gmsh_two_planes):
    """The second plane meets the slivers the first left (a coarse re-registration):
    the regions its degenerate points fold are repaired, nothing is refused."""
    P, C, planes, c1, c2 = gmsh_two_planes
    assert c2.n_pieces == 4
    one = _one_shot(P, C, planes)
    assert one.n_pieces == 4
    _assert_equals_one_shot(P, C, c1, c2, one)
    inc = incidence(c2, lambda p: {0} if c2.point_kind[p] != 2 else set())
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == 0, inc


def test_three_planes_on_the_gmsh_box_equal_the_one_shot_split(gmsh_two_planes):
    """The third plane, y = 0.640625, passes within σ+ of a gmsh vertex and of an
    earlier cut point, with cutting edges within τ of them, registered on several of
    their edges at once; those merged crossings are re-decided (split/declump.py) and
    nothing is refused: 8 pieces, equal to the one-shot split of the three planes, every
    simplex positive by exact orientation, faces paired, piece volumes the boxes'."""
    P, C, planes, _, c2 = gmsh_two_planes
    third = axis_plane(1, 0.640625)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResolutionWarning)  # coarse: slivers of c2
        c3 = recut(c2, *third)
    assert c3.n_pieces == 8
    one = _one_shot(P, C, planes + [third])
    assert one.n_pieces == 8
    # a gmsh vertex 1.6e-4 from the third plane: the one-shot registration (L over the
    # cells near all three planes, σ+ 2.5e-4) puts it on the cut, the third recut's
    # (σ+ 2.4e-4) just below it; the comparison leaves out the vertices within σ+ of a
    # plane (exact distances), and only those
    sigma = Fraction(one.source.tolerances_input_units()["sigma"])
    offsets = [(2, Fraction(0.546875)), (0, Fraction(0.421875)), (1, Fraction(0.640625))]
    near = {v for v in range(len(P)) for k, c in offsets
            if abs(Fraction(float(P[v, k])) - c) < sigma}
    assert len(near) <= 4
    _assert_equals_one_shot(P, C, c2, c3, one, exempt=frozenset(near))
    inc = incidence(c3, lambda p: {0} if c3.point_kind[p] != 2 else set())
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == 0, inc
    want = sorted(float(x * y * z) for x in (Fraction(27, 64), Fraction(37, 64))
                  for y in (Fraction(41, 64), Fraction(23, 64))
                  for z in (Fraction(35, 64), Fraction(29, 64)))
    vol = c3.piece_volumes()
    assert abs(vol.sum() - 1.0) <= 1e-12
    # merged points follow the later plane, off the earlier ones by up to σ+ (as in
    # test_three_planes_give_eight_pieces), and 9 degenerate points are moved onto the
    # mesh (≤ σ+ = 2.4e-4): measured ≤ 4.1e-7 per piece, a small fraction of σ+ × the
    # pieces' cut areas (> 0.1)
    got = sorted(vol.tolist())
    assert all(abs(g - w) <= 1e-6 for g, w in zip(got, want)), (got, want)


def test_three_planes_give_eight_pieces():
    P, C = cube_grid(8)
    planes = [axis_plane(2, 0.546875), axis_plane(0, 0.421875), axis_plane(1, 0.640625)]
    cm = predicates.intersect(P, C, *planes[0]).split().tetrahedralize()
    for Q, K in planes[1:]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResolutionWarning)  # coarse: slivers of cm
            cm = recut(cm, Q, K)
    assert cm.n_pieces == 8
    assert np.all(orientation_signs(cm.points, cm.cells) > 0)
    inc = incidence(cm, lambda p: {0} if cm.point_kind[p] != 2 else set())
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == 0, inc
    want = sorted(float(x * y * z) for x in (Fraction(27, 64), Fraction(37, 64))
                  for y in (Fraction(41, 64), Fraction(23, 64))
                  for z in (Fraction(35, 64), Fraction(29, 64)))
    vol = cm.piece_volumes()
    assert abs(vol.sum() - 1.0) <= 1e-12
    # not 1e-12 per piece: where a later plane meets an earlier plane's cut faces its
    # registration merges points within its tolerances (σ+ = 1.4e-4 here), placed on
    # the later plane, off the earlier one by up to that (as in the sphere after a plane)
    got = sorted(vol.tolist())
    assert all(abs(g - w) <= 1e-8 for g, w in zip(got, want)), (got, want)
    assert set(np.unique(cm.cut_round).tolist()) == {0, 1}


def test_a_sphere_after_a_plane_gives_four_pieces():
    P, C = cube_grid(8)
    c1 = predicates.intersect(P, C, *axis_plane(2, 0.546875)).split().tetrahedralize()
    Q, K = icosphere(2)
    cm = recut(c1, Q, K)
    assert cm.n_pieces == 4
    assert np.all(orientation_signs(cm.points, cm.cells) > 0)
    inc = incidence(cm, lambda p: {0} if cm.point_kind[p] != 2 else set())
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == 0, inc
    vol = cm.piece_volumes()
    below = np.zeros(4, dtype=bool)
    for p in range(4):  # a piece is below the plane when its simplices' centroids are
        below[p] = cm.points[cm.cells[cm.piece == p]][:, :, 2].mean() < 0.546875
    sphere = float(closed_surface_volume(Q, K))
    inner = np.argsort(vol)[:2]  # the two halves of the ball are the smallest pieces
    # not 1e-12: where the sphere meets the plane's cut faces the second registration
    # merges points within its tolerances (σ+ = 1.4e-4 of the box here), and the merged
    # points follow the sphere, off the plane by up to that: measured 1.0e-9
    assert abs(vol[below].sum() - 0.546875) <= 1e-8
    assert abs(vol[inner].sum() - sphere) <= 1e-8 * sphere
    assert set(np.unique(cm.cut_round).tolist()) == {0, 1}
