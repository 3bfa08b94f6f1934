"""Cuts along the mesh's faces (docs/split.md, rule 3: faces with every vertex on the
cut) and the split computed near the cut only, against exact ground truth: the side of
every cell is decided in rational arithmetic (``Fraction``) from its centroid, or by the
gmsh volume the cell was meshed in."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import predicates
from cut_cases import box_surface, gmsh_box_in_box, square_loop
from predicates.portable import rotate, rotation
from predicates.registration.examples import (circle_polygon, cube_grid, diagonal_cut,
                                              grid_plane, icosphere, square_grid,
                                              zigzag_cut)
from predicates.registration.split.mesh import split_mesh


def _inside_box(P, cells, lo, hi) -> np.ndarray:
    """+1 / −1: the exact centroid of each cell strictly inside / outside the box
    [lo, hi]^d (cells along the box's faces are never on it)."""
    out = []
    for c in cells.tolist():
        g = [sum(Fraction(float(P[v, k])) for v in c) / len(c) for k in range(P.shape[1])]
        assert all(x not in (lo, hi) for x in g)
        out.append(1 if all(lo < x < hi for x in g) else -1)
    return np.array(out)


def _check_two_sides(sm, side):
    """Two pieces, every new cell in the piece of its cell's exact side, and the
    invariants of docs/split.md (each off-cut vertex one material node)."""
    assert sm.n_pieces == 2
    s = side[sm.cell_origin]
    assert {frozenset(s[sm.piece == p].tolist()) for p in range(2)} == \
        {frozenset({1}), frozenset({-1})}
    mat = np.unique(sm.cells[sm.material])
    per_vertex = np.bincount(sm.node_origin[mat], minlength=len(sm.on_cut))
    assert np.all(per_vertex[~sm.on_cut & (np.bincount(sm.node_origin,
                                                       minlength=len(sm.on_cut)) > 0)] == 1)
    assert np.all(per_vertex[sm.on_cut] == 2)  # each on-cut vertex: one node per side


@pytest.mark.parametrize("flip", [False, True])
def test_kuhn_grid_cut_by_a_box_along_its_faces(flip):
    sim = cube_grid(8)
    res = predicates.intersect(*sim, *box_surface(8, 2, 6, flip))
    sm = res.split()
    assert sm.on_cut.sum() == 5 ** 3 - 3 ** 3
    _check_two_sides(sm, _inside_box(sim[0], sim[1], Fraction(1, 4), Fraction(3, 4)))
    assert len(sm.cells) == len(sim[1])  # the cut runs along faces: no cell is split


def test_square_grid_cut_by_a_square_along_its_edges():
    sim = square_grid(8)
    res = predicates.intersect(*sim, *square_loop(8, 2, 6))
    sm = res.split()
    _check_two_sides(sm, _inside_box(sim[0], sim[1], Fraction(1, 4), Fraction(3, 4)))


def test_a_corner_touching_the_cut_does_not_separate():
    """The half-open square's corner: cells touching the cut at vertices and faces not
    covered by it stay glued (an open polyline along grid edges, a crack: one piece)."""
    sim = square_grid(8)
    P, E = square_loop(8, 2, 6)
    res = predicates.intersect(*sim, P, E[:-4])  # the left side removed: open
    assert res.split().n_pieces == 1


@pytest.mark.parametrize("h", [0.1, 0.05])
def test_gmsh_box_fragment_cut_by_its_interface(h):
    pytest.importorskip("gmsh")
    P, T, tag, F = gmsh_box_in_box(h)
    res = predicates.intersect(P, T, P, F)
    sm = res.split()
    _check_two_sides(sm, np.where(tag == 1, 1, -1))


def _cases():
    P, T = icosphere(2)
    yield cube_grid(6), (rotate(P - 0.5, rotation(3, 3)) + 0.5, T)
    yield cube_grid(4), grid_plane(4)
    yield cube_grid(4), grid_plane(4, offset=True)
    yield cube_grid(8), box_surface(8, 2, 6, True)
    yield cube_grid(6), box_surface(6, 0, 3)  # along the mesh's boundary too
    yield square_grid(10), circle_polygon(37, radius=0.33)
    yield square_grid(8), diagonal_cut(8)
    yield square_grid(8), zigzag_cut(8)
    yield square_grid(8), square_loop(8, 2, 6)
    yield cube_grid(3), icosphere(1, center=(5.0, 5.0, 5.0))


FIELDS = ("cells", "cell_origin", "node_origin", "material", "piece", "n_pieces",
          "hit_offsets", "hit_index", "severed", "on_cut", "points")


@pytest.mark.parametrize("case", range(10))
def test_near_the_cut_equals_everywhere(case):
    sim, cut = list(_cases())[case]
    res = predicates.intersect(*sim, *cut)
    a, b = split_mesh(res), split_mesh(res, near_only=False)
    for f in FIELDS:
        assert np.array_equal(getattr(a, f), getattr(b, f)), f


def _more_cases():
    """Cracks (the cut ends inside the mesh; a circle half outside the square)."""
    P, T = grid_plane(3)
    sheet = P * np.array([0.8, 1.4, 1.0]) + np.array([-0.2, -0.2, 0.013])
    yield cube_grid(4), (sheet, T)
    yield square_grid(8), (np.array([[-0.3, 0.31], [0.3, 0.43], [0.61, 0.38]]),
                           np.array([[0, 1], [1, 2]]))
    Q, E = circle_polygon(29, radius=0.3)
    yield square_grid(7), (Q + 0.5, E)


@pytest.mark.parametrize("case", range(13))
def test_split_equals_the_straightforward_reference(case):
    """Every field of the split equals the rules written with Python loops and dicts
    over every cell and face (tests/support/split_reference.py): the vectorised passes
    (sorts, union-finds, CSR of the points) change nothing."""
    from split_reference import reference_split

    sim, cut = (list(_cases()) + list(_more_cases()))[case]
    res = predicates.intersect(*sim, *cut)
    got, want = split_mesh(res), reference_split(res)
    assert got.n_pieces == want["n_pieces"]
    for f in FIELDS + ("hit_points", "hit_kind", "hit_sim", "hit_weights"):
        assert np.array_equal(getattr(got, f), want[f]), f
