"""The conforming picture shows a crack (predicates/registration/pictures/conforming.py,
docs/split.md "Pictures"): the cut faces inside one piece (both sides in it) drawn in the
cut colour, each side opened towards its own simplex, over the piece made see-through;
the pictures of cuts that separate pieces unchanged. Sides are checked in exact rational
arithmetic (every float64 coordinate a ``Fraction``)."""
from __future__ import annotations

import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import matplotlib
import matplotlib.collections
import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import cube_grid, grid_plane, icosphere
from predicates.registration.pictures.conforming import (CRACK_GAP, crack_faces,
                                                         crack_sides, draw_conforming)
from predicates.registration.pictures.view import DEFAULT_VIEW

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[2]
FPERR = str(Path(sys.executable).with_name("fperr"))


@pytest.fixture(scope="module")
def offset_crack():
    """Kuhn 4 × the plane z = ½ through the cells' centres, [⅛, ⅞]²: a crack ending
    inside the cube (one piece)."""
    P, C = cube_grid(4)
    Q, K = grid_plane(4, offset=True)
    cm = predicates.intersect(P, C, Q, K).split().tetrahedralize()
    assert cm.n_pieces == 1 and len(cm.cut_faces) > 0
    return P, C, Q, K, cm


def _cut_coloured(rgb: np.ndarray) -> np.ndarray:
    """Pixels (…, 3) of the cut's reds (either side), not of a piece colour."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r - g > 0.15) & (r - b > 0.15) & (np.abs(g - b) < 0.12)


def test_the_crack_faces_are_the_cut_inside_the_piece(offset_crack):
    """Every cut face of the offset plane lies (exactly) on z = ½ within [⅛, ⅞]² and is
    a crack face; a cut that separates pieces (a ball, a plane through the cube) has
    none."""
    *_, cm = offset_crack
    faces = crack_faces(cm)
    assert np.array_equal(faces, np.arange(len(cm.cut_faces)))
    for f in cm.cut_faces[faces].tolist():
        for x, y, z in cm.points[f].tolist():
            assert Fraction(z) == Fraction(1, 2)
            assert all(Fraction(1, 8) <= Fraction(c) <= Fraction(7, 8) for c in (x, y))
    for S, T in (icosphere(1), grid_plane(4)):
        other = predicates.intersect(*cube_grid(4), S, T).split().tetrahedralize()
        assert other.n_pieces == 2 and len(other.cut_faces) > 0
        assert len(crack_faces(other)) == 0


def test_each_side_of_the_crack_opens_towards_its_own_simplex(offset_crack):
    """The copies of a face on z = ½ lie on z = ½ ± gap exactly (its unit normal is
    ±e_z), the first on the side of the simplex behind (``cut_sides`` column 0), the
    second on the side of the one in front, strictly: the two sides apart."""
    *_, cm = offset_crack
    faces = crack_faces(cm)
    gap = 0.01
    sides = crack_sides(cm, faces, gap)
    assert sides.shape == (2, len(faces), 3, 3)
    for col in (0, 1):
        for k, f in enumerate(faces.tolist()):
            copy = sides[col, k]
            assert np.array_equal(copy[:, :2], cm.points[cm.cut_faces[f]][:, :2])
            cell = cm.cells[cm.cut_sides[f, col]]
            apex_z = max(cm.points[cell][:, 2].tolist(), key=lambda z: abs(z - 0.5))
            want = 0.5 + gap if apex_z > 0.5 else 0.5 - gap
            assert Fraction(apex_z) != Fraction(1, 2)
            assert copy[:, 2].tolist() == [want] * 3, (col, f, copy[:, 2], apex_z)
    assert (sides[0, :, 0, 2] != sides[1, :, 0, 2]).all()


def _draw(cm, explode=0.0):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(4, 4), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    draw_conforming(ax, cm, explode=explode)
    fig.canvas.draw()
    return plt, fig, ax


def test_the_crack_is_drawn_in_the_cut_colour_over_its_piece(offset_crack):
    """Every crack face is drawn twice (within the gap of its own projected vertices),
    opaque, in the cut's reds, after (above) every face of its piece, which is
    see-through; in the pixels, points of the crack show its colour (on main's code
    they showed the closed blue cube)."""
    *_, cm = offset_crack
    plt, fig, ax = _draw(cm)
    colls = sorted(ax.collections, key=lambda c: c.get_zorder())
    piece, cracks = colls[0], colls[1:]
    assert len(cracks) == 2
    assert (piece.get_facecolors()[:, 3] < 0.5).all()
    assert all(c.get_zorder() > piece.get_zorder() for c in cracks)
    drawn = [p.vertices[:3] for c in cracks for p in c.get_paths()]
    colours = np.concatenate([c.get_facecolors() for c in cracks])
    assert len(drawn) == 2 * len(cm.cut_faces) and (colours[:, 3] == 1).all()
    assert _cut_coloured(colours[:, :3]).all()
    xy = DEFAULT_VIEW.project(cm.points[cm.cut_faces])[0]  # (K, 3, 2)
    tol = 2 * CRACK_GAP * 1.0  # the gap times the cube's extent, projected: ≤ itself
    hits = np.zeros(len(xy), dtype=int)
    for poly in drawn:
        close = np.abs(xy - poly[None]).max(axis=(1, 2)) <= tol
        assert close.any()
        hits[np.flatnonzero(close)] += 1
    assert (hits >= 2).all()
    rgba = np.asarray(fig.canvas.buffer_rgba(), dtype=np.float64)[..., :3] / 255
    height = rgba.shape[0]
    for x, y in [(0.5, 0.5), (0.3, 0.4), (0.7, 0.6), (0.4, 0.75), (0.65, 0.25)]:
        px, py = ax.transData.transform(DEFAULT_VIEW.project(np.array([x, y, 0.5]))[0])
        pixel = rgba[int(round(height - py)), int(round(px))]
        assert _cut_coloured(pixel), ((x, y), pixel)
    plt.close(fig)


def test_pieces_without_a_crack_stay_opaque():
    """A ball cut out of the cube: two pieces, no crack; every face opaque, one
    collection, no polygon in the cut's reds (the picture as before)."""
    cm = predicates.intersect(*cube_grid(4), *icosphere(1)).split().tetrahedralize()
    plt, fig, ax = _draw(cm, explode=0.3)
    (coll,) = ax.collections
    colours = coll.get_facecolors()
    assert (colours[:, 3] == 1).all() and not _cut_coloured(colours[:, :3]).any()
    plt.close(fig)


