"""The cut surface in the pictures of the split (predicates/registration/split/plot.py,
docs/split.md "Pictures"): every cut polygon is moved with the piece behind it, so a
closed cut bounding a piece moves with that piece as a whole. Sides are decided in exact
rational arithmetic (every float64 coordinate a ``Fraction``)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np

import predicates
from predicates.registration.examples import (circle_polygon, cube_grid, icosphere,
                                              square_grid)
from predicates.registration.split.plot import _surface_polygons
from predicates.registration.split.surface import cut_surface
from cut_cases import axis_plane


def _fr(P):
    return [[Fraction(float(x)) for x in p] for p in P]


def _side(a, b, c, p) -> int:
    """sign of ((b − a) × (c − a))·(p − a), exact (3D); of (b − a) × (p − a) when c is
    None (2D: +1 left of a→b)."""
    u = [y - x for x, y in zip(a, b)]
    w = [y - x for x, y in zip(a, p)]
    if c is None:
        det = u[0] * w[1] - u[1] * w[0]
    else:
        v = [y - x for x, y in zip(a, c)]
        det = (w[0] * (u[1] * v[2] - u[2] * v[1]) - w[1] * (u[0] * v[2] - u[2] * v[0])
               + w[2] * (u[0] * v[1] - u[1] * v[0]))
    return (det > 0) - (det < 0)


def _inside_convex(sim_points, cut_points, cut_cells):
    """(N,) exact: strictly behind every cutting cell of a convex, outward-oriented closed
    cut (3D triangles; 2D counter-clockwise segments: behind = left), after checking that
    it is one (every cut vertex strictly behind every cell it is not on)."""
    Q, S = _fr(cut_points), _fr(sim_points)
    d = len(cut_cells[0])

    def behind(cell, p):
        s = _side(Q[cell[0]], Q[cell[1]], Q[cell[2]] if d == 3 else None, p)
        return s < 0 if d == 3 else s > 0

    for cell in cut_cells.tolist():
        assert all(behind(cell, Q[k]) for k in range(len(Q)) if k not in cell)
    return np.array([all(behind(cell, p) for cell in cut_cells.tolist()) for p in S])


def _material_side(sm, vertex_side):
    """The pieces of the fragments whose material corners are all on the side, and of
    the others."""
    side = vertex_side[sm.node_origin[sm.cells]]
    m = sm.material
    yes = (side | ~m).all(axis=1)
    no = (~side | ~m).all(axis=1)
    assert (yes ^ no).all()  # every fragment on one side (no corner on the cut here)
    return set(sm.piece[yes].tolist()), set(sm.piece[no].tolist())


def _moved_with(sm, cs, explode=0.3):
    """(Q,) the piece whose explode offset moved each drawn polygon (−1: none)."""
    off = sm.explode_offsets(explode)
    out = []
    for q, P in enumerate(_surface_polygons(sm, cs, explode, None)):
        X = cs.points[cs.polygon(q)].astype(np.float64)
        hit = [p for p in range(sm.n_pieces) if np.array_equal(P, X + off[p])]
        out.append(hit[0] if len(hit) == 1 else -1)
    return np.array(out)


def test_a_closed_cut_moves_with_the_ball_it_encloses():
    """cube 6 × icosphere(2): 12 cutting triangles lie in cells with every corner
    outside the ball (a cap of it bulging into the cell), whose only fragment is the
    cube's; they used to be drawn with the cube (on its faces, holes in the ball)."""
    (sp, tets), (cp, tris) = cube_grid(6), icosphere(2)
    res = predicates.intersect(sp, tets, cp, tris)
    sm, cs = res.split(), cut_surface(res)
    inside = _inside_convex(sp, cp, tris)
    ball, cube = _material_side(sm, inside)
    assert len(ball) == 1 and len(cube) == 1 and ball != cube
    # the case the old rule missed is present: a cutting triangle whose every polygon
    # lies in a cell with no corner inside
    grazed = [t for t in np.unique(cs.cut_cell).tolist()
              if not inside[tets[cs.cell[cs.cut_cell == t]]].any()]
    assert len(grazed) == 12
    moved = _moved_with(sm, cs)
    assert len(moved) == len(cs) > 1000
    assert (moved == ball.pop()).all()


def test_a_closed_polygon_moves_with_the_disc_it_encloses():
    (sp, tris), (cp, segs) = square_grid(10), circle_polygon(37, radius=0.33)
    res = predicates.intersect(sp, tris, cp, segs)
    sm, cs = res.split(), cut_surface(res)
    disc, rest = _material_side(sm, _inside_convex(sp, cp, segs))
    assert len(disc) == 1 and len(rest) == 1 and disc != rest
    moved = _moved_with(sm, cs)
    assert len(moved) == len(cs) > 30 and (moved == disc.pop()).all()


def test_a_plane_moves_with_the_half_behind_it():
    """An open cut across the cube (z = 0.45, off the grid): every polygon with the
    half on the side its cutting triangles' normal points away from."""
    (sp, tets), (cp, tris) = cube_grid(4), axis_plane(2, 0.45)
    res = predicates.intersect(sp, tets, cp, tris)
    sm, cs = res.split(), cut_surface(res)
    Q = _fr(cp)
    normal_up = {_side(*(Q[i] for i in t), [q + (k == 2) for k, q in enumerate(Q[t[0]])])
                 for t in tris.tolist()}
    assert len(normal_up) == 1  # one orientation for the whole sheet
    below = np.array([Fraction(float(z)) < Fraction(0.45) for z in sp[:, 2]])
    lower, upper = _material_side(sm, below)
    assert len(lower) == 1 and len(upper) == 1 and lower != upper
    behind = lower if normal_up.pop() > 0 else upper
    moved = _moved_with(sm, cs, explode=0.5)
    assert len(moved) == len(cs) > 20 and (moved == behind.pop()).all()
