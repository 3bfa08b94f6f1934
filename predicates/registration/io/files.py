"""Mesh files in and out of the registration (section 1 of the paper): the file-level
steps of :func:`predicates.registration.intersect_files` — every output checked before
any work, both inputs read under guard (:mod:`~predicates.registration.io.read`),
converted and validated with errors naming the file, and the results written atomically
(:mod:`~predicates.registration.io.write`)."""
from __future__ import annotations

import os

import numpy as np

from predicates.registration.plan.inputs import Arrays, validate_mesh
from predicates.registration.io.convert import (
    Converted, common_plane, convert_cut, convert_sim)
from predicates.registration.io.read import MeshFileError, read_mesh
from predicates.registration.io.write import (
    MESH_FORMATS, PLOT_FORMATS, check_output, check_outputs, write_meshio, write_mesh)

__all__ = ["MESH_FORMATS", "PLOT_FORMATS", "MeshFileError", "check_output", "check_outputs",
           "converted_cut", "input_roles", "load_pair", "merge_pieces", "read_mesh",
           "write_mesh", "write_results"]


def load_pair(sim, cut: str | os.PathLike, *, dtype="float64", sim_region=None,
              cut_region=None, scheduler=None) -> Arrays:
    """Read, convert and validate two mesh files; any problem raises an error that
    starts with the file's path (:class:`MeshFileError`). ``sim``: one file, or a list
    of files holding the pieces of one simulation mesh (:func:`merge_pieces`; pieces
    with global point ids, in a partitioned run on ``scheduler``, are read by its
    workers and their cells stay there: :mod:`~predicates.registration.partition.pieces`,
    validated by the plan on the workers)."""
    remote = _pieces_on_workers(sim, scheduler, sim_region)
    dim, s, sim_name = remote or _load_sim(sim, sim_region)
    cut_mesh = read_mesh(cut)
    try:
        if remote is None:
            validate_mesh(s.points, s.cells, "simulation", s.points.shape[1],
                          np.dtype(dtype), allow_empty=False)
    except (ValueError, TypeError) as e:
        raise MeshFileError(sim_name, e) from None
    c = converted_cut(cut, cut_mesh, dim, dtype, s.plane, cut_region)
    plane = s.plane if s.plane is not None else c.plane  # common_plane's
    notes = [f"{sim_name}: {n}" for n in s.notes] + [f"{cut}: {n}" for n in c.notes]
    return Arrays((s.points, s.cells, c.points, c.cells), notes, plane)


def converted_cut(path, mesh, dim: int, dtype, plane: float | None,
                  region=None) -> Converted:
    """A cutting mesh read from ``path`` (``mesh``: its :func:`read_mesh`) for a
    ``dim``-D simulation mesh in the plane z = ``plane`` (None: 3D or 2D points):
    converted (``region``: a gmsh physical group or cell block), validated and its
    plane checked (:func:`common_plane`); any problem raises :class:`MeshFileError`
    naming the file."""
    try:
        c = convert_cut(mesh, dim, region)
        validate_mesh(c.points, c.cells, "cutting", dim, np.dtype(dtype), allow_empty=True)
        common_plane(Converted(None, None, [], plane), c)
    except (ValueError, TypeError) as e:
        raise MeshFileError(path, e) from None
    return c


def input_roles(sim, cut, then=()) -> dict:
    """The input files by role ("SIM", or "SIM piece i" for the pieces of one mesh,
    "CUT", and "--then i" for further cuts), for :func:`check_outputs` (an output never
    overwrites an input)."""
    sims = [sim] if isinstance(sim, (str, os.PathLike)) else list(sim)
    names = ["SIM"] if len(sims) == 1 else [f"SIM piece {i + 1}" for i in range(len(sims))]
    later = {f"--then {i + 1}": p for i, p in enumerate(then)}
    return {**dict(zip(names, sims)), "CUT": cut, **later}


def _pieces_on_workers(sim, scheduler, region):
    """(dim, Converted, name) of several pieces with global point ids read by the
    workers of ``scheduler`` (a Client or a local Dask scheduler's name); None for one
    file, a serial run, or pieces without ids (read on the client, :func:`_load_sim`)."""
    paths = [sim] if isinstance(sim, (str, os.PathLike)) else list(sim)
    if scheduler is None or len(paths) < 2 or isinstance(scheduler, str) and \
            scheduler not in ("threads", "processes", "synchronous"):
        return None
    from predicates.registration.partition.pieces import NoGlobalIds, read_pieces_on_workers

    try:
        s = read_pieces_on_workers(paths, scheduler, region)
    except NoGlobalIds:
        return None
    return s.points.shape[1], s, f"{os.fspath(paths[0])} (+{len(paths) - 1} pieces)"


def _load_sim(sim, region):
    """(dim, Converted, name for messages) of the simulation mesh: one file, or the
    pieces of one mesh (each read and converted alike, then merged)."""
    if isinstance(sim, (str, os.PathLike)):
        sim = [sim]
    paths = list(sim)
    if not paths:
        raise ValueError("no simulation mesh file given")
    parts = []
    for path in paths:
        mesh = read_mesh(path)
        try:
            parts.append(convert_sim(mesh, region))
        except (ValueError, TypeError) as e:
            raise MeshFileError(path, e) from None
    if len(parts) == 1:
        return (*parts[0], os.fspath(paths[0]))
    name = f"{os.fspath(paths[0])} (+{len(paths) - 1} pieces)"
    (dim, first), rest = parts[0], parts[1:]
    for path, (d, c) in zip(paths[1:], rest):
        if d != dim or c.plane != first.plane:
            what = f"{d}D" if d != dim else f"in the plane z = {c.plane}"
            raise MeshFileError(path, f"this piece is {what}, the first piece "
                                      f"{os.fspath(paths[0])} is not: the pieces of one "
                                      f"simulation mesh share its dimension and plane")
    P, C, merged = merge_pieces([c.points for _, c in parts], [c.cells for _, c in parts])
    notes = [n for _, c in parts for n in c.notes]
    notes.append(f"{len(paths)} pieces read as one mesh ({len(P)} points; {merged} "
                 f"repeated points of shared piece boundaries merged)")
    return dim, Converted(P, C, notes, first.plane), name


def merge_pieces(points: list, cells: list) -> tuple[np.ndarray, np.ndarray, int]:
    """The pieces of one mesh as one (points, cells, number of points merged): the
    points concatenated, bit-identical coordinates merged (pieces share their boundary
    vertices) in order of first appearance, the cells renumbered."""
    off = np.cumsum([0] + [len(p) for p in points[:-1]])
    P = np.concatenate([np.asarray(p, dtype=np.float64) for p in points])
    C = np.concatenate([np.asarray(c, dtype=np.int64) + o for c, o in zip(cells, off)])
    uniq, first, inv = np.unique(P, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # ids in order of first appearance
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return uniq[order], rank[inv.ravel()][C], len(P) - len(uniq)


def write_results(res, *, output=None, plot=None, sim_output=None) -> None:
    """Write the intersection points (``output``), the simulation mesh with its cut-cell
    data (``sim_output``) and a 2D picture (``plot``), each atomically."""
    if output is not None:
        write_meshio(output, res.to_meshio())
    if sim_output is not None:
        write_meshio(sim_output, res.sim_mesh())
    if plot is not None:
        from predicates.registration.io.write import write_atomic
        from predicates.registration.pictures.plot import plot_2d

        write_atomic(plot, lambda tmp: plot_2d(res, tmp))
