"""The 3D pictures' own projection (predicates/registration/pictures/view.py,
docs/design.md "The same answer on every machine"): an exact rational rotation near the
asked view, applied in a fixed order with IEEE operations, faces painted back to front,
and no mplot3d anywhere in the 3D pictures."""
from __future__ import annotations

import math
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import matplotlib
import mpmath
import numpy as np
import pytest

from predicates.registration.pictures.view import _unit_circle, draw_faces, view

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[2]
ANGLES = [(30, -60), (20, -75), (15, -60), (90, 0), (-45, 135), (0, 180), (60, 10)]


def _exact_rows(elev, azim):
    ce, se = _unit_circle(elev)
    ca, sa = _unit_circle(azim)
    return ((-sa, ca, Fraction(0)), (-se * ca, -se * sa, ce), (ce * ca, ce * sa, se))


@pytest.mark.parametrize("elev,azim", ANGLES)
def test_view_is_an_exact_rotation_near_the_asked_angles(elev, azim):
    for deg in (elev, azim):
        c, s = _unit_circle(deg)
        assert c * c + s * s == 1  # on the unit circle exactly
        mpmath.mp.dps = 40
        got = mpmath.atan2(mpmath.mpf(s.numerator) / s.denominator,
                           mpmath.mpf(c.numerator) / c.denominator) * 180 / mpmath.pi
        off = abs((got - deg + 180) % 360 - 180)
        assert off < 0.01, (deg, float(got))
    R = _exact_rows(elev, azim)
    for i in range(3):  # orthonormal and right-handed, in exact arithmetic
        for j in range(3):
            assert sum(a * b for a, b in zip(R[i], R[j])) == (1 if i == j else 0)
    (r0, r1, r2), (u0, u1, u2) = R[0], R[1]
    assert (r1 * u2 - r2 * u1, r2 * u0 - r0 * u2, r0 * u1 - r1 * u0) == R[2]
    v = view(elev, azim)
    for row_f, row_q in zip(v.rows, R):  # each entry rounded once from its fraction
        for f, q in zip(row_f, row_q):
            assert f == float(q) and abs(Fraction(f) - q) <= Fraction(math.ulp(f)) / 2
    # the viewer where mplot3d's view_init puts it (z up in the picture)
    e, a = math.radians(elev), math.radians(azim)
    towards = (math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e))
    assert max(abs(x - y) for x, y in zip(v.rows[2], towards)) < 1e-3
    assert v.rows[0][2] == 0.0 and v.rows[1][2] >= 0.0


def test_projection_sums_left_to_right_in_ieee_arithmetic():
    """Each coordinate is ((x·r₀ + y·r₁) + z·r₂) with one rounding per operation, as
    Python floats compute it (no FMA, no BLAS): bit for bit."""
    rng = np.random.default_rng(7)
    P = rng.uniform(-3, 3, size=(200, 3))
    v = view(20, -75)
    xy, depth = v.project(P.reshape(20, 10, 3))
    for n, (x, y, z) in enumerate(P.tolist()):
        want = [(x * r[0] + y * r[1]) + z * r[2] for r in v.rows]
        got = [*xy.reshape(-1, 2)[n].tolist(), depth.reshape(-1)[n]]
        assert got == want
        exact = [sum(Fraction(p) * Fraction(c) for p, c in zip((x, y, z), r)) for r in v.rows]
        size = Fraction(math.ulp(abs(x) + abs(y) + abs(z)))  # bounds every partial sum
        assert all(abs(Fraction(g) - q) <= 3 * size for g, q in zip(got, exact))


def _square(x0, y0, z, size=2.0):
    return np.array([[x0, y0, z], [x0 + size, y0, z], [x0 + size, y0 + size, z],
                     [x0, y0 + size, z]], dtype=np.float64)


