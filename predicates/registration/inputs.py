"""Input of :func:`predicates.registration.intersect` (steps 1–2 of
:mod:`predicates.registration.pipeline`): the call's forms, validation, meshio meshes,
and the exact power-of-two scaling.

Everything a user can get wrong is rejected here with a ValueError or TypeError that
names the mesh, the array and the problem, before any work is done.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .broadphase import boxes_of

__all__ = ["MeshInput", "from_meshio", "max_box_edge", "mesh_arrays", "scale_points",
           "validate_mesh", "validate_pair"]


@dataclass
class MeshInput:
    """A validated mesh: points (N, dim) in the working dtype, cells (M, k) int64."""

    points: np.ndarray
    cells: np.ndarray
    role: str
    rounded: bool = False  # were the coordinates rounded into the working dtype?


def _points(points, role, dtype):
    name = f"{role} points"
    try:
        arr = np.asarray(points)
    except Exception as e:  # ragged nested lists and the like
        raise ValueError(f"{name} cannot be read as an array: {e}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be real numbers (float or int), got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (N, 2) or (N, 3), got {arr.shape}")
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} contain NaN or infinity (point {bad[0]}: {arr[bad[0]]})")
    with np.errstate(all="ignore"):
        out = arr.astype(dtype)
    if not np.isfinite(out).all():
        raise ValueError(f"{name} overflow {np.dtype(dtype).name}: coordinates up to "
                         f"{np.abs(arr).max():.3g}")
    with np.errstate(all="ignore"):
        rounded = bool(np.any(out.astype(np.result_type(arr.dtype, out.dtype)) != arr))
    return out, rounded


def _cells(cells, role, width, n_points, what):
    name = f"{role} cells"
    try:
        arr = np.asarray(cells)
    except Exception as e:
        raise ValueError(f"{name} cannot be read as an array: {e}") from None
    if arr.size == 0:
        arr = arr.reshape(0, width).astype(np.int64)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integer vertex indices, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (M, {width}) ({what}), got {arr.shape}")
    if arr.size:
        if arr.dtype.kind == "i" and arr.min() < 0:
            i = int(np.argwhere(arr < 0)[0, 0])
            raise ValueError(f"{name}: negative vertex index in cell {i}: {arr[i].tolist()}")
        if arr.max() >= n_points:
            i = int(np.argwhere(arr >= n_points)[0, 0])
            raise ValueError(f"{name}: vertex index out of range in cell {i}: "
                             f"{arr[i].tolist()} (the mesh has {n_points} points)")
    arr = arr.astype(np.int64)
    s = np.sort(arr, axis=1)
    rep = np.any(s[:, 1:] == s[:, :-1], axis=1)
    if rep.any():
        i = int(np.argmax(rep))
        raise ValueError(f"{name}: cell {i} repeats a vertex: {arr[i].tolist()}")
    return arr


def validate_mesh(points, cells, role, dim, dtype, allow_empty):
    """Check one mesh; returns a :class:`MeshInput` in the working ``dtype``."""
    pts, rounded = _points(points, role, dtype)
    if pts.shape[1] != dim:
        raise ValueError(f"mixed dimensions: the simulation mesh is {dim}D but the "
                         f"{role} points are {pts.shape[1]}D")
    k = dim + 1 if role == "simulation" else dim
    what = {(2, 3): "triangles", (2, 2): "segments", (3, 4): "tetrahedra",
            (3, 3): "triangles"}[dim, k]
    c = _cells(cells, role, k, len(pts), f"{what} of a {dim}D {role} mesh")
    if len(c) == 0 and not allow_empty:
        raise ValueError(f"the {role} mesh is empty (0 cells)")
    return MeshInput(pts, c, role, rounded)


def validate_pair(sim_points, sim_cells, cut_points, cut_cells, dtype):
    """Validate both meshes; the dimension is the simulation points' column count."""
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise TypeError(f"dtype must be float64 or float32, not {dtype}")
    sp = np.asarray(sim_points) if not isinstance(sim_points, np.ndarray) else sim_points
    if sp.ndim != 2 or sp.shape[-1] not in (2, 3):
        _points(sim_points, "simulation", dtype)  # raises the right error
    dim = sp.shape[1]
    sim = validate_mesh(sim_points, sim_cells, "simulation", dim, dtype, allow_empty=False)
    cut = validate_mesh(cut_points, cut_cells, "cutting", dim, dtype, allow_empty=True)
    return dim, sim, cut


# -- meshio -----------------------------------------------------------------------------
def _blocks(mesh, cell_type):
    out = [np.asarray(b.data) for b in mesh.cells if b.type == cell_type]
    return np.concatenate(out) if out else None


def _planar(points, role):
    """Drop a constant z column of a 2D mesh stored with 3D points (meshio's habit)."""
    pts = np.asarray(points)
    if pts.ndim == 2 and pts.shape[1] == 3:
        z = pts[:, 2]
        if len(z) and not np.all(z == z[0]):
            raise ValueError(f"the {role} mesh has 2D cells but its points are not in "
                             "one plane z = const (mixed dimensions)")
        return pts[:, :2], (float(z[0]) if len(z) else 0.0)
    return pts, None


