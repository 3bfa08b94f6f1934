"""A 2D crack ending inside a cell (docs/split.md, "The conforming tetrahedralization",
"A crack tip inside a cell"; split/slit_fill.py): the region holding the tip — the cell
with a slit from an edge to an interior point — is triangulated, not refused. Every
check exact: triangles positive (Fraction orientation), the square tiled (the triangles'
exact areas sum to 1, faces paired; each cell's up to its edge points' rounding), no
triangle's interior meets a cut face, the crack opens (distinct nodes on its two sides except at its tips)."""
from __future__ import annotations

from fractions import Fraction

import meshio
import numpy as np
import pytest

import predicates
from conform_check import (boundary_locator, exact_mesh_volume, incidence,
                           orientation_signs, piece_boundaries)
from predicates.registration.examples import square_grid
from predicates.registration.split.surface import cut_surface

POLYLINE = np.array([(0.23, 0.41), (0.5, 0.52), (0.77, 0.47)])


def _orient(a, b, c) -> Fraction:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _crosses(tri, seg) -> bool:
    """The open segment meets the open triangle (counter-clockwise), exactly: the set of
    t in (0, 1) with every edge's orientation of s(t) > 0 (linear in t) is not empty."""
    p, q = seg
    lo, hi = Fraction(0), Fraction(1)
    for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
        f0, f1 = _orient(a, b, p), _orient(a, b, q)  # f(t) = f0 + t (f1 − f0) > 0
        if f1 == f0:
            if f0 <= 0:
                return False
            continue
        t = f0 / (f0 - f1)
        lo, hi = (max(lo, t), hi) if f1 > f0 else (lo, min(hi, t))
        if lo >= hi:
            return False
    return True


def check_crack(P, C, Q, K, tips=None, opens: bool = True):
    """Conform the cut (Q, K) of (P, C) and check every property of the module
    docstring exactly; returns the conforming mesh. ``tips``: the crack's ends (its
    first and last point by default; none for a closed crack); ``opens``: some node
    of the crack, not a tip, is duplicated (a single segment has none)."""
    res = predicates.intersect(P, C, Q, K)
    cm = res.split().tetrahedralize()
    assert np.all(orientation_signs(cm.points, cm.cells) > 0)
    loc = boundary_locator(res, cut_surface(res))
    inc = incidence(cm, lambda p: loc(cm, p))
    assert inc["bad_interior"] == inc["cut_unpaired"] == inc["over"] == inc["stray"] == 0, inc
    assert piece_boundaries(cm) == {"open": 0, "nonmanifold": 0}
    assert exact_mesh_volume(cm.points, cm.cells) == Fraction(1)
    # per cell up to rounding only: a registered point on an edge is on it up to rounding
    # (shared by both cells, so the total above is exact)
    for c in np.unique(cm.cell_origin).tolist():
        mine = exact_mesh_volume(cm.points, cm.cells[cm.cell_origin == c])
        assert abs(mine - exact_mesh_volume(P, C[[c]])) <= Fraction(1, 2 ** 50), c
    F = [[Fraction(float(x)) for x in p] for p in cm.points]
    for f in cm.cut_faces.tolist():
        lo, hi = cm.points[f].min(axis=0), cm.points[f].max(axis=0)
        box = cm.points[cm.cells]
        near = np.flatnonzero(np.all(box.min(axis=1) <= hi, axis=1)
                              & np.all(box.max(axis=1) >= lo, axis=1))
        for t in near.tolist():
            assert not _crosses([F[v] for v in cm.cells[t]], [F[v] for v in f]), (t, f)
    ends = (Q[0], Q[-1]) if tips is None else tips
    tips = {int(v) for v in range(len(cm.points))
            for e in ends if np.array_equal(cm.points[v], e)}
    _, node = cm.opened()
    opened = 0
    for f, (b, a) in zip(cm.cut_faces.tolist(), cm.cut_sides.tolist()):
        assert b >= 0 and a >= 0
        for v in f:
            if v in tips:
                continue
            kb, ka = cm.cells[b].tolist().index(v), cm.cells[a].tolist().index(v)
            assert node[b, kb] != node[a, ka], (f, v)
            opened += 1
    assert (opened > 0) == opens and len(cm.cut_faces) >= len(K)
    return cm


def test_a_polyline_crack_with_both_tips_inside_cells():
    """Square grid 8 × the open polyline (0.23, 0.41)–(0.5, 0.52)–(0.77, 0.47): was refused
    in cells 25 and 94 (its tips), now one piece with every exact property."""
    P, C = square_grid(8)
    cm = check_crack(P, C, POLYLINE, np.array([[0, 1], [1, 2]]))
    assert cm.n_pieces == 1


