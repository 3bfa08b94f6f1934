"""Run the built-in examples (generated, no download).

1. 2D: an n×n grid of squares (two triangles each) cut by a circle polygon;
2. 3D: the unit cube as n/2 × n/2 × n/2 cubes of six tetrahedra cut by an icosphere;
3. degenerate cases, robust registration against the naive zero-tolerance baseline:
   cuts lying on mesh edges, through mesh vertices and on mesh faces, also under ten
   fixed rotations (so that "on" holds only to rounding; counts summed). Inconsistencies: cutting vertices inside the
   simulation mesh not located exactly once (IntersectionResult.mislocated), plus
   cutting edges whose events are not a walk through the mesh
   (IntersectionResult.broken_walks).

Prints the summary tables and writes into --out (default ./fperr-demo/):
demo_2d.png (plot), demo_2d.vtu, demo_3d.vtu (intersection points, for ParaView) and
the meshes themselves (demo_2d_sim.vtu, demo_2d_cut.vtu, demo_3d_sim.vtu,
demo_3d_cut.vtu).
"""
from __future__ import annotations

import os
import sys

import numpy as np


def add_arguments(p):
    p.add_argument("--out", default="fperr-demo", metavar="DIR",
                   help="output directory (default ./fperr-demo, created if missing)")
    p.add_argument("--n", type=int, default=16, metavar="N",
                   help="grid resolution: N×N squares in 2D, N/2 cubes per side in 3D "
                        "(default 16)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def rotation(dim, seed=1):
    """A fixed rotation (deterministic), to make exact incidences hold only to rounding."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(dim, dim)))
    return q * np.sign(np.diag(r))


ROTATIONS = 10


def degenerate_cases(n):
    """[(name, [(sim, cut), ...] variants, inside mask of the cutting vertices)]:
    rotated cases come as ROTATIONS fixed rotations (their counts are summed)."""
    from .meshes import example

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


def _write_mesh(path, points, cells, cell_type):
    import meshio

    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    meshio.Mesh(pts, [(cell_type, np.asarray(cells))]).write(path)


def run(args):
    from .cli_intersect import plot_2d
    from .registration import intersect
    from .meshes import example

    if args.n < 2:
        print("fperr demo: error: --n must be at least 2", file=sys.stderr)
        return 2
    dtype = np.dtype(args.dtype)
    os.makedirs(args.out, exist_ok=True)
    n, n3 = args.n, max(2, args.n // 2)
    progress = not args.quiet

    ex2 = example("circle", n, segments=4 * n)
    res2 = intersect(*ex2["sim"], *ex2["cut"], dtype=dtype, progress=progress)
    print(f"== 2D: {n}×{n} grid cut by a {4 * n}-gon ==")
    print(res2, end="\n\n")
    plot_2d(res2, os.path.join(args.out, "demo_2d.png"),
            title=f"fperr demo: {n}×{n} grid cut by a circle polygon")
    res2.to_meshio().write(os.path.join(args.out, "demo_2d.vtu"))
    _write_mesh(os.path.join(args.out, "demo_2d_sim.vtu"), *ex2["sim"], "triangle")
    _write_mesh(os.path.join(args.out, "demo_2d_cut.vtu"), *ex2["cut"], "line")

    subdiv = int(np.clip(round(np.log2(max(n3, 2))), 1, 5))
    ex3 = example("sphere", n3, subdivisions=subdiv)
    res3 = intersect(*ex3["sim"], *ex3["cut"], dtype=dtype, progress=progress)
    print(f"== 3D: {n3}³ cubes × 6 tetrahedra cut by an icosphere "
          f"({len(ex3['cut'][1])} triangles) ==")
    print(res3, end="\n\n")
    res3.to_meshio().write(os.path.join(args.out, "demo_3d.vtu"))
    _write_mesh(os.path.join(args.out, "demo_3d_sim.vtu"), *ex3["sim"], "tetra")
    _write_mesh(os.path.join(args.out, "demo_3d_cut.vtu"), *ex3["cut"], "triangle")

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
    print(f"\nwrote demo_2d.png, demo_2d.vtu, demo_3d.vtu and the meshes into {args.out}/")
    return 0
