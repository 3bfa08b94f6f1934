"""The conforming tetrahedralization (triangulation) of the split
(predicates.registration.split.conform, docs/split.md) against exact ground truth: every
simplex positive in exact arithmetic on its stored coordinates, faces shared by two
simplices of one piece, cut faces by one simplex on each side with the same nodes, closed
piece boundaries, and piece volumes equal to the exact polyhedral volumes."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import predicates
from conform_check import (below_surface_volume, boundary_locator, closed_surface_volume,
                           exact_mesh_volume, incidence, orientation_signs,
                           piece_boundaries, polygon_area, polygon_area_3d)
from predicates.portable import rotation
from predicates.registration.examples import (circle_polygon, cube_grid, grid_plane,
                                              icosphere, square_grid)
from predicates.registration.split.surface import cut_surface
from cut_cases import about_centre, disc_crack, tiny_rotation


def _sphere():
    P, T = icosphere(2)
    return about_centre(P, rotation(3, 3)), T


def _vertex_at(P, x) -> int:
    return int(np.flatnonzero(np.all(P == np.asarray(x), axis=1))[0])


def _piece_of_vertex(cm, v) -> int:
    return int(cm.piece[np.flatnonzero((cm.cells == v).any(axis=1))[0]])


def check(res, cm, want: dict, exact_vs=None):
    """All the invariants; ``want``: {piece: exact volume}."""
    cs = cut_surface(res)
    sign = orientation_signs(cm.points, cm.cells)
    assert (sign <= 0).sum() == 0, f"{(sign == 0).sum()} zero, {(sign < 0).sum()} negative"
    loc = boundary_locator(res, cs)
    inc = incidence(cm, lambda p: loc(cm, p))
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == inc["stray"] == 0, inc
    assert np.all(cm.cut_sides >= 0)
    pb = piece_boundaries(cm)
    assert pb == {"open": 0, "nonmanifold": 0}, pb
    vol = cm.piece_volumes()
    for p, v in want.items():
        assert abs(vol[p] - float(v)) <= 1e-12 * float(v), (p, vol[p], float(v))
    return inc


CASES3 = {
    "plane": lambda n: grid_plane(n),
    "plane_2ulp": lambda n: (about_centre(grid_plane(n)[0], tiny_rotation()),
                             grid_plane(n)[1]),
}


@pytest.mark.parametrize("n", [8, 16])
@pytest.mark.parametrize("name", sorted(CASES3))
def test_kuhn_grid_cut_by_a_plane(name, n):
    P, C = cube_grid(n)
    Q, K = CASES3[name](n)
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 2
    below = below_surface_volume(Q, K)
    bottom = _piece_of_vertex(cm, 0)
    inc = check(res, cm, {bottom: below, 1 - bottom: 1 - below})
    assert inc["cut_faces"] == 2 * n * n  # the plane's triangles, on grid faces
    assert set(np.unique(cm.side).tolist()) <= {-1, 0, 1}


def test_kuhn_grid_cut_by_a_sphere():
    P, C = cube_grid(8)
    Q, K = _sphere()
    res = predicates.intersect(P, C, Q, K)
    sm = res.split()
    cm = sm.tetrahedralize()
    inside = closed_surface_volume(Q, K)
    centre = _piece_of_vertex(cm, _vertex_at(P, (0.5, 0.5, 0.5)))
    check(res, cm, {centre: inside, 1 - centre: 1 - inside})
    # the cut faces tile the sphere: their area is the sphere's, and each lies on the
    # cutting cell it is tagged with (its registered points' cutting primitives)
    cs = cut_surface(res)
    for f, t in zip(cm.cut_faces.tolist(), cm.cut_cell.tolist()):
        tri = set(res.cut_cells[t].tolist())
        for p in f:
            if cm.point_kind[p] == 1:
                assert set(cs.cut[cm.point_hit[p]][cs.cut[cm.point_hit[p]] >= 0].tolist()) <= tri
    X = cm.points[cm.cut_faces]
    area = 0.5 * np.sqrt((np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]) ** 2).sum(1)).sum()
    full = 0.5 * np.sqrt((np.cross(Q[K[:, 1]] - Q[K[:, 0]], Q[K[:, 2]] - Q[K[:, 0]]) ** 2)
                         .sum(1)).sum()
    assert abs(area - full) <= 1e-12 * full
    # the simplices of each new cell of the split fill its fragment: material side
    assert np.array_equal(np.unique(cm.fragment), np.arange(len(sm.cells)))


def test_gmsh_box_cut_by_a_sphere():
    pytest.importorskip("gmsh")
    from cut_cases import gmsh_box_in_box

    P, C, _, _ = gmsh_box_in_box(0.1)
    Q, K = _sphere()
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 2
    inside, total = closed_surface_volume(Q, K), exact_mesh_volume(P, C)
    centre = int(np.argmin(np.abs(cm.piece_volumes() - float(inside))))
    check(res, cm, {centre: inside, 1 - centre: total - inside})


def test_a_crack_inside_the_cube_stays_one_piece():
    """The offset plane ends inside the cube: one piece, its cut faces still paired."""
    P, C = cube_grid(8)
    res = predicates.intersect(P, C, *grid_plane(8, offset=True))
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 1
    check(res, cm, {0: Fraction(1)})


def test_square_grid_cut_by_a_circle():
    P, C = square_grid(8)
    Q, E = circle_polygon(29, radius=0.33)
    Q = about_centre(Q, rotation(2, 5))
    res = predicates.intersect(P, C, Q, E)
    cm = res.split().triangulate()
    assert cm.n_pieces == 2
    inside = polygon_area(Q)
    centre = _piece_of_vertex(cm, _vertex_at(P, (0.5, 0.5)))
    check(res, cm, {centre: inside, 1 - centre: 1 - inside})
    assert len(cm.cut_faces) >= len(E)


def test_uncut_mesh_comes_back_unchanged():
    P, C = cube_grid(3)
    res = predicates.intersect(P, C, *icosphere(1, center=(5.0, 5.0, 5.0)))
    cm = res.split().tetrahedralize()
    assert len(cm.cells) == len(C) and np.array_equal(cm.points, P)
    assert np.all(orientation_signs(cm.points, cm.cells) > 0)


def test_kuhn16_sphere_no_region_refused():
    """Kuhn 16 × the rotated icosphere: 23 regions fold when every degenerate registered
    point sits on the cut (docs/split.md); those points are moved onto their simulation
    primitives (each by at most the tolerance σ) and nothing is refused. Every invariant
    holds exactly, and the pieces' volumes are the exact volume enclosed by the cut faces
    as placed (Fraction), which differs from the sphere's only near the moved points."""
    from predicates.registration.split.tetra_faces import degenerate_on_sim, on_cut_points

    P, C = cube_grid(16)
    Q, K = _sphere()
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 2
    check(res, cm, {})
    moved = np.flatnonzero(cm.point_moved)
    assert 0 < len(moved) < 100
    cs = cut_surface(res)
    deg, on_sim = degenerate_on_sim(res, cs)
    h = cm.point_hit[moved]
    assert np.all(deg[h]) and np.array_equal(cm.points[moved], on_sim[h])
    shift = np.sqrt(((on_sim[h] - on_cut_points(res, cs)[h]) ** 2).sum(axis=1))
    assert shift.max() <= res.tolerances_input_units()["sigma"]
    kept = np.flatnonzero((cm.point_kind == 1) & ~cm.point_moved)
    assert np.array_equal(cm.points[kept], on_cut_points(res, cs)[cm.point_hit[kept]])
    enclosed = closed_surface_volume(cm.points, cm.cut_faces)
    centre = _piece_of_vertex(cm, _vertex_at(P, (0.5, 0.5, 0.5)))
    vol = cm.piece_volumes()
    assert abs(vol[centre] - float(enclosed)) <= 1e-12 * float(enclosed)
    assert abs(vol[1 - centre] - float(1 - enclosed)) <= 1e-12 * float(1 - enclosed)
    sphere = closed_surface_volume(Q, K)
    assert 0 < abs(float(enclosed - sphere)) <= 1e-6 * float(sphere)



