"""`fperr intersect` and `fperr demo`."""
from __future__ import annotations

import meshio
import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from proofs.cli import main


def _pad3(p):
    return np.column_stack([p, np.zeros(len(p))]) if p.shape[1] == 2 else p


def write_case(tmp_path, name, n, sim_ext, cut_ext, **kw):
    ex = example(name, n, **kw)
    sim_type, cut_type = ("triangle", "line") if ex["dim"] == 2 else ("tetra", "triangle")
    sim = tmp_path / f"sim{sim_ext}"
    cut = tmp_path / f"cut{cut_ext}"
    meshio.Mesh(_pad3(ex["sim"][0]), [(sim_type, ex["sim"][1])]).write(sim)
    meshio.Mesh(_pad3(ex["cut"][0]), [(cut_type, ex["cut"][1])]).write(cut)
    return ex, str(sim), str(cut)


def test_intersect_2d_writes_vtu_and_png(tmp_path, capsys):
    ex, sim, cut = write_case(tmp_path, "circle", 6, ".msh", ".vtk", segments=20)
    out, png = tmp_path / "hits.vtu", tmp_path / "hits.png"
    assert main(["intersect", sim, cut, "-o", str(out), "--plot", str(png), "--quiet"]) == 0
    text = capsys.readouterr()
    assert text.err == ""  # --quiet: no progress bar
    ref = predicates.intersect(*ex["sim"], *ex["cut"])
    for kind, count in ref.counts.items():
        assert any(line.split()[:1] == [kind] and line.split()[-1] == str(count)
                   for line in text.out.splitlines())
    assert "tau" in text.out
    back = meshio.read(out)
    assert len(back.points) == ref.total
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("exts", [(".vtu", ".stl"), (".mesh", ".off"), (".vtk", ".ply"),
                                  (".msh", ".obj")])
def test_intersect_3d_formats(tmp_path, capsys, exts):
    ex, sim, cut = write_case(tmp_path, "plane_offset", 3, *exts)
    out = tmp_path / "hits.vtu"
    assert main(["intersect", sim, cut, "-o", str(out), "--quiet"]) == 0
    ref = predicates.intersect(*ex["sim"], *ex["cut"])
    assert len(meshio.read(out).points) == ref.total


def test_intersect_float32_and_naive(tmp_path, capsys):
    _, sim, cut = write_case(tmp_path, "sphere", 3, ".vtu", ".stl", subdivisions=1)
    assert main(["intersect", sim, cut, "--dtype", "float32", "--quiet"]) == 0
    assert "binary32" in capsys.readouterr().out
    assert main(["intersect", sim, cut, "--naive", "--quiet"]) == 0
    assert "NAIVE" in capsys.readouterr().out


def test_rejected_input_writes_nothing(tmp_path, capsys):
    _, sim, cut = write_case(tmp_path, "plane_offset", 2, ".vtu", ".vtu")
    out, png = tmp_path / "hits.vtu", tmp_path / "hits.png"
    # 3D case with --plot: refused, nothing written
    assert main(["intersect", sim, cut, "-o", str(out), "--plot", str(png), "--quiet"]) == 2
    assert "2D meshes only" in capsys.readouterr().err
    # a NaN coordinate
    m = meshio.read(sim)
    m.points[3, 1] = np.nan
    bad = tmp_path / "bad.vtu"
    m.write(bad)
    assert main(["intersect", str(bad), cut, "-o", str(out), "--quiet"]) == 2
    assert "NaN" in capsys.readouterr().err
    # a tetrahedron repeating a vertex
    m = meshio.read(sim)
    m.cells[0].data[5, 3] = m.cells[0].data[5, 0]
    m.write(bad)
    assert main(["intersect", str(bad), cut, "-o", str(out), "--quiet"]) == 2
    assert "repeats a vertex" in capsys.readouterr().err
    # mixed dimensions, missing file, unwritable output
    _, sim2, cut2 = write_case(tmp_path, "circle", 3, ".msh", ".vtk")
    assert main(["intersect", sim, cut2, "-o", str(out), "--quiet"]) == 2
    assert "mixed dimensions" in capsys.readouterr().err
    assert main(["intersect", str(tmp_path / "nope.vtu"), cut, "-o", str(out)]) == 2
    assert "no such mesh file" in capsys.readouterr().err
    assert main(["intersect", sim, cut, "-o", str(tmp_path / "x.unknownext")]) == 2
    assert main(["intersect", sim, cut, "-o", str(tmp_path / "missing" / "x.vtu")]) == 2
    assert main(["intersect", sim2, cut2, "--plot", str(tmp_path / "x.jpg2")]) == 2
    assert not out.exists() and not png.exists()
    assert not (tmp_path / "missing").exists()


def test_demo(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--n", "4", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "2D" in text and "3D" in text and "naive" in text
    for f in ("demo_2d.png", "demo_2d.vtu", "demo_3d.vtu", "demo_2d_sim.vtu",
              "demo_3d_cut.vtu"):
        assert (out / f).stat().st_size > 0
    # the degenerate-case table: robust column all zero, naive not
    rows = [line.split() for line in text.splitlines() if "rotated" in line]
    assert rows and all(r[-3] == "0" for r in rows)
    assert sum(int(r[-1]) for r in rows) > 0
