"""The virtual-node split (predicates.registration.split.mesh, issue 15) against exact ground truth.

Sides are decided in exact rational arithmetic (every float64 coordinate is a
``Fraction``): inside a closed triangle mesh by exact ray parity along +x (a ray that
meets an edge or vertex of the mesh raises, instead of guessing), inside a closed
polygon by the exact half-open crossing rule, and the side of a height-field cut
(a tilted plane, a polyline over x) by exact barycentric interpolation.
"""
from __future__ import annotations

import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import circle_polygon, cube_grid, grid_plane, icosphere, square_grid
from predicates.portable import cos_sin, rotate, rotation
from predicates.registration.split.rules import (components, match_rows, row_components,
                                                 sort_rows)

ROOT = Path(__file__).resolve().parents[2]


# -- exact ground truth ---------------------------------------------------------------------
def _fr(p):
    return tuple(Fraction(float(x)) for x in p)


def _sgn(x):
    return (x > 0) - (x < 0)


def inside_closed_surface(q, P, T) -> int:
    """+1 inside, −1 outside, 0 on the closed triangle mesh (P, T): exact parity of the
    crossings of the ray q + t·(1, 0, 0), t > 0."""
    lo, hi = P[T].min(axis=1), P[T].max(axis=1)  # float comparisons are exact
    cand = np.flatnonzero((lo[:, 1] <= q[1]) & (q[1] <= hi[:, 1]) & (lo[:, 2] <= q[2])
                          & (q[2] <= hi[:, 2]) & (hi[:, 0] >= q[0]))
    qf, count = _fr(q), 0
    for t in cand:
        a, b, c = (tuple(x - y for x, y in zip(_fr(P[i]), qf)) for i in T[t])
        s = [u[1] * v[2] - u[2] * v[1] for u, v in ((a, b), (b, c), (c, a))]
        if 0 in s:
            raise AssertionError(f"ray from {q} meets an edge or vertex: pick another case")
        if len({_sgn(x) for x in s}) > 1:
            continue
        n = [(b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]),
             (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2]),
             (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])]
        h = sum(ni * ai for ni, ai in zip(n, a))  # n·(a − q): same sign as n_x ⇔ t > 0
        if h == 0:
            return 0
        count += _sgn(h) == _sgn(n[0])
    return 1 if count % 2 else -1


def inside_polygon(q, P, E) -> int:
    """+1 inside, −1 outside, 0 on the closed polygon with segments E (exact)."""
    x, y = _fr(q)
    count = 0
    for i, j in E:
        (ax, ay), (bx, by) = _fr(P[i]), _fr(P[j])
        if ((bx - ax) * (y - ay) - (by - ay) * (x - ax) == 0
                and min(ax, bx) <= x <= max(ax, bx) and min(ay, by) <= y <= max(ay, by)):
            return 0
        if (ay > y) != (by > y):
            count += ax + (y - ay) * (bx - ax) / (by - ay) > x
    return 1 if count % 2 else -1


def side_of_height_field(q, P, cells) -> int:
    """sign(q_last − f(q_rest)) for the piecewise-linear height field (P, cells) over the
    first d − 1 coordinates (2D: segments over x; 3D: triangles over xy), exact."""
    qf = _fr(q)
    for c in cells:
        V = [_fr(P[i]) for i in c]
        if len(V) == 2:
            (ax, ay), (bx, by) = V
            if min(ax, bx) <= qf[0] <= max(ax, bx):
                return _sgn(qf[1] - (ay + (qf[0] - ax) * (by - ay) / (bx - ax)))
            continue
        a, b, cc = V
        u, v, w = [b[k] - a[k] for k in (0, 1)], [cc[k] - a[k] for k in (0, 1)], \
            [qf[k] - a[k] for k in (0, 1)]
        det = u[0] * v[1] - u[1] * v[0]
        l1, l2 = (w[0] * v[1] - w[1] * v[0]) / det, (u[0] * w[1] - u[1] * w[0]) / det
        if l1 >= 0 and l2 >= 0 and l1 + l2 <= 1:
            return _sgn(qf[2] - (a[2] + l1 * (b[2] - a[2]) + l2 * (cc[2] - a[2])))
    raise AssertionError(f"{q} is outside the height field's domain")