def test_an_inclusion_drawn_in_place_shows_through_its_see_through_host():
    """A small icosphere inside cell 0 of Kuhn 4 (an inclusion, split/enclosed.py), far
    from the centre, so drawn in place: the cube piece around it is see-through and the
    inclusion's 80 faces are the only opaque ones (before, the opaque cube hid it)."""
    P, C = cube_grid(4)
    Q, K = icosphere(1)
    cm = predicates.intersect(P, C, P[C[0]].mean(axis=0) + 0.01 * Q, K).split().tetrahedralize()
    assert cm.n_pieces == 2
    plt, fig, ax = _draw(cm, explode=0.3)
    (coll,) = ax.collections
    alpha = coll.get_facecolors()[:, 3]
    assert (alpha == 1).sum() == len(K) and (alpha[alpha < 1] < 0.5).all()
    plt.close(fig)


def test_cli_conforming_png_of_a_crack_shows_it(tmp_path, offset_crack):
    """``fperr cut SIM CUT --conforming --png``: exit 0, the picture written, a visible
    share of its pixels in the cut's reds; the same cube cut by a plane through it (two
    pieces) has none of those pixels (nor had the crack's picture on main's code)."""
    import matplotlib.pyplot as plt

    P, C, Q, K, cm = offset_crack
    meshio.write(tmp_path / "sim.vtu", meshio.Mesh(P, [("tetra", C)]))
    meshio.write(tmp_path / "crack.vtu", meshio.Mesh(Q, [("triangle", K)]))
    Qp, Kp = grid_plane(4)
    meshio.write(tmp_path / "plane.vtu", meshio.Mesh(Qp, [("triangle", Kp)]))
    shares = {}
    for cut in ("crack", "plane"):
        png = tmp_path / f"{cut}.png"
        r = subprocess.run([FPERR, "cut", str(tmp_path / "sim.vtu"),
                            str(tmp_path / f"{cut}.vtu"), "--conforming", "--png", str(png),
                            "--quiet"], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-2000:]
        img = plt.imread(png)[..., :3]
        shares[cut] = _cut_coloured(img).mean()
    assert shares["crack"] > 0.02 and shares["plane"] == 0, shares


