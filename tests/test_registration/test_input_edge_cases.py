"""Inputs a newcomer hits: meshes at extreme scales, pyvista grids read from gmsh files,
2D meshes given with three coordinates, non-tetrahedral volumes, several cell types in
a cutting mesh, and meshes that collapse to a point (each with the reason and what to
do). Through the command line where the behaviour is the command's."""
from __future__ import annotations

import subprocess
import sys
import warnings

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import cube_grid, example, icosphere

CIRCLE = example("circle", 6)
(SP, SC), (CP, CC) = CIRCLE["sim"], CIRCLE["cut"]


def _pairs(res) -> dict:
    return {k: (res[k].sim.tolist(), res[k].cut.tolist(), res[k].sim_weights.tobytes(),
                res[k].cut_weights.tobytes()) for k in res.kinds}


def _fperr(*argv, cwd):
    return subprocess.run([sys.executable, "-m", "fperr", *map(str, argv)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def _write_2d(path, points, cells, kind):
    meshio.write(path, meshio.Mesh(np.column_stack([points, np.zeros(len(points))]),
                                   [(kind, cells)]))


@pytest.mark.parametrize("e", [-990, -600, 600, 990])
def test_power_of_two_scales_give_the_same_pairs_and_no_warning(e):
    """Exact power-of-two scaling: identical ids and weights (bits) at 2^±990, and no
    numpy warning on the way (the report's edges are computed on rescaled copies)."""
    ref = predicates.intersect(SP, SC, CP, CC)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = predicates.intersect(np.ldexp(SP, e), SC, np.ldexp(CP, e), CC)
    assert _pairs(res) == _pairs(ref)
    assert res.resolution.h_sim == np.ldexp(ref.resolution.h_sim, e)
    assert "None" not in str(res)


@pytest.mark.parametrize("scale", ["1e-300", "1e-310", "1e300"])
def test_command_line_at_extreme_scales(scale, tmp_path):
    s = float(scale)
    _write_2d(tmp_path / "sim.vtu", SP * s, SC, "triangle")
    _write_2d(tmp_path / "cut.vtu", CP * s, CC, "line")
    r = _fperr("intersect", "sim.vtu", "cut.vtu", "-o", "hits.vtu", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr.lower() and "None" not in r.stdout
    total = predicates.intersect(SP, SC, CP, CC).total
    assert len(meshio.read(tmp_path / "hits.vtu").points) == total


def _gmsh_box(path):
    """A gmsh file with vertex, line, triangle and tetra blocks and physical groups."""
    sp, sc = cube_grid(2)
    blocks = [("vertex", np.array([[0]])), ("line", np.array([[0, 1]])),
              ("triangle", np.array([[0, 1, 3], [0, 3, 2]])), ("tetra", sc)]
    phys = [np.array([1]), np.array([2]), np.array([3, 3]), np.full(len(sc), 7)]
    meshio.Mesh(sp, blocks, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys},
                field_data={"corner": np.array([1, 0]), "edge": np.array([2, 1]),
                            "skin": np.array([3, 2]), "body": np.array([7, 3])}
                ).write(path, file_format="gmsh22", binary=False)
    return sp, sc


def test_pyvista_grid_from_a_gmsh_file(tmp_path):
    pv = pytest.importorskip("pyvista")
    sp, sc = _gmsh_box(tmp_path / "box.msh")
    grid = pv.read(tmp_path / "box.msh")
    assert {int(t) for t in grid.celltypes} >= {1, 3, 5, 10}  # the mixed blocks
    cut = icosphere(1)
    ref = predicates.intersect(sp, sc, *cut)
    res = predicates.intersect(grid, meshio.Mesh(cut[0], [("triangle", cut[1])]))
    assert res.total == ref.total > 0
    assert predicates.intersect(grid, meshio.Mesh(cut[0], [("triangle", cut[1])]),
                                sim_region=7).total == ref.total
    with pytest.raises(ValueError, match="pass the tag"):  # pyvista drops the names
        predicates.intersect(grid, meshio.Mesh(cut[0], [("triangle", cut[1])]),
                             sim_region="body")


def test_planar_arrays_with_three_coordinates_are_2d():
    P3 = np.column_stack([SP, np.full(len(SP), 0.25)])
    Q3 = np.column_stack([CP, np.full(len(CP), 0.25)])
    res = predicates.intersect(P3, SC, Q3, CC)
    assert _pairs(res) == _pairs(predicates.intersect(SP, SC, CP, CC))
    assert res.plane == 0.25 and res.dim == 2
    Q3[:, 2] = 0.5
    with pytest.raises(ValueError, match="different planes"):
        predicates.intersect(P3, SC, Q3, CC)


def test_wedges_are_named_and_mixed_cutting_blocks_noted(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1.0]])
    meshio.write(tmp_path / "prism.vtu",
                 meshio.Mesh(pts, [("wedge", np.array([[0, 1, 2, 3, 4, 5]]))]))
    cp, cc = icosphere(1)
    meshio.write(tmp_path / "ball.vtu", meshio.Mesh(cp, [("triangle", cc)]))
    r = _fperr("intersect", "prism.vtu", "ball.vtu", "-o", "out.vtu", cwd=tmp_path)
    assert r.returncode == 2 and "wedge" in r.stderr and "tetrahedra" in r.stderr
    assert not (tmp_path / "out.vtu").exists()
    sp, sc = cube_grid(2)
    meshio.write(tmp_path / "cube.vtu", meshio.Mesh(sp, [("tetra", sc)]))
    meshio.write(tmp_path / "both.vtu", meshio.Mesh(cp, [("triangle", cc),
                                                        ("tetra", np.array([[0, 1, 2, 3]]))]))
    r = _fperr("intersect", "cube.vtu", "both.vtu", cwd=tmp_path)
    assert r.returncode == 0 and "tetrahedra are ignored" in r.stdout + r.stderr


@pytest.mark.parametrize("case,word", [("point", "needs extent"),
                                       ("offset", "translate it back"),
                                       ("underflow", "use float64")])
def test_a_mesh_collapsed_to_a_point_is_refused_with_the_reason(case, word, tmp_path):
    sp, cp, extra = SP, CP, []
    if case == "point":
        cp = np.full_like(CP, 0.5)
    elif case == "offset":
        sp, cp = SP + 1e16, CP + 1e16
    else:
        sp, cp, extra = SP * 1e-46, CP * 1e-46, ["--dtype", "float32"]
    _write_2d(tmp_path / "sim.vtu", sp, SC, "triangle")
    _write_2d(tmp_path / "cut.vtu", cp, CC, "line")
    r = _fperr("intersect", "sim.vtu", "cut.vtu", "-o", "hits.vtu", *extra, cwd=tmp_path)
    assert r.returncode == 2 and "is the same point" in r.stderr and word in r.stderr
    assert not (tmp_path / "hits.vtu").exists()
