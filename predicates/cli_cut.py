"""Cut a simulation mesh along a cutting mesh: the virtual-node split (issue 15).

SIM: triangles (2D) or tetrahedra (3D); CUT: line segments (2D) or triangles (3D), any
format meshio reads. Registers the intersections robustly (the paper's section 1), then
splits every cell into its material fragments and glues them into pieces (rules:
docs/split.md). Prints the registration and the split; -o writes the split mesh with
cell data piece, cell_origin, material (bitmask of material corners), material_count
and point data node_origin (VTK formats only: other formats drop cell data); --explode
moves the pieces apart in the written mesh and the picture; --png draws them.

examples:
  fperr cut cube.vtu sphere.stl -o pieces.vtu --png pieces.png --explode 0.3
  fperr cut square.msh polyline.vtk -o pieces.vtk
"""
from __future__ import annotations

import os
import sys

import numpy as np

#: formats whose meshio writers keep cell data (checked: .msh, .off, .ply, .stl drop it)
OUTPUT_FORMATS = (".vtu", ".vtk")
PNG_FORMATS = (".png", ".pdf", ".svg")


def add_arguments(p):
    p.add_argument("sim", help="simulation mesh file (triangles in 2D, tetrahedra in 3D)")
    p.add_argument("cut", help="cutting mesh file (segments in 2D, triangles in 3D)")
    p.add_argument("-o", "--output", metavar="PIECES.vtu",
                   help="write the split mesh with its cell data (.vtu or .vtk)")
    p.add_argument("--explode", type=float, default=0.0, metavar="FACTOR",
                   help="move each piece by FACTOR × (its centroid − the mesh centroid), "
                        "in -o and --png (default 0; --png alone uses 0.3)")
    p.add_argument("--png", metavar="FILE", help="draw the pieces (png, pdf or svg)")
    p.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                   help="working precision of the registration (default float64)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _check(path: str, formats: tuple, flag: str, why: str) -> None:
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise ValueError(f"{flag} {path}: directory {parent} does not exist")
    ext = os.path.splitext(path)[1].lower()
    if ext not in formats:
        raise ValueError(f"{flag} {path}: '{ext or 'no extension'}' {why}; use "
                         f"{' or '.join(formats)}")


def run(args) -> int:
    from .mesh_input import read_mesh
    from .registration import intersect

    try:
        if args.output:
            _check(args.output, OUTPUT_FORMATS, "-o",
                   "files cannot hold the cell data (piece, cell_origin, material)")
        if args.png:
            _check(args.png, PNG_FORMATS, "--png", "is not a picture format")
        if not np.isfinite(args.explode) or args.explode < 0:
            raise ValueError(f"--explode must be a finite number >= 0, got {args.explode}")
        sim, cut = read_mesh(args.sim), read_mesh(args.cut)
        res = intersect(sim, cut, dtype=np.dtype(args.dtype), progress=not args.quiet)
    except (ValueError, TypeError, FileNotFoundError, ArithmeticError) as e:
        print(f"fperr cut: error: {e}", file=sys.stderr)
        return 2
    sm = res.split()
    print(res)
    print(sm)
    if args.output:
        sm.to_meshio(explode=args.explode).write(args.output)
        print(f"wrote {args.output} ({len(sm.cells)} cells, {sm.n_pieces} pieces)")
    if args.png:
        from .split_plot import plot_split

        plot_split(sm, args.png, explode=args.explode or 0.3)
        print(f"wrote {args.png}")
    return 0