# -- cases ----------------------------------------------------------------------------------
def rotated(P, R):
    """P rotated by R about the unit cube's centre, the same bits on every machine."""
    return rotate(P - 0.5, R) + 0.5


def tilted_sheet(x_max=1.6, m=6, tilt=0.35):
    """A triangulated square [−0.6, x_max] × [−0.6, 1.6] at z = ½, rotated about the cube
    centre by ``tilt`` radians about the axis (1, 2, 0)/√5: a height field over xy."""
    P, T = grid_plane(m - 1)
    P = P.copy()
    P[:, 0] = -0.6 + (x_max + 0.6) * P[:, 0]
    P[:, 1] = -0.6 + 2.2 * P[:, 1]
    k = np.array([1.0, 2.0, 0.0]) / np.sqrt(5.0)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    KK = rotate(K, K.T)  # K·K
    (c,), (s,) = cos_sin(np.array([tilt]))
    R = np.eye(3) + s * K + (1 - c) * KK
    return rotated(P, R), T


def polyline(xs, ys):
    P = np.stack([xs, ys], 1).astype(np.float64)
    a = np.arange(len(P) - 1)
    return P, np.stack([a, a + 1], 1)


def split_of(sim, cut):
    res = predicates.intersect(*sim, *cut)
    return res, res.split()


# -- checks ---------------------------------------------------------------------------------
def check_split(res, sm, n_pieces, side=None):
    """The invariants of the split; with ``side`` (exact, per vertex: −1, 0, +1) also the
    on-cut vertices and that each piece's material vertices lie on one exact side."""
    cells, N = res.sim_cells, len(res.sim_points)
    assert sm.n_pieces == n_pieces
    assert np.array_equal(sm.node_origin[sm.cells], cells[sm.cell_origin])
    assert np.array_equal(sm.points, res.sim_points[sm.node_origin])
    assert np.array_equal(np.unique(sm.cell_origin), np.arange(len(cells)))
    assert np.array_equal(np.unique(sm.piece), np.arange(n_pieces))
    on = sm.on_cut if side is None else side == 0
    if side is not None:
        assert np.array_equal(sm.on_cut, on)
    # the copies of every cell cover each off-cut corner exactly once as material;
    # on-cut corners are material in every copy (docs/split.md, rule 2)
    cover = np.zeros(cells.shape, dtype=np.int64)
    np.add.at(cover, sm.cell_origin, sm.material.astype(np.int64))
    copies = np.bincount(sm.cell_origin)[:, None] * np.ones_like(cells)
    off = ~on[cells]
    assert np.all(cover[off] == 1) and np.all(cover[~off] == copies[~off])
    # every off-cut vertex has exactly one material node
    mat = np.unique(sm.cells[sm.material])
    per_vertex = np.bincount(sm.node_origin[mat], minlength=N)
    assert np.all(per_vertex[~on] == 1)
    if side is None:
        return
    f, k = np.nonzero(sm.material)
    s = side[cells[sm.cell_origin[f], k]]
    sides = [set(s[(sm.piece[f] == p) & (s != 0)].tolist()) for p in range(n_pieces)]
    assert all(len(x) == 1 for x in sides), sides
    if n_pieces == 2:
        assert sides[0] != sides[1]
        # on-cut vertices (all touch both sides here): one material node per side.
        # (Two copies of one cell may share a piece: two same-side corners separated
        # inside the cell, e.g. by a convex cut bulging through their edge.)
        assert np.all(per_vertex[on] == 2)


# -- 3D -------------------------------------------------------------------------------------
def test_cube_cut_by_rotated_icosphere_two_pieces():
    sim = cube_grid(6)
    P, T = icosphere(2)
    cut = (rotated(P, rotation(3, 3)), T)
    res, sm = split_of(sim, cut)
    side = np.array([inside_closed_surface(q, *cut) for q in sim[0]])
    assert np.all(side != 0) and (side > 0).sum() > 8  # a real ball of vertices inside
    check_split(res, sm, 2, side)
    assert len(sm.cells) > len(sim[1])  # cells were cut into fragments


