"""The embedded cut surface (predicates.registration.split.surface, docs/split.md)
against exact clipping in rational arithmetic (tests/support/exact_clip.py): the
polygon of every (cell, cutting cell) with positive area, its vertices as registered
points in cyclic order and orientation; watertight surfaces; tiled cutting triangles."""
from __future__ import annotations

import collections

import numpy as np
import pytest

import predicates
from exact_clip import clipped, fr, polygon_area2
from predicates.portable import rotation
from predicates.registration.examples import (circle_polygon, cube_grid, grid_plane,
                                              icosphere, square_grid)
from predicates.registration.split.surface import cut_surface
from cut_cases import about_centre, tiny_rotation


#: the kinds of a cut in general position (a cutting edge through a face, a simulation
#: edge through a cutting triangle, a cutting vertex inside a cell)
GENERIC = ("triangle_edge", "edge_triangle", "tetrahedron_vertex")


def CASES():
    P, T = icosphere(2)
    return {
        "sphere": (cube_grid(4), (about_centre(P, rotation(3, 3)), T)),
        "plane": (cube_grid(4), grid_plane(4)),
        "plane_2ulp": (cube_grid(4), (about_centre(grid_plane(4)[0], tiny_rotation()),
                                      grid_plane(4)[1])),
        "plane_offset": (cube_grid(4), grid_plane(4, offset=True)),
        "circle": (square_grid(8), (about_centre(circle_polygon(29, radius=0.33)[0],
                                                  rotation(2, 5)),
                                    circle_polygon(29, radius=0.33)[1])),
    }


def _keys(cs, q):
    return [(frozenset(cs.sim[h][cs.sim[h] >= 0].tolist()),
             frozenset(cs.cut[h][cs.cut[h] >= 0].tolist())) for h in cs.polygon(q)]


def _exact_polygons(res):
    """{(cell, cutting cell): [(sim ids, cut ids)] in the cutting cell's orientation}
    for every pair with a positive-area (3D) / positive-length (2D) exact clip."""
    P, C, Q, K = res.sim_points, res.sim_cells, res.cut_points, res.cut_cells
    blo, bhi = P[C].min(axis=1), P[C].max(axis=1)
    tlo, thi = Q[K].min(axis=1), Q[K].max(axis=1)
    out = {}
    for t in range(len(K)):
        for c in np.flatnonzero(np.all((blo <= thi[t]) & (bhi >= tlo[t]), axis=1)).tolist():
            poly = clipped([fr(Q[i]) for i in K[t]], [fr(P[i]) for i in C[c]])
            pts = [p for p, _, _ in poly]
            if res.dim == 3 and (len(pts) < 3 or polygon_area2(pts) == 0):
                continue
            if res.dim == 2 and (len(pts) < 2 or pts[0] == pts[1]):
                continue
            out[c, t] = [(frozenset(C[c][sorted(s)].tolist()), frozenset(K[t][sorted(u)].tolist()))
                         for _, s, u in poly]
    return out


def _within(r, e) -> bool:
    """Registered point r stands for exact point e: its primitives are faces of e's."""
    return r[0] <= e[0] and r[1] <= e[1]


def _registered_in(cs, res, c, t):
    cell, tri = set(res.sim_cells[c].tolist()), set(res.cut_cells[t].tolist())
    keys = [(frozenset(cs.sim[h][cs.sim[h] >= 0].tolist()),
             frozenset(cs.cut[h][cs.cut[h] >= 0].tolist())) for h in range(len(cs.points))]
    return [k for k in keys if k[0] <= cell and k[1] <= tri]


def _merges(got, want):
    """How many exact points the registration merged into their neighbours, when the
    cyclic sequence ``got`` is ``want`` (same orientation) with runs of consecutive
    points each replaced by one registered point on a common face of their primitives
    (a degenerate pair registered instead of several); None when it is not."""
    for r in range(len(want)):
        e = want[r:] + want[:r]
        j = 0
        for i, g in enumerate(got):
            if j >= len(e) or not _within(g, e[j]):
                break
            j += 1
            while (j < len(e) and _within(g, e[j])
                   and not (i + 1 < len(got) and got[i + 1] == e[j])):
                j += 1
        else:
            if j == len(e):
                return len(want) - len(got)
    return None


@pytest.mark.parametrize("name,most", [("sphere", 0.02), ("plane", 0), ("plane_offset", 0),
                                       ("plane_2ulp", 1), ("circle", 0.02)])