def _det3(a, b, c, d) -> Fraction:
    """((b − a) × (c − a))·(d − a) in exact arithmetic (Fraction coordinates)."""
    e = [[y - x for x, y in zip(a, p)] for p in (b, c, d)]
    return (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
            - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
            + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))


def _crossed_cut_faces(cm, lo, hi) -> list:
    """The cut faces the segment [lo, hi] (exact points) meets, by exact orientations on
    the faces' stored coordinates (a float screen first, with a wide margin)."""
    X = cm.points[cm.cut_faces]
    mid = np.array([float(v) for v in lo]) / 2 + np.array([float(v) for v in hi]) / 2
    near = np.flatnonzero(np.all(X.min(axis=1) <= mid + 1e-6, axis=1)
                          & np.all(X.max(axis=1) >= mid - 1e-6, axis=1))
    out = []
    for f in near.tolist():
        a, b, c = ([Fraction(float(v)) for v in p] for p in X[f])
        s_lo, s_hi = _det3(a, b, c, lo), _det3(a, b, c, hi)
        if s_lo * s_hi >= 0:
            continue
        around = [_det3(lo, hi, p, q) for p, q in ((a, b), (b, c), (c, a))]
        if all(x >= 0 for x in around) or all(x <= 0 for x in around):
            out.append(f)
    return out