def test_faces_are_painted_back_to_front_ties_in_input_order(tmp_path):
    """Seen from above (depth = z exactly), the collection holds the faces far to near,
    colours following; faces of equal depth keep their input order; in the pixels the
    near square covers the far one whatever order they were given in."""
    import matplotlib.pyplot as plt

    top = view(90, -90)  # picture (x, y), depth z: exact
    assert top.rows == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    faces = np.stack([_square(0, 0, 2), _square(1, 1, 0), _square(5, 5, 1), _square(6, 6, 1),
                      _square(1, 0, -1)])
    colours = np.array([[1, 0, 0, 1], [0, 0, 1, 1], [0, 1, 0, 1], [0, 1, 1, 1], [1, 1, 0, 1]],
                       dtype=np.float64)
    edges = colours[:, [1, 2, 0, 3]]
    fig = plt.figure(figsize=(3, 3))
    ax = fig.add_axes((0, 0, 1, 1))  # data [-1, 9]² fills the picture
    coll = draw_faces(ax, top, faces, colours, edgecolors=edges, linewidths=0)
    order = [4, 1, 2, 3, 0]  # z = -1, 0, 1 (input order: 2 before 3), 2
    assert np.array_equal(coll.get_facecolors(), colours[order])
    assert np.array_equal(coll.get_edgecolors(), edges[order])
    assert [p.vertices[0].tolist() for p in coll.get_paths()] == \
        [faces[i][0, :2].tolist() for i in order]
    ax.set_xlim(-1, 9)
    ax.set_ylim(-1, 9)
    ax.set_axis_off()
    fig.savefig(tmp_path / "a.png", dpi=50)
    plt.close(fig)
    img = plt.imread(tmp_path / "a.png")
    h, w = img.shape[:2]
    def pixel(x, y):
        return img[int(round(h * (1 - (y + 1) / 10))), int(round(w * (x + 1) / 10))][:3]

    # (1.5, 1.5) is in square 0 (red, z = 2) and square 1 (blue, z = 0): red on top;
    # (2.5, 2.5) in square 1 only; (6.5, 6.5) in 2 (green) and 3 (cyan), equal depth:
    # the later one on top
    assert np.allclose(pixel(1.5, 1.5), (1, 0, 0), atol=0.02), pixel(1.5, 1.5)
    assert np.allclose(pixel(2.5, 2.5), (0, 0, 1), atol=0.02), pixel(2.5, 2.5)
    assert np.allclose(pixel(6.5, 6.5), (0, 1, 1), atol=0.02), pixel(6.5, 6.5)


def test_3d_pictures_draw_without_mplot3d(tmp_path):
    """plot_3d_cells, plot_split (with the cut surface) and plot_conforming write real
    pictures without a 3D axis or collection of mplot3d (whose projection differs per BLAS
    kernel)."""
    code = f"""
import sys
from pathlib import Path
import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d import art3d, axes3d
import predicates

def refuse(*args, **kwargs):  # pyplot imports mplot3d; no 3D axis or collection is made
    raise AssertionError("mplot3d used")

axes3d.Axes3D.__init__ = art3d.Poly3DCollection.__init__ = refuse
from predicates.registration.examples import cube_grid, grid_plane, icosphere
from predicates.registration.pictures.conforming import plot_conforming
from predicates.registration.pictures.plot import plot_3d_cells
from predicates.registration.split.plot import plot_split
from predicates.registration.split.surface import cut_surface
out = Path({str(tmp_path)!r})
res = predicates.intersect(*cube_grid(4), *icosphere(1))
plot_3d_cells(res, out / "cells.png")
plot_split(res.split(), out / "split.png", surface=cut_surface(res))
plot_conforming(predicates.intersect(*cube_grid(2), *grid_plane(2)).split().tetrahedralize(),
                out / "conforming.png")
for name in ("cells", "split", "conforming"):
    img = plt.imread(out / f"{{name}}.png")[..., :3]
    rgb = (img * 255).round().astype(np.uint8).reshape(-1, 3)
    colours, counts = np.unique(rgb, axis=0, return_counts=True)
    assert len(colours) >= 20 and counts.max() < 0.95 * len(rgb), (name, len(colours))
print("ok")
"""
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-2000:]
