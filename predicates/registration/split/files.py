"""``fperr cut``'s files: register two mesh files, split the simulation mesh along the
cut (:mod:`predicates.registration.split.mesh`, docs/split.md) and write the split mesh
and its picture. Above the split and the pipeline: it runs both."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["SPLIT_FORMATS", "cut_files"]

SPLIT_FORMATS = (".vtu",)  # meshio's legacy .vtk writer drops field data


def cut_files(sim, cut, *, output=None, png=None, explode: float = 0.0,
              dtype: str = "float64", progress: bool = False, **options):
    """``fperr cut``: register two mesh files, split the simulation mesh, write the split
    mesh (``output``: .vtu, which keeps its cell data) and a picture (``png``). Every
    argument is checked before any work (an output naming an input is refused), inputs
    are read under guard, files are written atomically: a refused run writes nothing.
    ``options``: as in :func:`~predicates.registration.intersect`. Returns
    (IntersectionResult, SplitMesh)."""
    from predicates.registration.io.files import check_outputs, load_pair
    from predicates.registration.io.write import write_atomic, write_meshio
    from predicates.registration.pipeline import intersect

    if output is not None:
        ext = os.path.splitext(os.fspath(output))[1].lower()
        if ext not in SPLIT_FORMATS:
            raise ValueError(f"{output}: '{ext or 'no extension'}' files cannot hold the "
                             f"cell data (piece, cell_origin, material); use "
                             f"{' or '.join(SPLIT_FORMATS)}")
    if not np.isfinite(explode) or explode < 0:
        raise ValueError(f"explode must be a finite number >= 0, got {explode}")
    check_outputs({"SIM": sim, "CUT": cut}, {("-o", "mesh"): output, ("--png", "plot"): png})
    arrays = load_pair(sim, cut, dtype=dtype)
    res = intersect(*arrays, dtype=np.dtype(dtype), progress=progress, **options)
    sm = res.split()
    if output is not None:
        write_meshio(output, sm.to_meshio(explode=explode))
    if png is not None:
        from predicates.registration.split.plot import plot_split

        write_atomic(png, lambda tmp: plot_split(sm, tmp, explode=explode or 0.3))
    return res, sm