@pytest.mark.parametrize("n, radius", [(16, 0.5), (16, 3.0), (4, 0.5), (8, 0.5), (4, 1.2)])
def test_a_disc_crack_opens_across_its_whole_area(n, radius):
    """A disc crack of radius h/2 (inside one cell's neighbourhood) and 3h (its front
    crossing dozens of cells: regions with a partial slit, filled around the front by two
    cones joined across the uncut part of the cell, split/crack_front.py) inside Kuhn 16:
    one piece, nothing refused, every invariant exact; the cut faces tile the disc (their
    area is the disc's, exact Fraction area of the fan), and across every cut face the
    two sides have different nodes at every vertex not on the disc's rim (the crack
    front): the material is separated across the whole crack, joined only around its
    front. Exact points of the disc (rational points of its fan triangles, Fraction) are
    each met by a cut face whose two sides are separated there. At n = 4 and 8 the front
    of the h/2 disc runs inside one cell from face to face, an arc no point of the uncut
    part sees: that region is split along the front closed by a path on its faces
    (split/crack_front.py; was refused)."""
    h = 1.0 / n
    P, C = cube_grid(n)
    Q, K = disc_crack(radius * h, (0.5 + 0.3 * h, 0.5 + 0.2 * h, 0.5 + 0.1 * h))
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 1
    check(res, cm, {0: Fraction(1)})
    X = cm.points[cm.cut_faces]
    area = 0.5 * np.sqrt((np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]) ** 2).sum(1)).sum()
    exact = sum(polygon_area_3d(Q[list(t)]) for t in K.tolist())
    # a degenerate point moved onto its simulation primitive (by ≤ σ, docs/split.md)
    # changes the area of each cut face through it by at most σ × its perimeter
    sigma = res.tolerances_input_units()["sigma"]
    moved = cm.point_moved[cm.cut_faces].any(axis=1)
    perimeter = sum(np.sqrt(((X[:, k] - X[:, (k + 1) % 3]) ** 2).sum(1)) for k in range(3))
    assert cm.point_moved.sum() <= 4
    assert abs(area - exact) <= 1e-12 * exact + sigma * perimeter[moved].sum()
    cs = cut_surface(res)
    rim = set(range(1, len(Q)))

    def on_front(p) -> bool:
        if cm.point_kind[p] != 1:
            return False
        ids = cs.cut[cm.point_hit[p]]
        w = cs.cut_weights[cm.point_hit[p]]
        return all(int(i) in rim for i, x in zip(ids, w) if i >= 0 and x != 0)

    _, node = cm.opened()
    inner = 0
    for f, (b, a) in zip(cm.cut_faces.tolist(), cm.cut_sides.tolist()):
        for v in f:
            if on_front(v):
                continue
            kb = int(np.flatnonzero(cm.cells[b] == v)[0])
            ka = int(np.flatnonzero(cm.cells[a] == v)[0])
            assert node[b, kb] != node[a, ka], (f, v)
            inner += 1
    assert inner > 0
    # exact points of the disc, off its rim, each met by an opened cut face
    F = [[Fraction(float(x)) for x in q] for q in Q]
    weights = [(Fraction(1, 3),) * 3, (Fraction(1, 2), Fraction(1, 4), Fraction(1, 4)),
               (Fraction(1, 8), Fraction(5, 8), Fraction(1, 4)),
               (Fraction(1, 8), Fraction(3, 16), Fraction(11, 16))]
    met = 0
    for t in K.tolist():
        a, b, c = (F[i] for i in t)
        normal = [(b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]),
                  (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2]),
                  (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])]
        scale = Fraction(h * 1e-3) / max(abs(x) for x in normal)
        for w in weights:
            x = [w[0] * a[k] + w[1] * b[k] + w[2] * c[k] for k in range(3)]
            lo = [x[k] - scale * normal[k] for k in range(3)]
            hi = [x[k] + scale * normal[k] for k in range(3)]
            faces = _crossed_cut_faces(cm, lo, hi)
            assert faces, (t, w)
            for f in faces:
                b_, a_ = cm.cut_sides[f].tolist()
                assert {node[b_, k] for k in range(4)} != {node[a_, k] for k in range(4)}
                opened = [v for v in cm.cut_faces[f].tolist()
                          if node[b_, cm.cells[b_].tolist().index(v)]
                          != node[a_, cm.cells[a_].tolist().index(v)]]
                assert opened, (t, w, f)
            met += 1
    assert met == len(K) * len(weights)