@pytest.mark.parametrize("case", ["rotated", "grid"])
def test_cube_cut_by_plane_two_pieces(case):
    sim = cube_grid(4)
    cut = tilted_sheet() if case == "rotated" else grid_plane(4)
    res, sm = split_of(sim, cut)
    side = np.array([side_of_height_field(q, *cut) for q in sim[0]])
    if case == "grid":  # every vertex of z = ½ registered on the cut, no cell split
        assert (side == 0).sum() == 25 and len(sm.cells) == len(sim[1])
    else:
        assert np.all(side != 0) and len(sm.cells) > len(sim[1])
    check_split(res, sm, 2, side)


def test_cube_crack_one_piece():
    sim = cube_grid(4)
    res, sm = split_of(sim, tilted_sheet(x_max=0.55))  # the sheet ends inside the cube
    assert len(sm.cells) > len(sim[1])  # cells along the crack are split ...
    check_split(res, sm, 1)  # ... but the material goes round the crack tip


def test_cube_far_cut_no_duplication():
    sim = cube_grid(3)
    res, sm = split_of(sim, icosphere(1, center=(5.0, 5.0, 5.0)))
    check_split(res, sm, 1)
    assert np.array_equal(sm.cell_origin, np.arange(len(sim[1])))
    assert np.array_equal(sm.node_origin, np.arange(len(sim[0])))
    assert sm.material.all() and len(sm.hit_points) == 0


# -- 2D -------------------------------------------------------------------------------------
def test_square_cut_by_rotated_polygon_two_pieces():
    sim = square_grid(10)
    P, E = circle_polygon(37, radius=0.33)
    cut = (rotated(P, rotation(2, 5)), E)
    res, sm = split_of(sim, cut)
    side = np.array([inside_polygon(q, *cut) for q in sim[0]])
    assert np.all(side != 0) and (side > 0).sum() > 8
    check_split(res, sm, 2, side)


@pytest.mark.parametrize("case", ["tilted", "diagonal"])
def test_square_cut_by_polyline_two_pieces(case):
    sim = square_grid(8)
    if case == "tilted":
        cut = polyline([-0.3, 0.2, 0.55, 0.9, 1.3], [0.31, 0.43, 0.38, 0.61, 0.57])
    else:  # y = x through grid vertices, on the mesh's diagonal edges
        cut = polyline([-0.25, 1.25], [-0.25, 1.25])
    res, sm = split_of(sim, cut)
    side = np.array([side_of_height_field(q, *cut) for q in sim[0]])
    assert (side == 0).sum() == (9 if case == "diagonal" else 0)
    check_split(res, sm, 2, side)


def test_square_crack_and_far_cut_one_piece():
    sim = square_grid(8)
    res, sm = split_of(sim, polyline([-0.3, 0.3, 0.61], [0.31, 0.43, 0.38]))
    assert len(sm.cells) > len(sim[1])
    check_split(res, sm, 1)
    res, sm = split_of(sim, polyline([3.0, 4.0], [3.0, 4.5]))
    check_split(res, sm, 1)
    assert len(sm.cells) == len(sim[1]) and len(sm.points) == len(sim[0])


# -- the intersection points and the union-find ---------------------------------------------
def test_hits_on_each_cell_match_brute_force():
    sim = square_grid(6)
    res, sm = split_of(sim, circle_polygon(23, radius=0.3))
    want = np.concatenate([res[k].points(res.sim_points) for k in res.kinds if len(res[k])])
    assert np.array_equal(sm.hit_points, want)
    prims = [frozenset(r[r >= 0].tolist()) for r in sm.hit_sim]
    for f in range(len(sm.cells)):
        cell = set(res.sim_cells[sm.cell_origin[f]].tolist())
        assert sorted(sm.hits_of(f).tolist()) == [h for h, p in enumerate(prims) if p <= cell]
    assert sm.hit_offsets[-1] > len(sm.hit_points)  # points shared by several cells


def _bfs_smallest(n, rows):
    """The smallest member of each node's component, rows joining their entries (BFS)."""
    adj = [[] for _ in range(n)]
    for r in rows:
        for x, y in zip(r[:-1], r[1:]):
            adj[x].append(y)
            adj[y].append(x)
    want = np.full(n, -1)
    for s in range(n):
        if want[s] < 0:
            want[s], stack = s, [s]
            while stack:
                for y in adj[stack.pop()]:
                    if want[y] < 0:
                        want[y] = s
                        stack.append(y)
    return want


