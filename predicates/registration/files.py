"""Mesh files in and out of the registration (section 1 of the paper): the file-level
steps of :func:`predicates.registration.intersect_files` — every output checked before
any work, both inputs read under guard (:mod:`~predicates.registration.io_read`),
converted and validated with errors naming the file, and the results written atomically
(:mod:`~predicates.registration.io_write`)."""
from __future__ import annotations

import os

import numpy as np

from .inputs import Arrays, validate_mesh
from .io_convert import common_plane, convert_cut, convert_sim
from .io_read import MeshFileError, read_mesh
from .io_write import (MESH_FORMATS, PLOT_FORMATS, check_output, check_outputs,
                       write_meshio, write_mesh)

__all__ = ["MESH_FORMATS", "PLOT_FORMATS", "MeshFileError", "check_output", "check_outputs",
           "load_pair", "read_mesh", "write_mesh", "write_results"]


def load_pair(sim: str | os.PathLike, cut: str | os.PathLike, *, dtype="float64",
              sim_region=None, cut_region=None) -> Arrays:
    """Read, convert and validate two mesh files; any problem raises an error that
    starts with the file's path (:class:`MeshFileError`)."""
    sim_mesh = read_mesh(sim)
    cut_mesh = read_mesh(cut)
    try:
        dim, s = convert_sim(sim_mesh, sim_region)
        validate_mesh(s.points, s.cells, "simulation", s.points.shape[1], np.dtype(dtype),
                      allow_empty=False)
    except (ValueError, TypeError) as e:
        raise MeshFileError(sim, e) from None
    try:
        c = convert_cut(cut_mesh, dim, cut_region)
        validate_mesh(c.points, c.cells, "cutting", s.points.shape[1], np.dtype(dtype),
                      allow_empty=True)
    except (ValueError, TypeError) as e:
        raise MeshFileError(cut, e) from None
    try:
        plane = common_plane(s, c)
    except ValueError as e:
        raise MeshFileError(cut, e) from None
    notes = [f"{sim}: {n}" for n in s.notes] + [f"{cut}: {n}" for n in c.notes]
    return Arrays((s.points, s.cells, c.points, c.cells), notes, plane)


def write_results(res, *, output=None, plot=None, sim_output=None) -> None:
    """Write the intersection points (``output``), the simulation mesh with its cut-cell
    data (``sim_output``) and a 2D picture (``plot``), each atomically."""
    if output is not None:
        write_meshio(output, res.to_meshio())
    if sim_output is not None:
        write_meshio(sim_output, res.sim_mesh())
    if plot is not None:
        from .io_write import write_atomic
        from .plot import plot_2d

        write_atomic(plot, lambda tmp: plot_2d(res, tmp))