@pytest.mark.parametrize("n, radius", [(4, 0.05), (8, 0.1)])
def test_a_disc_crack_entirely_inside_one_cell(n, radius):
    """A disc crack entirely inside one cell, off its centre (every registered point a
    cutting vertex inside that one tetrahedron: a closed front). Its two sides alone made
    a zero-volume region (refused); it is now part of the cell's region, filled by a
    bipyramid over the disc and the shell around it (split/crack_front.py). Every
    invariant exact (positive simplices, faces paired, no simplex across the crack, the
    cube's volume), the cut faces tile the disc (exact Fraction area), and across every
    cut face the disc's centre has a different node on each side: the crack opens."""
    h = 1.0 / n
    P, C = cube_grid(n)
    Q, K = disc_crack(radius * h, (0.5 + 0.62 * h, 0.5 + 0.35 * h, 0.5 + 0.2 * h))
    res = predicates.intersect(P, C, Q, K)
    inside = res["tetrahedron_vertex"]
    assert len(inside.sim) == len(Q) and len(np.unique(inside.sim, axis=0)) == 1
    assert sum(len(res[k].sim) for k in res.kinds) == len(Q)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 1
    check(res, cm, {0: Fraction(1)})
    X = cm.points[cm.cut_faces]
    area = sum(polygon_area_3d(x) for x in X)
    exact = sum(polygon_area_3d(Q[list(t)]) for t in K.tolist())
    assert len(cm.cut_faces) == len(K) and abs(area - exact) <= 1e-12 * exact
    centre = int(np.flatnonzero((cm.points == Q[0]).all(axis=1))[0])
    _, node = cm.opened()
    for f, (b, a) in zip(cm.cut_faces.tolist(), cm.cut_sides.tolist()):
        if centre in f:
            kb = cm.cells[b].tolist().index(centre)
            ka = cm.cells[a].tolist().index(centre)
            assert node[b, kb] != node[a, ka]


