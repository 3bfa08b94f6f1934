"""Every consumer of a result handles a refined cutting mesh (refinement is on by
default, docs/resolution.md): a coarse cutting mesh — long segments, a big triangle — is
refined to the simulation cells it meets, so ``res.cut_points`` has more points than the
input and the pairs' cutting ids number the refined mesh. Pictures, consistency counts
with an input-point mask, ParaView output, the split, the data frame, per-partition
files and the command line must all take that mesh, and map back to the input where
they report cutting ids."""
from __future__ import annotations

import subprocess
import sys
from fractions import Fraction

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import cube_grid, square_grid
from predicates.registration.partition.files import write_parts
from predicates.registration.pictures.plot import plot_2d, plot_3d_cells, plot_robust_naive
from predicates.portable import weighted_sum

#: a coarse closed quadrilateral well inside the unit square, not on grid lines
QUAD = np.array([[0.21, 0.23], [0.78, 0.26], [0.74, 0.81], [0.24, 0.77]])
QUAD_CELLS = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
#: one big triangle across a cube grid
TRI = np.array([[0.05, 0.1, 0.2], [0.93, 0.2, 0.3], [0.4, 0.95, 0.8]])


@pytest.fixture(scope="module")
def res2():
    sp, sc = square_grid(12)
    r = predicates.intersect(sp, sc, QUAD, QUAD_CELLS)
    assert r.cut_refined and len(r.cut_points) > len(QUAD)  # the premise of every test
    return r


@pytest.fixture(scope="module")
def res3():
    sp, sc = cube_grid(5)
    r = predicates.intersect(sp, sc, TRI, np.array([[0, 1, 2]]))
    assert r.cut_refined and len(r.cut_points) > 3
    return r


def _inside_quad(q) -> bool:
    """Exact point-in-convex-polygon (counter-clockwise QUAD) with fractions."""
    x, y = Fraction(q[0]), Fraction(q[1])
    for a, b in QUAD_CELLS:
        ax, ay = map(Fraction, QUAD[a])
        bx, by = map(Fraction, QUAD[b])
        if (bx - ax) * (y - ay) - (by - ay) * (x - ax) <= 0:
            return False
    return True


def test_masks_over_the_input_points_are_accepted(res2):
    inside = np.ones(len(QUAD), dtype=bool)
    full = res2.cut_point_mask(inside)
    assert len(full) == len(res2.cut_points) and full[:4].all() and not full[4:].any()
    assert res2.cut_point_mask(full) is not None
    assert res2.inconsistencies(inside) == 0 == res2.inconsistencies(full)
    assert len(res2.location_counts("cut")) == len(res2.cut_points)
    with pytest.raises(ValueError, match="4 points as given"):
        res2.cut_point_mask(np.ones(5, dtype=bool))


def test_pictures(res2, res3, tmp_path):
    naive = predicates.intersect(res2.sim_points, res2.sim_cells, QUAD, QUAD_CELLS,
                                 tolerance_scale=0)
    plot_2d(res2, tmp_path / "a.png")
    plot_robust_naive(res2, naive, np.ones(len(QUAD), dtype=bool), tmp_path / "b.png")
    plot_3d_cells(res3, tmp_path / "c.png")
    for f in ("a.png", "b.png", "c.png"):
        assert (tmp_path / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _check_input_map(res, cells, weights):
    """Σ w·(the input cell's vertices) is the pair's point on the refined cut, to the
    rounding of the refinement's midpoints."""
    X = np.concatenate([res[k].points(side="cut") for k in res.kinds])
    input_cells = QUAD_CELLS if res.dim == 2 else np.array([[0, 1, 2]])
    inputs = res.cut_points[:res.input_cut_points].astype(np.float64)
    back = weighted_sum(weights, inputs[input_cells[cells]])
    assert np.abs(back - X).max() <= 1e-13
    assert np.all(weights >= -1e-15) and np.abs(weights.sum(1) - 1).max() <= 1e-14


def test_paraview_points_map_back_to_the_input(res2, res3, tmp_path):
    for res in (res2, res3):
        m = res.to_meshio()
        cells = m.point_data["cut_input_cell"]
        assert len(cells) == res.total
        _check_input_map(res, cells, m.point_data["cut_input_weights"])
        path = tmp_path / f"p{res.dim}.vtu"
        meshio.write(path, m)
        back = meshio.read(path)
        assert np.array_equal(back.point_data["cut_input_cell"], cells)


def test_sim_mesh_and_split(res2):
    sm = res2.sim_mesh()
    cut = sm.cell_data["cut"][0]
    assert np.array_equal(np.flatnonzero(cut), res2.intersected_cells())
    split = res2.split()
    assert split.n_pieces == 2
    side = np.array([_inside_quad(q) for q in res2.sim_points])
    # every material corner of a piece's cells is on that piece's exact side of the cut
    corner_side = side[res2.sim_cells[split.cell_origin]]
    for piece in range(2):
        s = corner_side[split.piece == piece][split.material[split.piece == piece]]
        assert len(s) and (s.all() or not s.any())
    assert {bool(corner_side[split.piece == p][split.material[split.piece == p]][0])
            for p in range(2)} == {True, False}


def test_dataframe_and_partition_files(res2, tmp_path):
    pd = pytest.importorskip("pandas")
    df = res2.to_dataframe()
    assert isinstance(df, pd.DataFrame) and len(df) == res2.total
    X = np.concatenate([res2[k].points() for k in res2.kinds])
    assert np.array_equal(df[["x", "y"]].to_numpy(), X)
    paths = write_parts(res2, 2, str(tmp_path / "hits_{part}.vtu"))
    parts = [meshio.read(p) for p in paths]
    assert sum(len(m.points) for m in parts) == res2.total
    assert all("cut_input_cell" in m.point_data for m in parts)


def test_command_line_with_a_coarse_cut(res2, tmp_path):
    meshio.write(tmp_path / "sim.vtu", meshio.Mesh(
        np.column_stack([res2.sim_points, np.zeros(len(res2.sim_points))]),
        [("triangle", res2.sim_cells)]))
    meshio.write(tmp_path / "cut.vtu", meshio.Mesh(
        np.column_stack([QUAD, np.zeros(4)]), [("line", QUAD_CELLS)]))
    r = subprocess.run([sys.executable, "-m", "fperr", "intersect", "sim.vtu", "cut.vtu",
                        "-o", "hits.vtu", "--sim-output", "cells.vtu", "--plot", "p.png"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    hits = meshio.read(tmp_path / "hits.vtu")
    assert len(hits.points) == res2.total
    assert set(hits.point_data["cut_input_cell"].tolist()) == {0, 1, 2, 3}
    assert (tmp_path / "p.png").stat().st_size > 1000
