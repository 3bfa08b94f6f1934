"""``fperr cut --conforming`` (docs/split.md, "The conforming tetrahedralization"): the
pieces written as tetrahedra in the format the extension says, positive in exact
arithmetic once read back; a refusal exits 1 and writes nothing."""
from __future__ import annotations

import meshio
import numpy as np

from conform_check import orientation_signs
from predicates.registration.examples import cube_grid, grid_plane, icosphere


def _write(tmp_path, sim, cut):
    s, c = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(sim[0], [("tetra", sim[1])]).write(s)
    meshio.Mesh(cut[0], [("triangle", cut[1])]).write(c)
    return str(s), str(c)


def _main(*args) -> int:
    from proofs.cli import main

    return main(list(args))


def test_cut_conforming_writes_positive_tetrahedra(tmp_path, capsys):
    s, c = _write(tmp_path, cube_grid(4), icosphere(1))
    out, png = tmp_path / "pieces.vtu", tmp_path / "pieces.png"
    assert _main("cut", s, c, "--conforming", "-o", str(out), "--png", str(png),
                 "--quiet") == 0
    assert "conforming:" in capsys.readouterr().out
    back = meshio.read(out)
    T = back.cells_dict["tetra"]
    assert {"piece", "cell_origin", "fragment", "side"} <= set(back.cell_data)
    assert sorted(set(back.cell_data["piece"][0].tolist())) == [0, 1]
    assert np.all(orientation_signs(back.points, T) > 0)
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_cut_conforming_refusal_exits_1_and_writes_nothing(tmp_path, capsys, monkeypatch):
    import predicates.registration.split.conform as conform

    def refuse(res, sm, cs=None):
        raise conform.NotConforming("conforming tetrahedralization refused in 1 cell(s)")

    monkeypatch.setattr(conform, "conforming_mesh", refuse)
    s, c = _write(tmp_path, cube_grid(2), grid_plane(2))
    out = tmp_path / "pieces.vtu"
    assert _main("cut", s, c, "--conforming", "-o", str(out), "--quiet") == 1
    assert "refused in 1 cell" in capsys.readouterr().err
    assert not out.exists()


def test_cut_conforming_refuses_formats_without_cell_data(tmp_path, capsys):
    s, c = _write(tmp_path, cube_grid(2), grid_plane(2))
    assert _main("cut", s, c, "--conforming", "-o", str(tmp_path / "p.stl"), "--quiet") == 2
    assert "cell data" in capsys.readouterr().err


def _cut_cli(tmp_path, cut, pieces: set) -> None:
    """``fperr cut --conforming`` (a subprocess) on Kuhn 4 × ``cut``: exit 0, the file
    written and read back by meshio, every tetrahedron positive in exact arithmetic, the
    cube's volume exactly (Fraction sum of the simplices' exact volumes: 1), the pieces
    ``pieces``."""
    import subprocess
    import sys
    from fractions import Fraction
    from pathlib import Path

    from conform_check import exact_mesh_volume

    s, c = _write(tmp_path, cube_grid(4), cut)
    out = tmp_path / "pieces.vtu"
    root = Path(__file__).resolve().parents[2]
    r = subprocess.run([sys.executable, "-m", "fperr", "cut", s, c, "--conforming", "-o",
                        str(out), "--quiet"], cwd=root, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    back = meshio.read(out)
    T = back.cells_dict["tetra"]
    assert np.all(orientation_signs(back.points, T) > 0)
    assert exact_mesh_volume(back.points, T) == Fraction(1)
    assert set(back.cell_data["piece"][0].tolist()) == pieces


def test_cut_conforming_disc_crack_inside_one_cell_through_the_cli(tmp_path):
    """Kuhn 4 × the disc crack of radius h/2, whose front runs inside one cell from face
    to face (was refused, exit 1): one piece (:func:`_cut_cli`'s checks)."""
    from cut_cases import disc_crack

    h = 0.25
    _cut_cli(tmp_path, disc_crack(0.5 * h, (0.5 + 0.3 * h, 0.5 + 0.2 * h, 0.5 + 0.1 * h)),
             {0})


def test_cut_conforming_an_inclusion_inside_one_cell_through_the_cli(tmp_path):
    """Kuhn 4 × an icosphere of radius 0.01 inside cell 37 (was refused, exit 1: a cell
    with a cavity): two pieces (:func:`_cut_cli`'s checks)."""
    P, C = cube_grid(4)
    Q, K = icosphere(1)
    _cut_cli(tmp_path, (P[C[37]].mean(axis=0) + 0.01 * Q, K), {0, 1})
