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

Prints the summary tables and writes into the output directory: demo_2d.png (the 2D
registration), demo_degenerate_2d.png (a degenerate 2D case, robust beside naive, the
naive run's inconsistencies marked), demo_3d.png (the cut tetrahedra), demo_split_3d.png (the virtual-node split of a cube
by a sphere and by a plane through grid vertices), demo_2d.vtu,
demo_3d.vtu (intersection points with the kind legend, for ParaView), the simulation
meshes with cut-cell data (demo_2d_sim.vtu, demo_3d_sim.vtu) and the cutting meshes
(demo_2d_cut.vtu, demo_3d_cut.vtu).

The degenerate table runs at resolution min(n, 10): it compares methods, and its
counts do not need large meshes (at n = 64 it would dominate the run time).
"""
from __future__ import annotations

import os
import sys

import numpy as np

from predicates import portable
from predicates.registration.examples import example
from predicates.registration.io.write import write_meshio, write_mesh
from predicates.registration.pipeline import intersect
from predicates.registration.pictures.plot import plot_2d, plot_3d_cells, plot_robust_naive

__all__ = ["DEGENERATE_MAX_N", "FILES", "ROTATIONS", "degenerate_cases", "demo", "rotation",
           "sphere_case"]

#: the largest resolution of the degenerate-case table
DEGENERATE_MAX_N = 10
#: the files the demo writes
FILES = ("demo_2d.png", "demo_degenerate_2d.png", "demo_3d.png", "demo_split_3d.png",
         "demo_conforming_3d.png", "demo_2d.vtu",
         "demo_3d.vtu", "demo_2d_sim.vtu", "demo_2d_cut.vtu", "demo_3d_sim.vtu",
         "demo_3d_cut.vtu")


def rotation(dim: int, seed: int = 1) -> np.ndarray:
    """A fixed rotation, the same bits on every machine (:func:`portable.rotation`), to
    make exact incidences hold only to rounding."""
    return portable.rotation(dim, seed)


def _rotated(mesh, R):
    return portable.rotate(mesh[0], R), mesh[1]


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
                variants.append((_rotated(ex["sim"], R), _rotated(ex["cut"], R)))
        out.append((name, variants, inside))
    return out


def demo(out: str | os.PathLike, *, n: int = 16, dtype: str = "float64",
         progress: bool = False) -> None:
    """Run the three parts of the demo (module docstring) at grid resolution ``n``
    (n×n squares in 2D, n/2 cubes per side in 3D) in the working precision ``dtype``,
    print their tables and write the files into the directory ``out`` (created if
    missing). ``progress``: a bar on stderr over the demo's steps."""
    if isinstance(n, bool) or int(n) != n or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"{out} exists and is not a directory")
    dtype = np.dtype(dtype)
    os.makedirs(out, exist_ok=True)
    from tqdm import tqdm

    cases = degenerate_cases(min(int(n), DEGENERATE_MAX_N))
    bar = tqdm(total=5 + sum(len(v) for _, v, _ in cases), disable=not progress,
               desc="fperr demo", unit="step", leave=False, mininterval=0.5)
    with bar:
        _demo_2d(out, int(n), dtype, bar)
        _demo_3d(out, max(2, int(n) // 2), dtype, bar)
        _degenerate_picture(out, dtype, bar)
        _split_picture(out, bar)
        _degenerate_table(cases, dtype, bar)
    print(f"\nwrote {', '.join(FILES)} into {out}/")


def _demo_2d(out, n, dtype, bar):
    ex2 = example("circle", n, segments=4 * n)
    res2 = intersect(*ex2["sim"], *ex2["cut"], dtype=dtype)
    bar.write(f"== 2D: {n}×{n} grid cut by a {4 * n}-gon ==\n{res2}\n", file=sys.stdout)
    plot_2d(res2, os.path.join(out, "demo_2d.png"),
            title=f"fperr demo: {n}×{n} grid cut by a {4 * n}-gon, {res2.total} pairs")
    write_meshio(os.path.join(out, "demo_2d.vtu"), res2.to_meshio())
    write_meshio(os.path.join(out, "demo_2d_sim.vtu"), res2.sim_mesh())
    write_mesh(os.path.join(out, "demo_2d_cut.vtu"), *ex2["cut"], "line")
    bar.update()


def sphere_case(n3: int) -> dict:
    """The 3D example: n3³ cubes × 6 tetrahedra and an icosphere no coarser than them."""
    subdiv = int(np.clip(round(np.log2(max(n3, 2))), 1, 5))
    return example("sphere", n3, subdivisions=subdiv)


def _demo_3d(out, n3, dtype, bar):
    ex3 = sphere_case(n3)
    # the icosphere is generated no coarser than the grid: the refinement has nothing to
    # do (0 rounds, same pairs: tests), and its check is one pass over the edges
    res3 = intersect(*ex3["sim"], *ex3["cut"], dtype=dtype)
    bar.write(f"== 3D: {n3}³ cubes × 6 tetrahedra cut by an icosphere "
              f"({len(ex3['cut'][1])} triangles) ==\n{res3}\n", file=sys.stdout)
    plot_3d_cells(res3, os.path.join(out, "demo_3d.png"),
                  title=f"fperr demo: {len(res3.intersected_cells())} of "
                        f"{len(res3.sim_cells)} tetrahedra cut by an icosphere (half shown)")
    write_meshio(os.path.join(out, "demo_3d.vtu"), res3.to_meshio())
    write_meshio(os.path.join(out, "demo_3d_sim.vtu"), res3.sim_mesh())
    write_mesh(os.path.join(out, "demo_3d_cut.vtu"), *ex3["cut"], "triangle")
    bar.update()


def _degenerate_picture(out, dtype, bar):
    """The rotated zig-zag through edge midpoints: the first rotation whose naive run
    is inconsistent, robust beside naive."""
    ex = example("zigzag", 8, offset=True)
    inside = np.all((ex["cut"][0] > 0) & (ex["cut"][0] < 1), axis=1)
    for seed in range(ROTATIONS):
        R = rotation(2, seed)
        sim, cut = _rotated(ex["sim"], R), _rotated(ex["cut"], R)
        z = intersect(*sim, *cut, dtype=dtype, tolerance_scale=0)
        if z.inconsistencies(inside) or seed == ROTATIONS - 1:
            break
    r = intersect(*sim, *cut, dtype=dtype)
    plot_robust_naive(r, z, inside, os.path.join(out, "demo_degenerate_2d.png"),
                      title="zig-zag cut through edge midpoints of an 8×8 grid, rotated "
                            f"(rotation {seed}): on the mesh's edges only to rounding")
    bar.update()


def _split_picture(out, bar):
    """The virtual-node split (docs/split.md): a cube of 8³ × 6 tetrahedra cut by an
    icosphere and by the plane z = 1/2 through grid vertices, pieces exploded."""
    s_sphere, s_plane = demo_figure(os.path.join(out, "demo_split_3d.png"), n=8)
    bar.write(f"== split: cube cut by a sphere -> {s_sphere.n_pieces} pieces; by the plane "
              f"z = 1/2 through grid vertices -> {s_plane.n_pieces} pieces ==\n",
              file=sys.stdout)
    from predicates.registration.pictures.conforming import sphere_out_of_cube

    cm = sphere_out_of_cube(os.path.join(out, "demo_conforming_3d.png"), n=8)
    bar.write(f"== conforming: {len(cm.cells)} positive tetrahedra, "
              f"{len(cm.cut_faces)} cut faces, {cm.n_pieces} pieces ==\n", file=sys.stdout)
    bar.update()


def _degenerate_table(cases, dtype, bar):
    lines = ["== degenerate cases: robust against naive (zero tolerances) ==",
             "inconsistencies = cutting vertices inside the mesh not located exactly once",
             "                + cutting edges whose events are not a walk through the mesh"]
    rows = []
    for name, variants, inside in cases:
        row = np.zeros(4, dtype=np.int64)
        for sim, cut in variants:
            r = intersect(*sim, *cut, dtype=dtype)
            z = intersect(*sim, *cut, dtype=dtype, tolerance_scale=0)
            row += (r.total, r.inconsistencies(inside), z.total, z.inconsistencies(inside))
            bar.update()
        rows.append((name, *row.tolist()))
    w = max(len(r[0]) for r in rows)
    lines.append(f"{'case':<{w}}  {'robust pairs':>12}  {'inconsist.':>10}  "
                 f"{'naive pairs':>11}  {'inconsist.':>10}")
    for name, a, b, c, d in rows:
        lines.append(f"{name:<{w}}  {a:>12}  {b:>10}  {c:>11}  {d:>10}")
    bar.write("\n".join(lines), file=sys.stdout)


def demo_figure(path: str, n: int = 8, subdivisions: int = 3) -> list:
    """The demo picture: the unit cube (n³ cubes × 6 Kuhn tetrahedra) cut by an
    icosphere (cut away at y = ½ to show the ball in its cavity) and by the plane
    z = ½ through grid vertices (every vertex of that plane is registered on the cut;
    the halves exploded apart). The ball and the cube with its cavity have nearly the
    same centroid: they are set side by side (``SplitMesh.explode_offsets``). Returns the two splits."""
    from predicates.registration.examples import cube_grid, grid_plane, icosphere

    sim = cube_grid(n)
    s_sphere = intersect(sim, icosphere(subdivisions)).split()
    s_plane = intersect(sim, grid_plane(n)).split()
    from predicates.registration.pictures.view import view
    from predicates.registration.split.plot import _figure, draw_pieces

    plt, fig, (a1, a2) = _figure(3, 2)
    draw_pieces(a1, s_sphere, explode=0.15, clip=(1, 0.5, 1), view=view(elev=20, azim=-75))
    a1.set_title(f"cube cut by a sphere: {s_sphere.n_pieces} pieces, side by side\n"
                 "(cells with centroid y ≥ ½ shown, to look inside; lighter: fragments)")
    draw_pieces(a2, s_plane, explode=0.6, view=view(elev=15, azim=-60))
    a2.set_title(f"cut by the plane z = ½ through grid vertices: {s_plane.n_pieces} pieces"
                 f"\n({int(s_plane.on_cut.sum())} vertices on the cut; exploded)")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return [s_sphere, s_plane]