def test_a_2d_crack_is_drawn_as_red_segments_over_its_piece():
    """Square grid 8 × a polyline from grid vertex (¼, ½) to (¾, ½) (one piece): its cut
    segments, drawn in the cut colour above the triangles, are exactly the crack faces'
    (by coordinates, explode 0), which tile the polyline."""
    from predicates.registration.examples import square_grid
    from predicates.registration.pictures.conforming import CUT_RGB

    Q = np.array([[0.25, 0.5], [0.5, 0.5625], [0.75, 0.5]])
    cm = predicates.intersect(*square_grid(8), Q, np.array([[0, 1], [1, 2]])).split() \
        .triangulate()
    assert cm.n_pieces == 1
    cracks = crack_faces(cm)
    assert len(cracks) == len(cm.cut_faces) > 0
    length = sum(np.sqrt(((cm.points[b] - cm.points[a]) ** 2).sum())
                 for a, b in cm.cut_faces[cracks].tolist())
    assert abs(length - 2 * np.sqrt(0.25 ** 2 + 0.0625 ** 2)) < 1e-12
    plt, fig, ax = _draw(cm)
    (lines,) = [c for c in ax.collections
                if isinstance(c, matplotlib.collections.LineCollection)]
    assert lines.get_zorder() > max(c.get_zorder() for c in ax.collections if c is not lines)
    assert np.allclose(lines.get_colors()[:, :3], CUT_RGB)
    drawn = sorted(tuple(map(tuple, s.tolist())) for s in lines.get_segments())
    assert drawn == sorted(tuple(map(tuple, cm.points[f].tolist()))
                           for f in cm.cut_faces[cracks].tolist())
    plt.close(fig)


def test_the_crack_picture_is_the_same_on_every_kernel(tmp_path, offset_crack):
    """``fperr cut --conforming --png`` of the crack writes the same bytes under every
    OpenBLAS kernel this CPU runs and every lower level of numpy's SIMD dispatch
    (docs/design.md, "The same answer on every machine"): the opened sides and the
    see-through shading are elementwise, in a fixed order (no BLAS, no transcendental
    function)."""
    import os

    from blas_kernels import supported
    from numpy_dispatch import settings

    P, C, Q, K, _ = offset_crack
    meshio.write(tmp_path / "sim.vtu", meshio.Mesh(P, [("tetra", C)]))
    meshio.write(tmp_path / "crack.vtu", meshio.Mesh(Q, [("triangle", K)]))
    base = {k: v for k, v in os.environ.items()
            if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    runs = [{}] + [{"OPENBLAS_CORETYPE": k} for k in supported()[0]] \
        + [{"NPY_DISABLE_CPU_FEATURES": s} for s in settings()]
    pictures = []
    for n, extra in enumerate(runs):
        png = tmp_path / f"crack{n}.png"
        r = subprocess.run([sys.executable, "-m", "fperr", "cut", str(tmp_path / "sim.vtu"),
                            str(tmp_path / "crack.vtu"), "--conforming", "--png", str(png),
                            "--quiet"], cwd=ROOT, env={**base, **extra},
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, (extra, r.stderr[-2000:])
        pictures.append(png.read_bytes())
    assert pictures[0][:4] == b"\x89PNG" and len(runs) > 1
    assert [extra for extra, p in zip(runs, pictures) if p != pictures[0]] == []
