"""Register the intersections of a simulation mesh with a cutting mesh.

SIM: triangles (2D) or tetrahedra (3D); CUT: line segments (2D) or triangles (3D). Any
format meshio reads (Gmsh .msh, .vtu/.vtk, Medit .mesh, .obj, .off, .stl, .ply, ...).
Prints the tolerances and the number of pairs registered per kind; -o writes the
intersection points (kind, vertex ids and barycentric weights as point data) for
ParaView; --plot draws a 2D case with matplotlib, colour-coded by kind.

examples:
  fperr intersect grid.msh circle.vtk -o hits.vtu --plot hits.png
  fperr intersect cube.vtu sphere.stl --dtype float32 --quiet
"""
from __future__ import annotations

import os
import sys

import numpy as np

#: one colour per kind (matplotlib tab10), by registration order in 2D and 3D
COLOURS = {"vertex_vertex": "tab:red", "vertex_edge": "tab:orange", "edge_vertex": "tab:purple",
           "edge_edge": "tab:blue", "triangle_vertex": "tab:green",
           "vertex_triangle": "tab:brown", "edge_triangle": "tab:cyan",
           "triangle_edge": "tab:olive", "tetrahedron_vertex": "tab:pink"}

PLOT_FORMATS = (".png", ".pdf", ".svg")


def add_arguments(p):
    p.add_argument("sim", help="simulation mesh file (triangles in 2D, tetrahedra in 3D)")
    p.add_argument("cut", help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("-o", "--output", metavar="OUT.vtu",
                   help="write the intersection points (any meshio format, e.g. .vtu)")
    p.add_argument("--plot", metavar="OUT.png", help="draw a 2D case (png, pdf or svg)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision (default float64)")
    p.add_argument("--naive", action="store_true",
                   help="zero tolerances: the naive floating-point baseline, for comparison")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _check_output(path, kind):
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise ValueError(f"{kind} {path}: directory {parent} does not exist")
    if kind == "plot" and os.path.splitext(path)[1].lower() not in PLOT_FORMATS:
        raise ValueError(f"--plot {path}: use one of {', '.join(PLOT_FORMATS)}")
    if kind == "output":
        import meshio

        ext = os.path.splitext(path)[1].lower()
        if ext not in meshio._helpers.extension_to_filetypes:  # noqa: SLF001
            raise ValueError(f"-o {path}: meshio cannot write '{ext or 'no extension'}' "
                             "files (use .vtu for ParaView)")


def plot_2d(res, path, title=None):
    """Draw a 2D result: the simulation mesh, the cutting segments and the
    intersection points coloured by kind (matplotlib, Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    if res.dim != 2:
        raise ValueError("plots are drawn for 2D meshes only")
    sp = res.sim_points.astype(np.float64)
    cp = res.cut_points.astype(np.float64)
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.triplot(sp[:, 0], sp[:, 1], res.sim_cells, color="0.75", lw=0.6)
    ax.add_collection(LineCollection(cp[res.cut_cells], colors="k", linewidths=1.2))
    for kind in res.kinds:
        p = res[kind]
        if len(p):
            X = p.points(sp, "sim")
            ax.scatter(X[:, 0], X[:, 1], s=22, color=COLOURS[kind], zorder=3,
                       label=f"{kind} ({len(p)})", edgecolors="k", linewidths=0.3)
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    naive = " (naive: zero tolerances)" if res.tolerance_scale == 0 else ""
    ax.set_title(title or f"{res.total} intersections registered{naive}")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def run(args):
    from .registration import intersect
    from .mesh_input import read_mesh

    try:
        if args.output:
            _check_output(args.output, "output")
        if args.plot:
            _check_output(args.plot, "plot")
        sim, cut = read_mesh(args.sim), read_mesh(args.cut)
        res = intersect(sim, cut, dtype=np.dtype(args.dtype), progress=not args.quiet,
                        tolerance_scale=0.0 if args.naive else 1.0)
        if args.plot and res.dim != 2:
            raise ValueError("--plot draws 2D meshes only (this case is 3D; open the -o "
                             "output in ParaView instead)")
    except (ValueError, TypeError, FileNotFoundError, ArithmeticError) as e:
        print(f"fperr intersect: error: {e}", file=sys.stderr)
        return 2
    print(res)
    if args.output:
        res.to_meshio().write(args.output)
        print(f"wrote {args.output} ({res.total} points)")
    if args.plot:
        plot_2d(res, args.plot)
        print(f"wrote {args.plot}")
    return 0
