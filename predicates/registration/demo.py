"""The built-in examples of the registration (section 1 of the paper), generated (no
download): what ``fperr demo`` runs.

1. 2D: an n×n grid of squares (two triangles each) cut by a circle polygon;
2. 3D: the unit cube as n/2 × n/2 × n/2 cubes of six tetrahedra cut by an icosphere;
3. degenerate cases, robust registration against the naive zero-tolerance baseline:
   cuts lying on mesh edges, through mesh vertices and on mesh faces, also under ten
   fixed rotations (so that "on" holds only to rounding; counts summed).
   Inconsistencies: cutting vertices inside the simulation mesh not located exactly
   once (IntersectionResult.mislocated), plus cutting edges whose events are not a walk
   through the mesh (IntersectionResult.broken_walks).

Prints the summary tables and writes into the output directory:
demo_2d.png (plot), demo_2d.vtu, demo_3d.vtu (intersection points, for ParaView) and
the meshes themselves (demo_2d_sim.vtu, demo_2d_cut.vtu, demo_3d_sim.vtu,
demo_3d_cut.vtu).
"""
from __future__ import annotations

import os

import numpy as np

from .examples import example
from .files import write_mesh
from .pipeline import intersect
from .plot import plot_2d

__all__ = ["ROTATIONS", "degenerate_cases", "demo", "rotation"]


def rotation(dim, seed=1):
    """A fixed rotation (deterministic), to make exact incidences hold only to rounding."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(dim, dim)))
    return q * np.sign(np.diag(r))


ROTATIONS = 10


def degenerate_cases(n):
    """[(name, [(sim, cut), ...] variants, inside mask of the cutting vertices)]:
    rotated cases come as ROTATIONS fixed rotations (their counts are summed)."""
    n3 = max(2, n // 2)
    m = max(7, n)
    cases = [("2D diagonal on mesh edges", example("diagonal", n), False),
             ("2D zig-zag on edge midpoints", example("zigzag", n, offset=True), False),
             ("2D zig-zag on edge midpoints, rotated", example("zigzag", n, offset=True), True),
             ("2D zig-zag through vertices, slope 3, rotated",
              example("zigzag", m + m % 2, dx=2, dy=6), True),
             ("3D plane on grid vertices", example("plane", n3), False),
             ("3D plane on grid vertices, rotated", example("plane", n3), True),
             ("3D plane offset half a cell", example("plane_offset", n3), False),
             ("3D plane offset half a cell, rotated", example("plane_offset", n3), True)]
    out = []
    for name, ex, rot in cases:
        cp = ex["cut"][0]
        inside = np.all((cp > 0) & (cp < 1), axis=1)  # strictly inside the unit square/cube
        variants = [(ex["sim"], ex["cut"])]
        if rot:
            name = f"{name} ×{ROTATIONS}"
            variants = []
            for seed in range(ROTATIONS):
                R = rotation(ex["dim"], seed)
                variants.append(((ex["sim"][0] @ R.T, ex["sim"][1]),
                                 (ex["cut"][0] @ R.T, ex["cut"][1])))
        out.append((name, variants, inside))
    return out


def demo(out: str | os.PathLike, *, n: int = 16, dtype: str = "float64",
         progress: bool = False) -> None:
    """Run the three parts of the demo (module docstring) at grid resolution ``n``
    (n×n squares in 2D, n/2 cubes per side in 3D) in the working precision ``dtype``,
    print their tables and write the files into the directory ``out`` (created if
    missing)."""
    if int(n) != n or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"{out} exists and is not a directory")
    dtype = np.dtype(dtype)
    os.makedirs(out, exist_ok=True)
    _demo_2d(out, int(n), dtype, progress)
    _demo_3d(out, max(2, int(n) // 2), dtype, progress)
    _degenerate_table(int(n), dtype)
    print(f"\nwrote demo_2d.png, demo_2d.vtu, demo_3d.vtu and the meshes into {out}/")


def _demo_2d(out, n, dtype, progress):
    ex2 = example("circle", n, segments=4 * n)
    res2 = intersect(*ex2["sim"], *ex2["cut"], dtype=dtype, progress=progress)
    print(f"== 2D: {n}×{n} grid cut by a {4 * n}-gon ==")
    print(res2, end="\n\n")
    plot_2d(res2, os.path.join(out, "demo_2d.png"),
            title=f"fperr demo: {n}×{n} grid cut by a circle polygon")
    res2.to_meshio().write(os.path.join(out, "demo_2d.vtu"))
    write_mesh(os.path.join(out, "demo_2d_sim.vtu"), *ex2["sim"], "triangle")
    write_mesh(os.path.join(out, "demo_2d_cut.vtu"), *ex2["cut"], "line")


def _demo_3d(out, n3, dtype, progress):
    subdiv = int(np.clip(round(np.log2(max(n3, 2))), 1, 5))
    ex3 = example("sphere", n3, subdivisions=subdiv)
    res3 = intersect(*ex3["sim"], *ex3["cut"], dtype=dtype, progress=progress)
    print(f"== 3D: {n3}³ cubes × 6 tetrahedra cut by an icosphere "
          f"({len(ex3['cut'][1])} triangles) ==")
    print(res3, end="\n\n")
    res3.to_meshio().write(os.path.join(out, "demo_3d.vtu"))
    write_mesh(os.path.join(out, "demo_3d_sim.vtu"), *ex3["sim"], "tetra")
    write_mesh(os.path.join(out, "demo_3d_cut.vtu"), *ex3["cut"], "triangle")


def _degenerate_table(n, dtype):
    print("== degenerate cases: robust against naive (zero tolerances) ==")
    print("inconsistencies = cutting vertices inside the mesh not located exactly once\n"
          "                + cutting edges whose events are not a walk through the mesh")
    rows = []
    for name, variants, inside in degenerate_cases(n):
        row = np.zeros(4, dtype=np.int64)
        for sim, cut in variants:
            r = intersect(*sim, *cut, dtype=dtype)
            z = intersect(*sim, *cut, dtype=dtype, tolerance_scale=0)
            row += (r.total, r.inconsistencies(inside), z.total, z.inconsistencies(inside))
        rows.append((name, *row.tolist()))
    w = max(len(r[0]) for r in rows)
    print(f"{'case':<{w}}  {'robust pairs':>12}  {'inconsist.':>10}  {'naive pairs':>11}  "
          f"{'inconsist.':>10}")
    for name, a, b, c, d in rows:
        print(f"{name:<{w}}  {a:>12}  {b:>10}  {c:>11}  {d:>10}")