def test_polygons_match_exact_clipping(name, most):
    """``most``: the largest fraction of exact points merged (the plane rotated by 2 ulp
    is registered on the grid's vertices: its polygons are the faces')."""
    sim, cut = CASES()[name]
    res = predicates.intersect(*sim, *cut)
    cs = cut_surface(res)
    exact = _exact_polygons(res)
    got = {(int(cs.cell[q]), int(cs.cut_cell[q])): q for q in range(len(cs))}
    assert len(exact) > 10
    matched, merged, total = set(), 0, 0
    for (c, t), want in exact.items():
        q = got.get((c, t))
        if q is None:  # a polygon in a face: kept once, in the other cell
            cell = set(res.sim_cells[c].tolist())
            q = next((q for (c2, t2), q in got.items() if t2 == t and cs.on_face[q]
                      and all(k[0] <= cell for k in _keys(cs, q))), None)
        if q is None:  # a sliver the registration merged into fewer than d points
            reg = _registered_in(cs, res, c, t)
            assert len(reg) < res.dim and all(any(_within(r, e) for r in reg) for e in want)
            merged, total = merged + len(want) - len(reg), total + len(want)
            continue
        m = _merges(_keys(cs, q), want)
        assert m is not None, (c, t, _keys(cs, q), want)
        merged, total = merged + m, total + len(want)
        matched.add(q)
    assert matched == set(range(len(cs)))  # and nothing else is returned
    assert merged <= most * total  # merges are the degenerate exception


@pytest.mark.parametrize("name", ["sphere", "plane", "plane_2ulp", "plane_offset"])
def test_surface_is_watertight_and_tiles_every_cutting_triangle(name):
    sim, cut = CASES()[name]
    res = predicates.intersect(*sim, *cut)
    cs = cut_surface(res)
    K = res.cut_cells
    for t in range(len(K)):
        edges = collections.Counter()
        for q in np.flatnonzero(cs.cut_cell == t).tolist():
            p = cs.polygon(q).tolist()
            edges.update(zip(p, p[1:] + p[:1]))
        assert all(n == 1 for n in edges.values())
        for a, b in edges:
            if (b, a) in edges:
                continue
            # an open edge lies on the triangle's boundary: both points on one of its edges
            ids = set(cs.cut[a][cs.cut[a] >= 0].tolist()) | set(cs.cut[b][cs.cut[b] >= 0].tolist())
            assert len(ids) <= 2, (t, a, b)
    # the polygons of a triangle tile it (the surface lies inside the cube)
    X = cs.points
    area = np.zeros(len(K))
    for q in range(len(cs)):
        p = X[cs.polygon(q)]
        a = np.cross(p[1:-1] - p[0], p[2:] - p[0]).sum(axis=0)
        area[cs.cut_cell[q]] += 0.5 * np.sqrt((a * a).sum())
    Q = res.cut_points
    full = 0.5 * np.linalg.norm(np.cross(Q[K[:, 1]] - Q[K[:, 0]], Q[K[:, 2]] - Q[K[:, 0]]), axis=1)
    if name == "sphere":
        # exact up to rounding where every point is a generic crossing; elsewhere a
        # degenerate pair moved points by at most the registration's tolerance σ
        generic = {res.kinds.index(k) for k in GENERIC}
        exact_tri = np.ones(len(K), dtype=bool)
        for q in range(len(cs)):
            if not set(cs.kind[cs.polygon(q)].tolist()) <= generic:
                exact_tri[cs.cut_cell[q]] = False
        assert exact_tri.mean() > 0.7
        assert np.allclose(area[exact_tri], full[exact_tri], rtol=1e-12, atol=0)
        per = sum(np.linalg.norm(Q[K[:, (i + 1) % 3]] - Q[K[:, i]], axis=1) for i in range(3))
        assert np.all(np.abs(area - full) <= per * res.tolerances.values["sigma"])
    # the closed sphere: every edge of the whole surface is matched by its reverse
    if name == "sphere":
        alle = collections.Counter()
        for q in range(len(cs)):
            p = cs.polygon(q).tolist()
            alle.update(zip(p, p[1:] + p[:1]))
        assert all((b, a) in alle for a, b in alle)


def test_input_cutting_cells_through_the_refinement():
    sim = cube_grid(12)
    cut = icosphere(1)  # coarse: refined against the cells
    res = predicates.intersect(*sim, *cut)
    assert res.cut_refined
    cs = cut_surface(res)
    ref = res.refinement
    assert np.array_equal(cs.input_cut_cell, ref.cut_origin[cs.cut_cell])
    assert set(cs.input_cut_cell.tolist()) == set(range(len(cut[1])))
