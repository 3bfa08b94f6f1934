"""``fperr cut``'s outputs for a simulation (docs/split.md): the fragments' volumes and
centroids as cell data of -o, the cut surface as its own file (--surface), the picture
with the cut surface (--png / --plot); refused formats write nothing (exit 2)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np

from predicates.registration.examples import circle_polygon, cube_grid, icosphere, square_grid

ROOT = Path(__file__).resolve().parents[2]


def _fperr(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_cut_writes_volumes_surface_and_picture(tmp_path):
    P, T = cube_grid(6)
    meshio.Mesh(P, [("tetra", T)]).write(tmp_path / "cube.vtu")
    Q, F = icosphere(2)
    meshio.Mesh(Q, [("triangle", F)]).write(tmp_path / "ball.vtu")
    r = _fperr("cut", "cube.vtu", "ball.vtu", "-o", "pieces.vtu", "--surface", "surf.vtu",
               "--plot", "pieces.png", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    m = meshio.read(tmp_path / "pieces.vtu")
    cd = {k: v[0] for k, v in m.cell_data.items()}
    assert {"volume", "volume_fraction", "centroid", "unclaimed_fraction"} <= set(cd)
    assert cd["centroid"].shape == (len(cd["volume"]), 3)
    # the fractions of every cell's fragments and its unclaimed part make the cell
    org = cd["cell_origin"]
    total = np.bincount(org, cd["volume_fraction"])
    first = np.searchsorted(org, np.arange(len(total)))
    assert np.allclose(total + cd["unclaimed_fraction"][first], 1, rtol=0, atol=1e-12)
    s = meshio.read(tmp_path / "surf.vtu")
    assert {"cell", "cut_cell", "input_cut_cell"} <= set(s.cell_data)
    cells = np.concatenate(s.cell_data["cell"])
    assert cells.min() >= 0 and cells.max() < len(T)
    assert set(np.concatenate(s.cell_data["input_cut_cell"]).tolist()) == set(range(len(F)))
    assert (tmp_path / "pieces.png").read_bytes()[:4] == b"\x89PNG"
    for bad in ("surf.stl", "surf.obj", "surf"):
        r = _fperr("cut", "cube.vtu", "ball.vtu", "--surface", bad, "--quiet", cwd=tmp_path)
        assert r.returncode == 2 and "cell data" in r.stderr
        assert not (tmp_path / bad).exists()


def test_cut_surface_in_2d_is_segments(tmp_path):
    P, T = square_grid(8)
    meshio.Mesh(np.column_stack([P, np.zeros(len(P))]), [("triangle", T)]).write(
        tmp_path / "sq.vtu")
    Q, E = circle_polygon(23, radius=0.3)
    meshio.Mesh(np.column_stack([Q, np.zeros(len(Q))]), [("line", E)]).write(
        tmp_path / "c.vtu")
    r = _fperr("cut", "sq.vtu", "c.vtu", "-o", "p.vtu", "--surface", "s.vtu", "--quiet",
               cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    s = meshio.read(tmp_path / "s.vtu")
    assert [c.type for c in s.cells] == ["line"]
    assert np.allclose(s.points[:, 2], 0)
