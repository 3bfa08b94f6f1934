"""The conforming cut beside VTK's clip, on the same input, timed in the same run (figures
in README.md, "The conforming cut against VTK's clip"; docs/split.md, "The conforming
tetrahedralization").

Kuhn n (default 16) cut by the plane z = ½ through its grid vertices, exactly and rotated
about the cube's centre by 2 and 8 ulp of 1 radian (about (1, 2, 0)/√5). Per case:

- fperr: the registration (``predicates.intersect``), the split (``res.split()``) and the
  conforming tetrahedralization (``sm.tetrahedralize()``), best of ``--repeat``;
- VTK: pyvista's ``clip(normal=..., origin=...)`` of the same grid (table-based clip), both
  halves (``invert`` False / True), best of ``--repeat``, its cells triangulated
  (``triangulate()``) to count tetrahedra.

Counted on both, in the same way: zero-volume tetrahedra (exact orientation sign 0 of the
stored coordinates, ``classic.FILTERED`` through ``split.tetra_faces.positive``), the
open edges of each half's boundary surface (pyvista's ``extract_surface().n_open_edges``;
fperr's pieces are written with their own points, ``separated()``), and whether the
halves fit: the boundary triangles inside the cube of one half without a triangle of the
same corner coordinates in the other.
pyvista is a test extra: imported here only.

    PYTHONPATH=. python3 benchmarks/conform_clip_bench.py [--n 16] [--repeat 3] [--json F]
"""
from __future__ import annotations

import argparse
import json

import numpy as np
from timing import best  # benchmarks/timing.py (this script's folder)

from predicates import intersect
from predicates.portable import axis_rotation, rotate
from predicates.registration.examples import cube_grid, grid_plane
from predicates.registration.split.tetra_faces import positive


def tiny_rotation(ulps: int) -> np.ndarray:
    """The rotation by ``ulps`` ulp of 1 radian about (1, 2, 0)/√5 (portable; the same as
    tests/support/cut_cases.py)."""
    return axis_rotation([1.0, 2.0, 0.0], ulps * np.finfo(np.float64).eps)



def _grid(points: np.ndarray, tets: np.ndarray):
    import pyvista as pv

    cells = np.column_stack([np.full(len(tets), 4), tets]).ravel()
    types = np.full(len(tets), pv.CellType.TETRA, dtype=np.uint8)
    return pv.UnstructuredGrid(cells, types, np.asarray(points, dtype=np.float64))


def _tets(grid):
    """(points, tetrahedra) of a pyvista grid of tetrahedra, wedges, pyramids …"""
    tri = grid.triangulate()
    conn = np.asarray(tri.cells_dict.get(10, np.zeros((0, 4), np.int64)), dtype=np.int64)
    return np.asarray(tri.points, dtype=np.float64), conn


def _inner_faces(grid) -> set:
    """The boundary triangles of a half not on the cube's boundary, as sets of their
    corners' coordinates (exact floats)."""
    surf = grid.extract_surface(algorithm="dataset_surface").triangulate()
    X = np.asarray(surf.points, dtype=np.float64)
    F = np.asarray(surf.faces).reshape(-1, 4)[:, 1:]
    out = set()
    for f in F.tolist():
        T = X[f]
        if any(np.all(T[:, k] == v) for k in range(3) for v in (0.0, 1.0)):
            continue
        out.add(frozenset(map(tuple, T.tolist())))
    return out


def counts(points: np.ndarray, tets: np.ndarray, grid) -> dict:
    """Zero-volume tetrahedra (exact sign 0; orientation conventions differ, so only
    zero is counted) and open edges of the boundary surface."""
    s = positive(tets, points) if len(tets) else np.zeros(0, np.int8)
    return {"tets": int(len(tets)), "zero_volume": int((s == 0).sum()),
            "open_edges": int(grid.extract_surface(algorithm="dataset_surface").n_open_edges),
            "faces": _inner_faces(grid)}


def _fit(halves) -> int:
    """Boundary triangles inside the cube of one half with no identical triangle (same
    corner coordinates) in the other: 0 when the halves fit."""
    a, b = halves[0].pop("faces"), halves[1].pop("faces")
    for h in halves[2:]:
        h.pop("faces")
    return len(a ^ b)


def run_case(name: str, n: int, R, repeat: int) -> dict:
    P, C = cube_grid(n)
    Q, K = grid_plane(n)
    normal = np.array([0.0, 0.0, 1.0])
    if R is not None:
        Q = rotate(Q - 0.5, R) + 0.5
        normal = rotate(normal[None], R)[0]
    res, t_reg = best(lambda: intersect(P, C, Q, K), repeat)
    sm, t_split = best(res.split, repeat)
    cm, t_conf = best(sm.tetrahedralize, repeat)
    X, S = cm.separated()
    fperr_halves = []
    for p in range(cm.n_pieces):
        rows = S[cm.piece == p]
        fperr_halves.append(counts(X, rows, _grid(X, rows)))
    grid = _grid(P, C)
    halves, t_vtk = best(lambda: [grid.clip(normal=normal, origin=(0.5, 0.5, 0.5),
                                            invert=inv) for inv in (False, True)], repeat)
    vtk_halves = [counts(*_tets(h), h) for h in halves]
    fit_fperr, fit_vtk = _fit(fperr_halves), _fit(vtk_halves)
    return {"case": name, "cells": len(C), "t_register": t_reg, "t_split": t_split,
            "unmatched_fperr": fit_fperr, "unmatched_vtk": fit_vtk,
            "t_conforming": t_conf, "t_vtk_clip": t_vtk, "fperr_pieces": cm.n_pieces,
            "fperr": fperr_halves, "vtk": vtk_halves}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    rows = []
    for name, R in (("plane z=1/2", None), ("rotated 2 ulp", tiny_rotation(2)),
                    ("rotated 8 ulp", tiny_rotation(8))):
        r = run_case(name, a.n, R, a.repeat)
        rows.append(r)
        print(f"{name}: Kuhn {a.n} ({r['cells']} tets); register {r['t_register']:.3f} s, "
              f"split {r['t_split']:.3f} s, conforming {r['t_conforming']:.3f} s "
              f"({r['t_conforming'] / r['t_register']:.2f}x the registration), VTK clip "
              f"{r['t_vtk_clip']:.3f} s ({r['t_vtk_clip'] / r['t_register']:.2f}x)")
        for who in ("fperr", "vtk"):
            for k, h in enumerate(r[who]):
                print(f"  {who:5s} half {k}: {h['tets']} tets, {h['zero_volume']} zero-volume, "
                      f"{h['open_edges']} open edges")
            print(f"  {who:5s}: {r['unmatched_' + who]} triangles of the cut without their "
                  f"twin in the other half")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