def from_meshio(sim, cut):
    """(sim_points, sim_cells, cut_points, cut_cells) from two ``meshio.Mesh``.

    The simulation mesh decides the dimension: tetrahedra make it 3D (the cutting mesh
    then contributes its triangles), triangles make it 2D (the cutting mesh's lines).
    Other cell blocks (boundary facets, vertices) are ignored.
    """
    sim_tets = _blocks(sim, "tetra")
    if sim_tets is not None:
        cut_tris = _blocks(cut, "triangle")
        if cut_tris is None:
            kinds = sorted({b.type for b in cut.cells}) or ["none"]
            raise ValueError("mixed dimensions: the simulation mesh has tetrahedra (3D) "
                             "but the cutting mesh has no triangles (cell types: "
                             f"{', '.join(kinds)})")
        sp, cp = np.asarray(sim.points), np.asarray(cut.points)
        for role, p in (("simulation", sp), ("cutting", cp)):
            if p.ndim != 2 or p.shape[1] != 3:
                raise ValueError(f"mixed dimensions: 3D meshes need 3D points; the {role} "
                                 f"mesh's points have shape {p.shape}")
        return sp, sim_tets, cp, cut_tris
    sim_tris = _blocks(sim, "triangle")
    if sim_tris is None:
        kinds = sorted({b.type for b in sim.cells}) or ["none"]
        raise ValueError("the simulation mesh has neither tetrahedra nor triangles (cell "
                         f"types: {', '.join(kinds)}); triangulate it first")
    cut_lines = _blocks(cut, "line")
    if cut_lines is None:
        kinds = sorted({b.type for b in cut.cells}) or ["none"]
        raise ValueError("mixed dimensions: the simulation mesh has triangles (2D) but the "
                         f"cutting mesh has no line segments (cell types: {', '.join(kinds)})")
    sp, zs = _planar(sim.points, "simulation")
    cp, zc = _planar(cut.points, "cutting")
    if zs is not None and zc is not None and zs != zc and len(cut_lines):
        raise ValueError(f"the 2D meshes lie in different planes (z = {zs} and z = {zc})")
    return sp, sim_tris, cp, cut_lines


# -- the call's forms and the exact scaling ----------------------------------------------
def mesh_arrays(args: tuple) -> tuple:
    """(sim_points, sim_cells, cut_points, cut_cells) from the positional arguments of
    :func:`~predicates.registration.intersect`: four arrays, two ``meshio.Mesh`` or two
    ``(points, cells)`` tuples."""
    if len(args) == 4:
        return args
    if len(args) == 2:
        out = []
        for role, m in zip(("simulation", "cutting"), args):
            if hasattr(m, "points") and hasattr(m, "cells"):
                out.append(m)
            elif isinstance(m, (tuple, list)) and len(m) == 2:
                out.append(tuple(m))
            else:
                raise TypeError(f"the {role} mesh must be a meshio.Mesh or a (points, cells) "
                                f"tuple, got {type(m).__name__}")
        sim, cut = out
        if isinstance(sim, tuple) and isinstance(cut, tuple):
            return (*sim, *cut)
        if isinstance(sim, tuple) or isinstance(cut, tuple):
            raise TypeError("pass both meshes as meshio.Mesh or both as (points, cells)")
        return from_meshio(sim, cut)
    raise TypeError("intersect(sim_points, sim_cells, cut_points, cut_cells) or "
                    f"intersect(sim_mesh, cut_mesh); got {len(args)} positional arguments")


def max_box_edge(points: np.ndarray, cells: np.ndarray) -> float:
    """Largest bounding-box edge of any cell, in binary64, rounded up one ulp (an upper
    bound of the exact value: hi − lo is correctly rounded)."""
    if len(cells) == 0:
        return 0.0
    lo, hi = boxes_of(points, cells)  # no (n, k, d) gather: ~3x faster, 1/k the memory
    d = (hi - lo).max()
    return float(np.nextafter(d, np.inf)) if d > 0 else 0.0


def scale_points(points: np.ndarray, e: int, role: str) -> np.ndarray:
    """``points``·2^-e, refused unless exact (no overflow, no bit lost to underflow)."""
    with np.errstate(all="ignore"):
        out = np.ldexp(points, -e)
        back = np.ldexp(out, e)
    limit = np.finfo(points.dtype).max / 16
    if not (np.isfinite(out).all() and np.all(np.abs(out) <= limit)):
        raise ValueError(f"the {role} coordinates are too large relative to the cells' size "
                         f"(scaling the cells to unit size by 2^{-e} overflows "
                         f"{points.dtype.name}): translate the meshes closer to the origin")
    if not np.array_equal(back, points):
        raise ValueError(f"the {role} coordinates cannot be scaled exactly by 2^{-e} (to "
                         f"unit-size cells): some are so small relative to the cells that "
                         f"they underflow {points.dtype.name}; round them to zero first")
    return out