def _interior_point(P, C, c, rng) -> np.ndarray:
    """A point strictly inside cell c: weights k/16, k ≥ 2 (exact on the 1/8 grid)."""
    k = np.array([2, 2, 2]) + rng.multinomial(10, [1 / 3] * 3)
    x = np.zeros(2)
    for i in range(3):
        x = x + (k[i] / 16.0) * P[C[c, i]]
    return x


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("bent", [False, True])
def test_crack_tips_at_random_interior_points(seed, bent):
    """Seeded sample: a crack from a random interior point of a random cell to one of
    another (straight), or bent inside the tip's own cell first (a slit with a corner
    inside the cell): both tips inside cells, every exact property."""
    rng = np.random.default_rng(seed)
    P, C = square_grid(8)
    c0, c1 = rng.choice(len(C), 2, replace=False)
    a, b = _interior_point(P, C, c0, rng), _interior_point(P, C, c1, rng)
    Q = [a] + ([_interior_point(P, C, c0, rng)] if bent else []) + [b]
    Q = np.array(Q)
    if len(np.unique(Q, axis=0)) < len(Q):
        pytest.skip("the sample repeated a point")
    K = np.array([[i, i + 1] for i in range(len(Q) - 1)])
    cm = check_crack(P, C, Q, K)
    assert cm.n_pieces == 1


def _cut_cli(tmp_path, Q, K, check: bool = True):
    """``fperr cut SIM CUT --conforming -o out.vtu`` (a subprocess) on square grid 8 × the
    chain (Q, K); ``check``: exit 0, the file read back by meshio, every triangle
    positive (exact), the square's area exactly 1 (Fraction). Returns (process, out)."""
    import subprocess
    import sys
    from pathlib import Path

    P, C = square_grid(8)
    s, c, out = tmp_path / "sim.vtu", tmp_path / "cut.vtu", tmp_path / "out.vtu"
    meshio.Mesh(np.column_stack([P, np.zeros(len(P))]), [("triangle", C)]).write(s)
    meshio.Mesh(np.column_stack([Q, np.zeros(len(Q))]), [("line", K)]).write(c)
    root = Path(__file__).resolve().parents[2]
    r = subprocess.run([sys.executable, "-m", "fperr", "cut", str(s), str(c),
                        "--conforming", "-o", str(out), "--quiet"], cwd=root,
                       capture_output=True, text=True, timeout=600)
    if check:
        assert r.returncode == 0, r.stderr
        back = meshio.read(out)
        T, X = back.cells_dict["triangle"], back.points[:, :2]
        assert np.all(orientation_signs(X, T) > 0)
        assert exact_mesh_volume(X, T) == Fraction(1)
    return r, out


def test_crack_tip_inside_a_cell_through_the_cli(tmp_path):
    """The CLI on the polyline case (:func:`_cut_cli`'s checks)."""
    _cut_cli(tmp_path, POLYLINE, np.array([[0, 1], [1, 2]]))


def test_a_floating_face_chain_is_bridged_only_from_a_corner_that_sees_it():
    """3D, split/slits.py: a chain inside a face with both ends on the crack front is
    joined to the face's region by a bridge from a corner; a bridge meeting a chord is
    rejected by exact signs in the face's frame and the next (corner, end) that sees is
    taken; when none sees, the face is refused (Unresolved), never bridged across."""
    from predicates.registration.split.regions import Unresolved
    from predicates.registration.split.slits import _bridge, _clear

    def at(x, y):  # frame weights of the point (x, y), corner 0 at the origin
        return (1.0 - x - y, x, y)

    v0, v1, v2 = ("v", 0), ("v", 1), ("v", 2)
    e, m, f = ("h", 0), ("h", 1), ("h", 2)
    ring = [("h", 3), ("h", 4), ("h", 5)]
    pts = {e: (0.4, 0.4), m: (0.1, 0.5), f: (0.5, 0.1), ring[0]: (0.05, 0.05),
           ring[1]: (0.8, 0.05), ring[2]: (0.05, 0.8)}
    w = {v0: (1.0, 0.0, 0.0), v1: (0.0, 1.0, 0.0), v2: (0.0, 0.0, 1.0)}
    w.update({k: at(*p) for k, p in pts.items()})
    chain = [(e, m), (m, f)]
    assert not _clear(v0, e, chain, w)  # corner 0 to e crosses m–f at (0.3, 0.3)
    assert _clear(v0, f, chain, w)

    class Cs:  # the hit rows: every point registered on the face (0, 1, 2)
        sim = np.array([[0, 1, 2, -1]] * 6)
        sim_weights = np.array([list(at(*pts[("h", h)])) + [0.0] for h in range(6)])

    region = [v0, v1, v2]
    _bridge(region, [e, m, f], chain, [0, 1, 2], Cs)
    assert region == [v0, f, m, e, m, f, v0, v1, v2]
    closed = chain + list(zip(ring, ring[1:] + ring[:1]))  # a ring round the chain
    with pytest.raises(Unresolved):
        _bridge([v0, v1, v2], [e, m, f], closed, [0, 1, 2], Cs)