def test_components_against_breadth_first_search():
    rng = np.random.default_rng(0)
    for n, m in [(1, 0), (50, 0), (200, 150), (200, 400), (1000, 999)]:
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        if n == 1000:  # a path with shuffled labels: the long-diameter case
            perm = rng.permutation(n)
            a, b = perm[:-1], perm[1:]
        want = _bfs_smallest(n, list(zip(a.tolist(), b.tolist())))
        assert np.array_equal(components(n, a, b), want)


@pytest.mark.parametrize("width", [1, 2, 3, 4])
def test_row_components_against_breadth_first_search(width):
    """Rows of 1–4 entries (a cell's nodes): random graphs, a grid's triangles with
    shuffled labels (several rounds of contraction) and rows with repeated entries."""
    rng = np.random.default_rng(width)
    cases = [(1, np.zeros((0, width), int)), (300, rng.integers(0, 300, (120, width))),
             (300, rng.integers(0, 300, (400, width))),
             (40, np.repeat(rng.integers(0, 40, (15, 1)), width, axis=1))]
    P, T = square_grid(12)
    perm = rng.permutation(len(P))
    cases.append((len(P), perm[T][:, :width] if width <= 3 else
                  np.column_stack([perm[T], perm[T][:, :1]])))
    for n, rows in cases:
        want = _bfs_smallest(n, rows.tolist())
        got = row_components(n, [rows[:, j] for j in range(width)])
        assert got.dtype == np.int64 and np.array_equal(got, want)


def test_match_rows_against_brute_force():
    """Every (row, table row) pair of equal rows, by row then table row, with ids small
    and large (keys of n^w ≥ 2^62: the ids renumbered among the table's)."""
    rng = np.random.default_rng(4)
    for n, w in [(10, 2), (100000, 4), (3000000, 3), (60, 4)]:
        table = np.sort(rng.integers(0, min(n, 60), (40, w)), axis=1)
        table = np.concatenate([table, table[:5]])  # repeated rows: every copy matched
        rows = np.concatenate([table[rng.integers(0, len(table), 30)],
                               np.sort(rng.integers(0, min(n, 60), (200, w)), axis=1)])
        rows[-1, -1] = n - 1  # an id no table row holds
        want = [(i, j) for i, r in enumerate(rows.tolist())
                for j, t in enumerate(table.tolist()) if r == t]
        i, j = match_rows(rows, table, n)
        assert list(zip(i.tolist(), j.tolist())) == want and len(want) > 30


def test_sort_rows_equals_numpy_sort():
    rng = np.random.default_rng(3)
    for w in (1, 2, 3, 4, 5):
        for hi in (2, 1000, 2 ** 40):
            x = rng.integers(0, hi, (300, 6, w))
            assert np.array_equal(sort_rows(x), np.sort(x, axis=-1))
            assert np.array_equal(sort_rows(x[:, 0]), np.sort(x[:, 0], axis=1))


# -- the command ------------------------------------------------------------------------------
def _write(tmp_path, sim, cut):
    s, c = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sim[0], [("tetra", sim[1])]).write(s)
    meshio.Mesh(cut[0], [("triangle", cut[1])]).write(c)
    return str(s), str(c)


def _fperr(*args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)


def test_cli_cut_writes_pieces_and_refuses_formats_without_cell_data(tmp_path):
    sim, cut = cube_grid(4), grid_plane(4)
    s, c = _write(tmp_path, sim, cut)
    out, png = tmp_path / "pieces.vtu", tmp_path / "pieces.png"
    r = _fperr("cut", s, c, "-o", str(out), "--png", str(png), "--explode", "0.2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert "2 pieces" in r.stdout
    back = meshio.read(out)
    piece = back.cell_data["piece"][0]
    assert sorted(set(piece.tolist())) == [0, 1]
    assert {"cell_origin", "material"} <= set(back.cell_data)
    assert len(piece) == len(sim[1]) and len(back.points) == len(sim[0]) + 25
    assert png.read_bytes()[:4] == b"\x89PNG"
    for bad in ("pieces.stl", "pieces.msh", "pieces"):
        r = _fperr("cut", s, c, "-o", str(tmp_path / bad), "--quiet")
        assert r.returncode == 2 and "cell data" in r.stderr
        assert not (tmp_path / bad).exists()
