"""``fperr cut``'s files: register two mesh files as ``fperr intersect`` does, split the
simulation mesh along the cut (:mod:`predicates.registration.split.mesh`, docs/split.md)
and write the split mesh and its picture. Above the split and the pipeline: it runs
both."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["SPLIT_FORMATS", "check_cut_outputs", "cut_files"]

#: formats whose meshio writers keep cell data (checked: .msh, .off, .ply, .stl drop it)
SPLIT_FORMATS = (".vtu",)  # meshio's legacy .vtk writer drops field data


def check_cut_outputs(sim, cut, *, output=None, png=None, explode: float = 0.0) -> None:
    """The checks of :func:`cut_files` that need no work: the outputs' formats and
    directories (never an input file) and ``explode``; ValueError naming the problem."""
    from predicates.registration.io.files import check_outputs, input_roles

    if output is not None:
        ext = os.path.splitext(os.fspath(output))[1].lower()
        if ext not in SPLIT_FORMATS:
            raise ValueError(f"{output}: '{ext or 'no extension'}' files cannot hold the "
                             f"cell data (piece, cell_origin, material); use "
                             f"{' or '.join(SPLIT_FORMATS)}")
    if not np.isfinite(explode) or explode < 0:
        raise ValueError(f"explode must be a finite number >= 0, got {explode}")
    check_outputs(input_roles(sim, cut), {("-o", "mesh"): output, ("--png", "plot"): png})


def cut_files(sim, cut, *, output=None, png=None, explode: float = 0.0,
              conforming: bool = False, **options):
    """``fperr cut``: register two mesh files, split the simulation mesh, write the split
    mesh (``output``: .vtu, which keeps its cell data) and a picture (``png``). Every
    argument is checked before any work (an output naming an input is refused), inputs
    are read under guard, files are written atomically: a refused run writes nothing.
    ``sim``: a file or the pieces of one mesh; ``options``: as in
    :func:`~predicates.registration.intersect_files` (dtype, progress, regions,
    refine_cut, strict, tolerances, partitions/scheduler/timeout), so that ``fperr cut``
    registers exactly as ``fperr intersect`` does. ``conforming``: write (and draw) the
    conforming tetrahedra of the pieces instead (docs/split.md, "The conforming
    tetrahedralization"; a refusal raises
    :class:`~predicates.registration.split.conform.NotConforming`, nothing written).
    Returns (IntersectionResult, SplitMesh, ConformingMesh or None)."""
    from predicates.registration.io.write import write_atomic, write_meshio
    from predicates.registration.pipeline import intersect_files

    check_cut_outputs(sim, cut, output=output, png=png, explode=explode)
    res = intersect_files(sim, cut, **options)
    sm = res.split()
    cm = sm.tetrahedralize() if conforming else None
    if output is not None:
        write_meshio(output, (cm or sm).to_meshio(explode=explode))
    if png is not None and cm is not None:
        from predicates.registration.pictures.conforming import plot_conforming

        write_atomic(png, lambda tmp: plot_conforming(cm, tmp, explode=explode or 0.3))
    elif png is not None:
        from predicates.registration.split.plot import plot_split

        write_atomic(png, lambda tmp: plot_split(sm, tmp, explode=explode or 0.3))
    return res, sm, cm