def test_a_cutting_edge_within_tau_of_a_vertex_is_re_decided():
    """The plane y = 0.640625 on the gmsh box passes 1.6e-4 from a gmsh vertex (σ+ =
    2.4e-4), and an edge of the refined cutting mesh passes over it: the registration
    registers that cutting edge on five edges of the vertex at once (edge_edge), which
    left two coplanar cutting triangles' polygons coinciding or sharing a face chord
    (refused on main). The cluster is re-decided from the stored coordinates
    (split/declump.py): every exact invariant holds, two pieces, and the re-decided
    points are the crossings of their simulation edges with their cutting triangles."""
    pytest.importorskip("gmsh")
    from cut_cases import gmsh_box_in_box

    P, C, _, _ = gmsh_box_in_box(0.1)
    c = 0.640625
    u = np.linspace(-0.1, 1.1, 5)
    U, V = np.meshgrid(u, u, indexing="xy")
    Q = np.column_stack([U.ravel(), np.full(U.size, c), V.ravel()])
    v = (np.arange(4)[None, :] + 5 * np.arange(4)[:, None]).ravel()
    K = np.concatenate([np.stack([v, v + 1, v + 6], 1), np.stack([v, v + 6, v + 5], 1)])
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 2
    check(res, cm, {})
    before, after = cut_surface(res), cm.surface
    changed = np.flatnonzero(before.kind != after.kind[:len(before.kind)])
    assert len(changed) and len(after.kind) > len(before.kind)
    et = list(res.kinds).index("edge_triangle")
    R = np.asarray(res.cut_points)  # the refined cutting mesh the ids refer to
    for h in changed.tolist():  # each now an exact crossing of its edge and triangle
        assert after.kind[h] == et and before.kinds[before.kind[h]] == "edge_edge"
        a, b = ([Fraction(float(x)) for x in P[i]] for i in after.sim[h][:2])
        t = [[Fraction(float(x)) for x in R[i]] for i in after.cut[h][:3]]
        assert _det3(*t, a) * _det3(*t, b) < 0
        around = [_det3(a, b, t[i], t[(i + 1) % 3]) for i in range(3)]
        assert all(x > 0 for x in around) or all(x < 0 for x in around)
    vol = sorted(cm.piece_volumes().tolist())
    assert abs(sum(vol) - 1.0) <= 1e-12
    assert all(abs(g - w) <= 1e-6 for g, w in zip(vol, sorted([1 - c, c]))), vol


@pytest.mark.parametrize("subdivisions, cell, radius", [(0, 37, 0.01), (1, 37, 0.01),
                                                        (1, 200, 0.002), (2, 91, 0.005)])
def test_a_closed_surface_inside_one_cell_bounds_an_inclusion(subdivisions, cell, radius):
    """An icosphere strictly inside one tetrahedron of Kuhn 4 (an inclusion smaller than a
    cell; every registered point a cutting vertex inside that one cell). The material
    around it was refused (no cone fills a cell with a cavity); it is now filled by the
    beneath-beyond construction from the cavity (split/enclosed.py). Every invariant
    exact; two pieces, the inclusion's exact volume the polyhedron's (Fraction), the
    cube's exactly 1; every point of the surface has a different node on each side."""
    P, C = cube_grid(4)
    Q, K = icosphere(subdivisions)
    Q = P[C[cell]].mean(axis=0) + radius * Q
    res = predicates.intersect(P, C, Q, K)
    assert len(res["tetrahedron_vertex"].sim) == len(Q)
    assert np.all(res["tetrahedron_vertex"].sim[:, 0] == res["tetrahedron_vertex"].sim[0, 0])
    cm = res.split().tetrahedralize()
    assert cm.n_pieces == 2
    check(res, cm, {})
    vols = sorted(exact_mesh_volume(cm.points, cm.cells[cm.piece == p]) for p in (0, 1))
    assert vols == [closed_surface_volume(Q, K), 1 - closed_surface_volume(Q, K)]
    _, node = cm.opened()
    for f, (b, a) in zip(cm.cut_faces.tolist(), cm.cut_sides.tolist()):
        for v in f:
            assert node[b, cm.cells[b].tolist().index(v)] != node[a, cm.cells[a].tolist().index(v)]
    assert len(cm.cut_faces) == len(K)