def _at(P, C, c, k) -> np.ndarray:
    """The point of cell c with barycentric weights k/16 (exact on the 1/8 grid)."""
    x = np.zeros(2)
    for i in range(3):
        x = x + (k[i] / 16.0) * P[C[c, i]]
    return x


def _simple(Q, K) -> bool:
    """No two non-adjacent segments of the chain meet, and no two adjacent ones fold
    back onto each other (exact orientations)."""
    F = [[Fraction(float(x)) for x in q] for q in Q]
    for i, (a, b) in enumerate(K.tolist()):
        for p, q in K.tolist()[i + 1:]:
            shared = {a, b} & {p, q}
            o = (_orient(F[a], F[b], F[p]), _orient(F[a], F[b], F[q]),
                 _orient(F[p], F[q], F[a]), _orient(F[p], F[q], F[b]))
            if not shared and o[0] * o[1] <= 0 and o[2] * o[3] <= 0:
                return False
            if shared and all(x == 0 for x in o):
                return False
    return True


@pytest.mark.parametrize("m", [1, 2, 3])
def test_a_crack_entirely_inside_one_triangle(m):
    """Square grid 8 × an open chain of m segments touching no edge of cell 10: the
    slit floats inside the region (split/slit_fill.py bridges it to the cell's boundary
    by a segment crossing nothing, exactly); before, one segment raised IndexError and a
    longer chain was refused (NotConforming)."""
    P, C = square_grid(8)
    k = [(8, 4, 4), (4, 8, 4), (5, 5, 6), (4, 4, 8)][:m + 1]
    Q = np.array([_at(P, C, 10, w) for w in k])
    K = np.array([[i, i + 1] for i in range(m)])
    cm = check_crack(P, C, Q, K, opens=m > 1)
    assert cm.n_pieces == 1 and set(cm.cell_origin[cm.cut_sides.ravel()].tolist()) == {10}


@pytest.mark.parametrize("seed", range(12))
def test_floating_cracks_at_random_interior_points(seed):
    """Seeded sample: a simple open chain of 1–3 segments between random interior points
    of one random cell (chains crossing themselves are not a cut: drawn again)."""
    rng = np.random.default_rng(seed)
    P, C = square_grid(8)
    c = int(rng.integers(len(C)))
    while True:
        m = int(rng.integers(1, 4))
        Q = np.array([_interior_point(P, C, c, rng) for _ in range(m + 1)])
        K = np.array([[i, i + 1] for i in range(m)])
        if len(np.unique(Q, axis=0)) == len(Q) and _simple(Q, K):
            break
    cm = check_crack(P, C, Q, K, opens=m > 1)
    assert cm.n_pieces == 1


def test_a_closed_crack_inside_one_triangle_bounds_an_island():
    """A triangle of cracks inside cell 108: the island is a piece of its own whose
    exact area is the loop's, and the material around it one piece with a hole (the
    hole's side of the loop joined to the cell's region: split/enclosed.merge_enclosed)."""
    P, C = square_grid(8)
    Q = np.array([_at(P, C, 108, w) for w in ((8, 4, 4), (4, 8, 4), (4, 4, 8))])
    K = np.array([[0, 1], [1, 2], [2, 0]])
    cm = check_crack(P, C, Q, K, tips=())
    assert cm.n_pieces == 2
    F = [[Fraction(float(x)) for x in q] for q in Q]
    loop = abs(_orient(F[0], F[1], F[2])) / 2
    areas = sorted(exact_mesh_volume(cm.points, cm.cells[cm.piece == p])
                   for p in range(cm.n_pieces))
    assert areas == [loop, 1 - loop]


def test_crack_inside_one_triangle_through_the_cli(tmp_path):
    """The CLI on one segment inside a cell (:func:`_cut_cli`'s checks; it raised
    IndexError before: exit 1, an internal error)."""
    P, C = square_grid(8)
    _cut_cli(tmp_path, np.array([_at(P, C, 10, w) for w in ((8, 4, 4), (4, 8, 4))]),
             np.array([[0, 1]]))


def test_a_curve_meeting_itself_inside_a_cell_is_refused_by_name(tmp_path):
    """A chain whose third segment passes through its first point (a T inside cell 38:
    not a cut) is refused naming why, not as "no apex …": NotConforming from the
    library; through the CLI exit 1 and nothing written."""
    from predicates.registration.split.conform import NotConforming

    P, C = square_grid(8)
    Q = np.array([(0.828125, 0.53125), (0.8515625, 0.546875), (0.8046875, 0.53125),
                  (0.84375, 0.53125)])
    K = np.array([[0, 1], [1, 2], [2, 3]])
    with pytest.raises(NotConforming, match="crosses or touches itself"):
        predicates.intersect(P, C, Q, K).split().tetrahedralize()
    r, out = _cut_cli(tmp_path, Q, K, check=False)
    assert r.returncode == 1 and "crosses or touches itself" in r.stderr, r.stderr
    assert not out.exists()
