"""``fperr cut``'s files: register two mesh files as ``fperr intersect`` does, split the
simulation mesh along the cut (:mod:`predicates.registration.split.mesh`, docs/split.md)
and write the split mesh and its picture. Above the split and the pipeline: it runs
both."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["SPLIT_FORMATS", "SURFACE_FORMATS", "check_cut_outputs", "cut_files"]

#: formats whose meshio writers keep cell data (checked: .msh, .off, .ply, .stl drop it)
SPLIT_FORMATS = (".vtu",)  # meshio's legacy .vtk writer drops field data
#: formats for the cut surface: polygons of any size with cell data (cell, cut cell)
SURFACE_FORMATS = (".vtu",)  # check_output: results are .vtu


def _check_format(path, allowed, what) -> None:
    if path is None:
        return
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in allowed:
        raise ValueError(f"{path}: '{ext or 'no extension'}' files cannot hold the "
                         f"cell data ({what}); use {' or '.join(allowed)}")


def check_cut_outputs(sim, cut, *, output=None, png=None, explode: float = 0.0,
                      surface=None, then=()) -> None:
    """The checks of :func:`cut_files` that need no work: the outputs' formats and
    directories (never an input file) and ``explode``; ValueError naming the problem."""
    from predicates.registration.io.files import check_outputs, input_roles

    _check_format(output, SPLIT_FORMATS, "piece, cell_origin, material, volume")
    _check_format(surface, SURFACE_FORMATS, "cell, cut_cell, input_cut_cell")
    if not np.isfinite(explode) or explode < 0:
        raise ValueError(f"explode must be a finite number >= 0, got {explode}")
    if then and surface is not None:
        raise ValueError("--surface writes the first cut's polygons; with --then the cut "
                         "faces of every round are in the conforming mesh (-o): drop "
                         "--surface or --then")
    check_outputs(input_roles(sim, cut, then), {
        ("-o", "mesh"): output, ("--png", "plot"): png, ("--surface", "mesh"): surface})


def cut_files(sim, cut, *, output=None, png=None, explode: float = 0.0, surface=None,
              volumes: bool = True, conforming: bool = False, then=(), **options):
    """``fperr cut``: register two mesh files, split the simulation mesh, write the split
    mesh (``output``: .vtu, with the fragments' volumes and moments as cell data unless
    ``volumes`` is False, docs/split.md), the cut surface (``surface``: .vtu, the polygons of the
    cutting surface inside every cell) and a picture (``png``, the cut surface drawn
    in it). Every argument is checked before any work (an output naming an input is
    refused), inputs are read under guard, files are written atomically: a refused run
    writes nothing. ``sim``: a file or the pieces of one mesh; ``options``: as in
    :func:`~predicates.registration.intersect_files` (dtype, progress, regions,
    refine_cut, strict, tolerances, partitions/scheduler/timeout), so that ``fperr cut``
    registers exactly as ``fperr intersect`` does. ``conforming``: write (and draw) the
    conforming tetrahedra of the pieces instead of the split (docs/split.md, "The
    conforming tetrahedralization"; a refusal raises
    :class:`~predicates.registration.split.conform.NotConforming`, nothing written).
    ``then``: further cutting mesh files, each cutting the conforming mesh again in turn
    (docs/split.md, "Progressive cuts": implies ``conforming``; registered serially with
    the same dtype, tolerances and options); they are read before any work.
    Returns (IntersectionResult, SplitMesh, CutSurface or None, FragmentVolumes or None,
    ConformingMesh or None)."""
    from predicates.registration.io.read import read_mesh
    from predicates.registration.io.write import write_atomic, write_meshio
    from predicates.registration.pipeline import intersect_files
    from predicates.registration.split.surface import cut_surface
    from predicates.registration.split.volume import fragment_volumes

    check_cut_outputs(sim, cut, output=output, png=png, explode=explode, surface=surface,
                      then=then)
    later = [(p, read_mesh(p)) for p in then]  # a missing or unreadable file: no work
    res = intersect_files(sim, cut, **options)
    sm = res.split()
    cm = sm.tetrahedralize() if conforming or then else None
    if later:
        cm = _recut_files(cm, later, res, options)
    with_volumes = output is not None and volumes and cm is None
    # the surface only where something uses it: the volumes, --surface, the split picture
    cs = cut_surface(res) if (with_volumes or surface or (png and cm is None)) else None
    fv = fragment_volumes(res, sm, cs) if with_volumes else None
    if output is not None:
        write_meshio(output, cm.to_meshio(explode=explode) if cm is not None
                     else sm.to_meshio(explode=explode, volumes=fv))
    if surface is not None:
        write_meshio(surface, cs.to_meshio(plane=res.plane or 0.0))
    if png is not None and cm is not None:
        from predicates.registration.pictures.conforming import plot_conforming

        write_atomic(png, lambda tmp: plot_conforming(cm, tmp, explode=explode or 0.3))
    elif png is not None:
        from predicates.registration.split.plot import plot_split

        write_atomic(png, lambda tmp: plot_split(sm, tmp, explode=explode or 0.3,
                                                 surface=cs))
    return res, sm, cs, fv, cm


#: the registration options a recut takes (the run's partitioning and regions are the
#: first registration's: the conforming mesh is a new simulation mesh, cut serially)
_RECUT_OPTIONS = ("dtype", "refine_cut", "strict", "tolerances", "progress")


def _recut_files(cm, later, res, options):
    """``cm`` cut again by each further cutting mesh in turn (:func:`.progressive.recut`),
    every file converted for ``res``'s dimension and plane first (errors name it)."""
    from predicates.registration.io.files import converted_cut
    from predicates.registration.split.progressive import recut

    dtype = options.get("dtype", "float64")
    cuts = [converted_cut(p, mesh, res.dim, dtype, res.plane) for p, mesh in later]
    kept = {k: options[k] for k in _RECUT_OPTIONS if options.get(k) is not None}
    for c in cuts:
        cm = recut(cm, c.points, c.cells, **kept)
    return cm
