"""Issue 11: mesh files in and out through the command line (real processes: exit codes,
files written or not, one-line errors) — output formats, outputs naming inputs, the
ParaView legend, cut-cell data, planes z = c, JSON, second-order cells, regions,
tetrahedral cutting meshes, empty and disjoint meshes."""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from predicates.registration.result.intersection import KIND_CODES

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def fperr(*args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fperr", *map(str, args)], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=300)


def one_line_error(r, *words):
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert str(w) in lines[0], (w, lines[0])
    return lines[0]


def write_3d(tmp, n=2, sim="sim.vtu", cut="cut.vtu"):
    ex = example("plane_offset", n)
    meshio.Mesh(ex["sim"][0], [("tetra", ex["sim"][1])]).write(tmp / sim)
    meshio.Mesh(ex["cut"][0], [("triangle", ex["cut"][1])]).write(tmp / cut)
    return ex, tmp / sim, tmp / cut


def write_2d(tmp, z=0.0, n=4, sim="sim2.vtu", cut="cut2.vtu"):
    ex = example("circle", n, segments=12)
    pad = (lambda p: np.column_stack([p, np.full(len(p), z)]))
    meshio.Mesh(pad(ex["sim"][0]), [("triangle", ex["sim"][1])]).write(tmp / sim)
    meshio.Mesh(pad(ex["cut"][0]), [("line", ex["cut"][1])]).write(tmp / cut)
    return ex, tmp / sim, tmp / cut


# -- output files ------------------------------------------------------------------------
@pytest.mark.parametrize("ext", [".stl", ".msh", ".obj", ".xdmf", ".off", ".mesh", ".ply",
                                 ".vtk", ""])
def test_output_formats_that_cannot_hold_the_result_are_refused_first(tmp_path, ext):
    _, sim, cut = write_3d(tmp_path)
    out = tmp_path / f"out{ext}"
    r = fperr("intersect", sim, cut, "-o", out, "--quiet", cwd=tmp_path)
    one_line_error(r, out, ".vtu")
    assert r.stdout == "" and not out.exists()  # refused before the run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.vtu", "sim.vtu"]


def test_output_naming_an_input_is_refused_and_the_input_kept(tmp_path):
    _, sim, cut = write_3d(tmp_path)
    before = sim.read_bytes(), cut.read_bytes()
    for out, opt in ((sim, "-o"), (cut, "--sim-output"), ("./sim.vtu", "-o")):
        r = fperr("intersect", sim, cut, opt, out, "--quiet", cwd=tmp_path)
        one_line_error(r, "input", "refusing to overwrite")
    assert (sim.read_bytes(), cut.read_bytes()) == before
    r = fperr("intersect", sim, cut, "-o", "a.vtu", "--sim-output", "a.vtu", cwd=tmp_path)
    one_line_error(r, "both")


def test_failed_write_leaves_no_file(tmp_path):
    from predicates.registration.io.write import write_atomic

    target = tmp_path / "x.vtu"

    def half_then_fail(tmp):
        pathlib.Path(tmp).write_bytes(b"<VTKFile partial")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        write_atomic(target, half_then_fail)
    assert list(tmp_path.iterdir()) == []  # neither the target nor a temporary file
    write_atomic(target, lambda tmp: pathlib.Path(tmp).write_text("ok"))
    assert target.read_text() == "ok" and len(list(tmp_path.iterdir())) == 1


def test_kind_codes_have_a_legend_and_one_code_per_name_in_2d_and_3d(tmp_path):
    ex3, sim3, cut3 = write_3d(tmp_path)
    ex2, sim2, cut2 = write_2d(tmp_path)
    legends = {}
    for d, sim, cut in ((3, sim3, cut3), (2, sim2, cut2)):
        out = tmp_path / f"hits{d}.vtu"
        r = fperr("intersect", sim, cut, "-o", out, "--quiet", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        back = meshio.read(out)
        legend = {k: int(v.ravel()[0]) for k, v in back.field_data.items()}
        ref = predicates.intersect(*(ex3 if d == 3 else ex2)["sim"],
                                   *(ex3 if d == 3 else ex2)["cut"])
        assert set(legend) == set(ref.kinds)
        codes = back.point_data["kind"]
        for k, n in ref.counts.items():
            assert int(np.sum(codes == legend[k])) == n
        assert set(np.unique(codes)) <= set(legend.values())
        legends[d] = legend
    shared = set(legends[2]) & set(legends[3])
    assert {"vertex_vertex", "edge_edge", "triangle_vertex"} <= shared
    assert all(legends[2][k] == legends[3][k] == KIND_CODES[k] for k in shared)


def test_sim_output_has_cut_cell_data_to_threshold(tmp_path):
    ex, sim, cut = write_3d(tmp_path, n=3)
    r = fperr("intersect", sim, cut, "--sim-output", "cells.vtu", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    back = meshio.read(tmp_path / "cells.vtu")
    res = predicates.intersect(*ex["sim"], *ex["cut"])
    cut_flag = back.cell_data["cut"][0]
    assert np.array_equal(np.flatnonzero(cut_flag), res.intersected_cells())
    assert 0 < cut_flag.sum() < len(cut_flag)
    for k in res.kinds:
        assert np.array_equal(np.flatnonzero(back.cell_data[f"cut_by_{k}"][0]),
                              res.intersected_cells(k))
        bit = (back.cell_data["cut_kinds"][0] >> (KIND_CODES[k] - 1)) & 1
        assert np.array_equal(bit, back.cell_data[f"cut_by_{k}"][0])


def test_2d_mesh_in_a_plane_z_c_comes_back_at_z_c(tmp_path):
    _, sim, cut = write_2d(tmp_path, z=2.5)
    r = fperr("intersect", sim, cut, "-o", "hits.vtu", "--sim-output", "cells.vtu",
              "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for f in ("hits.vtu", "cells.vtu"):
        pts = meshio.read(tmp_path / f).points
        assert len(pts) and np.all(pts[:, 2] == 2.5)


def test_2d_mesh_in_another_coordinate_plane_is_told_so(tmp_path):
    ex = example("circle", 4, segments=12)
    p = ex["sim"][0]
    meshio.Mesh(np.column_stack([np.full(len(p), 1.0), p]),
                [("triangle", ex["sim"][1])]).write(tmp_path / "yz.vtu")
    _, _, cut = write_2d(tmp_path)
    r = fperr("intersect", "yz.vtu", cut, "--quiet", cwd=tmp_path)
    one_line_error(r, "yz.vtu", "plane x = 1", "z = const")


def test_intersect_json(tmp_path):
    ex, sim, cut = write_3d(tmp_path)
    r = fperr("intersect", sim, cut, "--format", "json", "-o", "h.vtu", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)  # stdout is the JSON document only
    res = predicates.intersect(*ex["sim"], *ex["cut"])
    assert d["counts"] == res.counts and d["total"] == res.total
    assert d["tolerances"] == res.tolerances_input_units()
    assert d["tolerances"]["L"] == float(res.tolerances.L) and d["dim"] == 3
    assert d["timings"]["total"] > 0 and "h.vtu" in d["outputs"]


def test_verify_json_lists_every_constraint(tmp_path):
    r = fperr("verify", "--dim", "2", "--format", "json", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    cs = d["dims"]["2"]["constraints"]
    text = fperr("verify", "--dim", "2", "--quiet", cwd=tmp_path).stdout
    assert len(cs) == text.count("  pass  ") + text.count("  FAIL  ") > 10
    for c in cs:
        assert c["status"] == "pass" and f"pass  {c['name']}" in text
        assert c["margin"] is None or c["margin"] >= 0
    assert d["ok"] is True


# -- input files ---------------------------------------------------------------------------
def test_meshio_sys_exit_is_a_one_line_error_and_a_valueerror(tmp_path):
    from predicates.registration import MeshFileError, intersect_files

    _, sim, _ = write_3d(tmp_path)
    bad = tmp_path / "bad.vtu"
    bad.write_text('<?xml version="1.0"?>\n')  # meshio: sys.exit(1)
    with pytest.raises(MeshFileError, match="bad.vtu"):
        intersect_files(sim, bad)
    r = fperr("intersect", sim, bad, cwd=tmp_path)
    one_line_error(r, bad)


def test_raw_numpy_errors_name_the_file(tmp_path):
    _, sim, _ = write_3d(tmp_path)
    bad = tmp_path / "short.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n")  # numpy: cannot reshape array of size 3
    one_line_error(fperr("intersect", sim, bad, cwd=tmp_path), bad, "truncated")
    bad = tmp_path / "words.obj"
    bad.write_text("v 1 2 vertex\nf 1 2 3\n")
    one_line_error(fperr("intersect", sim, bad, cwd=tmp_path), bad)


def test_second_order_cells_use_their_corners_with_a_note(tmp_path):
    ex = example("plane_offset", 2)
    P, T = ex["sim"]
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    mids = (P[T[:, [a for a, _ in edges]]] + P[T[:, [b for _, b in edges]]]) / 2
    P2 = np.concatenate([P, mids.reshape(-1, 3)])
    T10 = np.column_stack([T, len(P) + np.arange(6 * len(T)).reshape(-1, 6)])
    meshio.Mesh(P2, [("tetra10", T10)]).write(tmp_path / "sim10.vtu")
    C, F = ex["cut"]
    cm = (C[F[:, [0, 1, 0]]] + C[F[:, [1, 2, 2]]]) / 2
    F6 = np.column_stack([F, len(C) + np.arange(3 * len(F)).reshape(-1, 3)])
    meshio.Mesh(np.concatenate([C, cm.reshape(-1, 3)]), [("triangle6", F6)]).write(
        tmp_path / "cut6.vtu")
    r = fperr("intersect", "sim10.vtu", "cut6.vtu", "--format", "json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["counts"] == predicates.intersect(*ex["sim"], *ex["cut"]).counts
    notes = " ".join(d["notes"])
    assert "tetra10" in notes and "triangle6" in notes and "corner nodes" in notes


@pytest.mark.parametrize("ctype, k, need", [
    ("quad", 4, "tetrahedral (3D) or triangle (2D) mesh is needed"),
    ("hexahedron", 8, "fperr needs a tetrahedral mesh"),  # a volume: named, and what to do
    ("wedge", 6, "fperr needs a tetrahedral mesh")])
def test_non_simplex_meshes_get_their_cell_types_named(tmp_path, ctype, k, need):
    pts = np.random.default_rng(0).random((8, 3))
    meshio.Mesh(pts, [(ctype, np.arange(k)[None])]).write(tmp_path / "s.vtu")
    _, _, cut = write_3d(tmp_path)
    one_line_error(fperr("intersect", "s.vtu", cut, cwd=tmp_path), "s.vtu", ctype, need)


def test_triangle_surface_as_simulation_mesh_needs_a_volume_mesh(tmp_path):
    from predicates.registration.examples import icosphere

    meshio.Mesh(*icosphere(1)[:1], [("triangle", icosphere(1)[1])]).write(tmp_path / "s.vtu")
    _, _, cut = write_3d(tmp_path)  # a flat surface: also a 2D mesh in z = 1/2
    for sim in ("s.vtu", cut):
        one_line_error(fperr("intersect", sim, cut, "--quiet", cwd=tmp_path),
                       "a volume (tetrahedral) mesh is needed")


def _gmsh_two_groups(tmp_path):
    """A gmsh file with physical groups 7 ("lower", z < 1/2) and 8 ("upper")."""
    ex = example("plane_offset", 2)
    P, T = ex["sim"]
    up = P[T].mean(axis=1)[:, 2] > 0.5
    tags = np.where(up, 8, 7)
    m = meshio.Mesh(P, [("tetra", T)], cell_data={"gmsh:physical": [tags],
                                                  "gmsh:geometrical": [tags]},
                    field_data={"lower": np.array([7, 3]), "upper": np.array([8, 3])})
    m.write(tmp_path / "groups.msh", file_format="gmsh22", binary=False)
    return ex, T[~up], T[up]


def test_gmsh_physical_group_selection_cli_and_api(tmp_path):
    ex, lower, upper = _gmsh_two_groups(tmp_path)
    _, _, cut = write_3d(tmp_path)
    for region, cells in (("7", lower), ("lower", lower), ("upper", upper)):
        r = fperr("intersect", "groups.msh", cut, "--sim-region", region, "--format",
                  "json", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        ref = predicates.intersect(ex["sim"][0], cells, *ex["cut"])
        assert json.loads(r.stdout)["counts"] == ref.counts
        api = predicates.intersect(meshio.read(tmp_path / "groups.msh"),
                                   meshio.read(cut), sim_region=region)
        assert api.counts == ref.counts and len(api.sim_cells) == len(cells)
    one_line_error(fperr("intersect", "groups.msh", cut, "--sim-region", "middle",
                         cwd=tmp_path), "groups.msh", "no region 'middle'", "7 (lower)")


def test_cell_block_selection(tmp_path):
    ex = example("plane_offset", 2)
    F = ex["cut"][1]
    _, sim, _ = write_3d(tmp_path)
    # API: a mesh object's cell block by index
    three = meshio.Mesh(ex["cut"][0], [("triangle", F[:1]), ("line", F[:2, :2]),
                                       ("triangle", F[1:])])
    api = predicates.intersect(meshio.read(sim), three, cut_region=2)
    assert len(api.cut_cells) == len(F) - 1
    assert api.counts == predicates.intersect(*ex["sim"], ex["cut"][0], F[1:]).counts
    # CLI: a VTU's blocks (meshio groups them by cell type: triangles, vertices)
    meshio.Mesh(ex["cut"][0], [("triangle", F), ("vertex", np.arange(4)[:, None])]).write(
        tmp_path / "c.vtu")
    r = fperr("intersect", sim, "c.vtu", "--cut-region", "0", "--format", "json",
              cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["counts"] == predicates.intersect(*ex["sim"], *ex["cut"]).counts
    one_line_error(fperr("intersect", sim, "c.vtu", "--cut-region", "1", cwd=tmp_path),
                   "c.vtu", "no triangles (cell types: vertex)")
    one_line_error(fperr("intersect", sim, "c.vtu", "--cut-region", "5", cwd=tmp_path),
                   "c.vtu", "no region '5'", "cell blocks 0..1 (triangle, vertex)")


def test_tetrahedral_cutting_mesh_uses_its_boundary_with_a_note(tmp_path):
    from predicates.registration.examples import cube_grid

    P, T = cube_grid(1)  # one cube of 6 tetrahedra, inside the unit cube
    meshio.Mesh(P * 0.5 + 0.2, [("tetra", T)]).write(tmp_path / "tets.vtu")
    _, sim, _ = write_3d(tmp_path)
    r = fperr("intersect", sim, "tets.vtu", "--format", "json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert any("boundary triangles" in n for n in d["notes"])
    assert d["cutting_cells"] == 12  # the cube's surface: 6 faces × 2 triangles
    assert d["total"] > 0


def test_empty_and_disjoint_meshes_are_said_so(tmp_path):
    ex, sim, _ = write_3d(tmp_path)
    res = predicates.intersect(*ex["sim"], ex["cut"][0], np.zeros((0, 3), int))
    assert res.total == 0 and "the cutting mesh is empty" in str(res)
    meshio.Mesh(ex["cut"][0] + 10, [("triangle", ex["cut"][1])]).write(tmp_path / "far.vtu")
    r = fperr("intersect", sim, "far.vtu", cwd=tmp_path)
    assert r.returncode == 0 and "bounding boxes do not overlap" in r.stdout


def test_meshio_chatter_does_not_reach_stdout(tmp_path):
    """gmsh input: the stdout of --format json is exactly one JSON document."""
    ex = example("circle", 4, segments=12)
    pad = (lambda p: np.column_stack([p, np.zeros(len(p))]))
    meshio.Mesh(pad(ex["sim"][0]), [("triangle", ex["sim"][1])]).write(
        tmp_path / "s.msh", file_format="gmsh22")
    meshio.Mesh(pad(ex["cut"][0]), [("line", ex["cut"][1])]).write(
        tmp_path / "c.msh", file_format="gmsh22")
    r = fperr("intersect", "s.msh", "c.msh", "--format", "json", "-o", "o.vtu", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("{") and r.stdout.rstrip().endswith("}")
    json.loads(r.stdout)
