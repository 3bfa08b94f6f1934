"""Mesh files in and out of the registration (section 1 of the paper): reading any
format meshio knows, writing meshes and results, and checking an output path before any
work is done (so a refused run writes nothing)."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["PLOT_FORMATS", "check_output", "read_mesh", "write_mesh"]

#: the image formats :func:`predicates.registration.plot.plot_2d` writes
PLOT_FORMATS = (".png", ".pdf", ".svg")


def read_mesh(path: str | os.PathLike):
    """Read a mesh file with meshio (any format it knows), with a clear error."""
    import meshio

    if not os.path.isfile(path):
        raise FileNotFoundError(f"no such mesh file: {path}")
    try:
        with np.errstate(all="ignore"):  # meshio's STL reader overflows harmlessly
            return meshio.read(path)
    except meshio.ReadError as e:
        raise ValueError(f"cannot read {path}: {e}") from None


def check_output(path: str | os.PathLike, kind: str) -> None:
    """Refuse an output path that cannot be written: its directory is missing, or its
    extension is not a mesh format meshio knows (``kind="mesh"``) or an image format
    (``kind="plot"``)."""
    path = os.fspath(path)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise ValueError(f"{path}: directory {parent} does not exist")
    ext = os.path.splitext(path)[1].lower()
    if kind == "plot" and ext not in PLOT_FORMATS:
        raise ValueError(f"{path}: plots are written as {', '.join(PLOT_FORMATS)}")
    if kind == "mesh":
        import meshio

        if ext not in meshio.extension_to_filetypes:
            raise ValueError(f"{path}: meshio cannot write '{ext or 'no extension'}' "
                             "files (use .vtu for ParaView)")


def write_mesh(path: str | os.PathLike, points: np.ndarray, cells: np.ndarray,
               cell_type: str) -> None:
    """Write one cell block with meshio (2D points get z = 0, as mesh files expect)."""
    import meshio

    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    meshio.Mesh(pts, [(cell_type, np.asarray(cells))]).write(path)
