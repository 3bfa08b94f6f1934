"""Input of :func:`predicates.registration.intersect` (steps 1–2 of
:mod:`predicates.registration.pipeline`): the call's forms, validation, meshio meshes,
and the exact power-of-two scaling.

Everything a user can get wrong is rejected here with a ValueError or TypeError that
names the mesh, the array and the problem, before any work is done.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxgrid import colmax, colmin
from predicates.registration.spatial.broadphase import boxes_of
from predicates.registration.plan.scaling import (  # noqa: F401 (re-exported)
    _check_scaled, scale_points, times_pow2, times_pow2_quiet)

__all__ = ["Arrays", "MeshInput", "check_extent", "hull_of", "MeshTypeError", "from_meshio", "max_box_edge", "mesh_arrays",
           "renumbered", "run_vertices", "scale_points", "times_pow2", "cell_error", "first_bad", "validate_mesh", "validate_options", "validate_pair"]


@dataclass
class MeshInput:
    """A validated mesh: points (N, dim) in the working dtype, cells (M, k) of an
    integer dtype (the input's: never copied to int64)."""

    points: np.ndarray
    cells: np.ndarray
    role: str
    rounded: bool = False  # were the coordinates rounded into the working dtype?
    # the cells' BoxSummary when validation made it (tetrahedra); keyword-only: a
    # subclass's positional fields keep their places
    summary: object = field(default=None, kw_only=True)


class MeshTypeError(TypeError):
    """A mesh's points or cells of the wrong number type (strings, complex, float vertex
    ids): bad input, which the command line reports as such (exit 2), unlike a
    TypeError from inside the work, which is a bug."""


def _array(points, role):
    name = f"{role} points"
    try:
        arr = np.asarray(points)
    except Exception as e:  # ragged nested lists and the like
        raise ValueError(f"{name} cannot be read as an array: {e}") from None
    if arr.dtype.kind not in "fiu":
        raise MeshTypeError(f"{name} must be real numbers (float or int), got dtype "
                            f"{arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (N, 2) or (N, 3), got {arr.shape}")
    return arr


def _points(arr, used, role, dtype, finite: bool = False):
    """``arr`` in ``dtype``; only the ``used`` rows (referenced by a cell) are checked,
    the others are set to 0: an unreferenced vertex never matters. ``finite``: every
    value of ``arr`` is known finite (not tested again)."""
    name = f"{role} points"
    every = bool(used.all())  # the common case: no selection copies
    sel = arr if every else arr[used]
    if sel.dtype.kind == "f" and not finite and not np.isfinite(sel).all():
        bad = int(np.flatnonzero(used)[np.argwhere(~np.isfinite(sel))[0, 0]])
        raise ValueError(f"{name} contain NaN or infinity (point {bad}: {arr[bad]})")
    with np.errstate(all="ignore"):  # no copy when every point is used and in dtype
        out = arr.astype(dtype, copy=not every)
    if not every:
        out[~used] = 0
    if arr.dtype == out.dtype:  # a copy of finite values: finite, nothing rounded
        return out, False
    if not np.isfinite(out).all():
        raise ValueError(f"{name} overflow {np.dtype(dtype).name}: coordinates up to "
                         f"{np.abs(sel).max():.3g}")
    with np.errstate(all="ignore"):
        kept = out if every else out[used]
        rounded = bool(np.any(kept.astype(np.result_type(arr.dtype, out.dtype)) != sel))
    return out, rounded


def _cells(cells, role, width, n_points, what, blocks: Blocks = SERIAL, used=None,
           points=None, grid_for=None):
    """The cells as given when they are an integer array (no copy, the dtype kept; int64
    for an empty or non-array input), checked block by block: negative, out-of-range
    and repeated vertex ids are refused at their first cell, in that order. ``used``
    (n_points bools, compiled blocks): also marked with the vertices the cells use, in
    the same pass; returned as None when not marked. ``points`` (finite, C-ordered, in
    the working dtype; tetrahedra): the boxes' summary made in the same pass
    (:meth:`~predicates.registration.plan.cellboxes.CellBoxes.checked_summary`),
    returned third (else None); with the first round's flags at ``grid_for(cells)``'s
    grid when given (:mod:`~predicates.registration.plan.first_round`)."""
    name = f"{role} cells"
    try:
        arr = np.asarray(cells)
    except Exception as e:
        raise ValueError(f"{name} cannot be read as an array: {e}") from None
    if arr.size == 0:
        arr = arr.reshape(0, width).astype(np.int64)
    if arr.dtype.kind not in "iu":
        raise MeshTypeError(f"{name} must be integer vertex indices, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (M, {width}) ({what}), got {arr.shape}")
    summary = None
    if used is not None and blocks.accelerate and arr.dtype.kind == "i" and arr.size:
        if points is not None and width == 4:  # the ids read once for both
            from predicates.registration.plan.cellboxes import CellBoxes

            grid = None if grid_for is None else grid_for(len(arr))
            summary = CellBoxes(points, arr, blocks).checked_summary(used, grid)
        # a refused row (summary None) is found and named by the check alone
        found = [None] * 3 if summary is not None else \
            _checked_and_used(arr, n_points, blocks, used)
    else:
        found, used = first_bad(arr, width, n_points, blocks), None
    for t in range(3):  # the checks in this order, each at its first cell
        if found[t] is not None:
            raise cell_error(role, t, found[t], arr[found[t]].tolist(), n_points)
    return arr, used, summary


def _checked_and_used(arr: np.ndarray, n_points: int, blocks: Blocks, used) -> list:
    """:func:`first_bad` by the compiled pass (:func:`predicates.compiled.cellsums.
    check_cells`, the same rows), marking ``used`` as it reads the ids."""
    from predicates.compiled.cellsums import check_cells

    top = n_points if n_points <= np.iinfo(arr.dtype).max else -1

    def span(a: int, b: int) -> list:
        first = np.full(3, -1, dtype=np.int64)
        for lo, hi in blocks.each(a, b):
            got = np.full(3, -1, dtype=np.int64)
            check_cells(arr[lo:hi], top, got, used)  # used: only True written, any order
            first = np.where((first < 0) & (got >= 0), got + lo, first)
        return [int(f) if f >= 0 else None for f in first]

    found = blocks.map(span, len(arr))
    return [min((f[t] for f in found if f[t] is not None), default=None) for t in range(3)]


def first_bad(arr: np.ndarray, width: int, n_points: int,
              blocks: Blocks = SERIAL) -> list:
    """The first negative, out-of-range and repeating cell of the integer (M, width)
    array ``arr`` (row indices, None where there is none), block by block."""
    signed = arr.dtype.kind == "i"
    # the bound in the cells' own type (a bound beyond it: no id can reach it)
    top = n_points if n_points <= np.iinfo(arr.dtype).max else None

    def span(a: int, b: int) -> list:
        first = [None, None, None]
        for lo, hi in blocks.each(a, b):
            cols = [np.ascontiguousarray(arr[lo:hi, c]) for c in range(width)]
            bad = [np.zeros(hi - lo, dtype=bool) for _ in range(3)]
            for c in range(width):  # column by column: no reductions along short rows
                if signed:
                    bad[0] |= cols[c] < 0
                if top is not None:
                    bad[1] |= cols[c] >= top
                for d in range(c + 1, width):  # column pairs: ~6x faster than a row sort
                    bad[2] |= cols[c] == cols[d]
            for t in range(3):
                if first[t] is None and bad[t].any():
                    first[t] = lo + int(np.argmax(bad[t]))
        return first

    found = blocks.map(span, len(arr)) if arr.size else []
    return [min((f[t] for f in found if f[t] is not None), default=None) for t in range(3)]


def cell_error(role: str, t: int, i: int, row: list, n_points: int) -> ValueError:
    """The error of check ``t`` of :func:`first_bad` (0 negative, 1 out of range,
    2 repeated vertex) at cell ``i`` (its vertex ids ``row``)."""
    name = f"{role} cells"
    return ValueError((f"{name}: negative vertex index in cell {i}: {row}",
                       f"{name}: vertex index out of range in cell {i}: {row} (the mesh "
                       f"has {n_points} points)",
                       f"{name}: cell {i} repeats a vertex: {row}")[t])


def validate_mesh(points, cells, role, dim, dtype, allow_empty, blocks: Blocks = SERIAL,
                  summarize: bool = False, grid_for=None):
    """Check one mesh; returns a :class:`MeshInput` in the working ``dtype``;
    ``summarize``: with its boxes' summary when the cell check can make it in the same
    pass (:func:`_finite_as_given`; the plan's simulation mesh), and the first round's
    flags at ``grid_for(cell count)``'s grid (:func:`_cells`)."""
    arr = _array(points, role)
    if arr.shape[1] != dim:
        raise ValueError(f"mixed dimensions: the simulation mesh is {dim}D but the "
                         f"{role} points are {arr.shape[1]}D")
    k = dim + 1 if role == "simulation" else dim
    what = {(2, 3): "triangles", (2, 2): "segments", (3, 4): "tetrahedra",
            (3, 3): "triangles"}[dim, k]
    c, used, summary = _cells(cells, role, k, len(arr), f"{what} of a {dim}D {role} mesh",
                              blocks, np.zeros(len(arr), dtype=bool),
                              _finite_as_given(arr, dtype, blocks, k) if summarize else None,
                              grid_for)
    if len(c) == 0 and not allow_empty:
        raise ValueError(f"the {role} mesh is empty (0 cells)")
    if used is None:  # not marked by the compiled check
        used = _marked(c, len(arr))
    # (a summary was made only over finite points, _finite_as_given)
    pts, rounded = _points(arr, used, role, dtype, finite=summary is not None)
    return MeshInput(pts, c, role, rounded, summary=summary)


def _finite_as_given(arr: np.ndarray, dtype, blocks: Blocks, k: int):
    """3D points the boxes' summary can read during the cell check (docs/partitioned.md
    section 2): compiled, for tetrahedra, already in the working ``dtype`` (the points
    validation keeps, unchanged on every used row) and all finite (the summary's
    kernel assumes it; any other points are checked first, as before); else None."""
    if not (blocks.accelerate and k == 4 and arr.shape[1] == 3 and arr.dtype == dtype
            and arr.flags.c_contiguous and len(arr)):
        return None
    from predicates.compiled.tetsums import all_finite

    return arr if all_finite(arr) else None


def validate_pair(sim_points, sim_cells, cut_points, cut_cells, dtype,
                  blocks: Blocks = SERIAL, first_round=None):
    """Validate both meshes; the dimension is the simulation points' column count.
    ``blocks``: how the passes over the cells run (the same checks and messages).
    ``first_round(cut, n_sim)``: a grid for the first round's flags, made from the
    validated cutting mesh, which the simulation cells' sweep flags at (the cutting
    mesh is then checked first; its error, if any, still comes after the simulation
    mesh's)."""
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise TypeError(f"dtype must be float64 or float32, not {dtype}")
    sp = np.asarray(sim_points) if not isinstance(sim_points, np.ndarray) else sim_points
    if sp.ndim != 2 or sp.shape[-1] not in (2, 3):
        _array(sim_points, "simulation")  # raises the right error
    dim = sp.shape[1]
    cut = error = grid_for = None
    if first_round is not None:
        try:
            cut = validate_mesh(cut_points, cut_cells, "cutting", dim, dtype,
                                allow_empty=True, blocks=blocks)
            grid_for = (lambda n: first_round(cut, n))  # noqa: E731
        except Exception as e:  # raised after the simulation mesh's own checks
            error = e
    sim = validate_mesh(sim_points, sim_cells, "simulation", dim, dtype, allow_empty=False,
                        blocks=blocks, summarize=True, grid_for=grid_for)
    if error is not None:
        raise error
    if cut is None:
        cut = validate_mesh(cut_points, cut_cells, "cutting", dim, dtype, allow_empty=True,
                            blocks=blocks)
    return dim, sim, cut


def validate_options(dtype, tolerance_scale, progress, chunk) -> tuple:
    """(dtype, tolerance_scale) of :func:`~predicates.registration.intersect`, checked:
    every bad keyword argument is refused with a message naming it."""
    try:
        dt = np.dtype(dtype)
    except TypeError:
        raise TypeError(f"dtype must be float64 or float32, not {dtype!r}") from None
    if dt not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise TypeError(f"dtype must be float64 or float32, not {dt}")
    if isinstance(tolerance_scale, (bool, np.bool_)) or \
            not isinstance(tolerance_scale, (int, float, np.integer, np.floating)):
        raise TypeError(f"tolerance_scale must be a number in [0, 1], got "
                        f"{tolerance_scale!r}")
    ts = float(tolerance_scale)
    if not 0 <= ts <= 1:
        raise ValueError(f"tolerance_scale must be in [0, 1], got {tolerance_scale!r}")
    if not isinstance(progress, (bool, np.bool_)):
        raise TypeError(f"progress must be True or False, got {progress!r}")
    if isinstance(chunk, (bool, np.bool_)) or not isinstance(chunk, (int, np.integer)):
        raise TypeError(f"chunk must be a positive integer (pairs per batch), got {chunk!r}")
    if chunk < 1:
        raise ValueError(f"chunk must be a positive integer (pairs per batch), got {chunk}")
    return dt, ts


# -- the call's forms and the exact scaling ----------------------------------------------
class Arrays(tuple):
    """(sim_points, sim_cells, cut_points, cut_cells), with ``notes`` (what the
    conversion of mesh objects did) and ``plane`` (z of 2D meshes stored in z = c)."""

    notes: list
    plane: float | None

    def __new__(cls, arrays, notes=(), plane=None):
        self = super().__new__(cls, arrays)
        self.notes, self.plane = list(notes), plane
        return self


def from_meshio(sim, cut, sim_region=None, cut_region=None) -> Arrays:
    """(sim_points, sim_cells, cut_points, cut_cells) from two mesh objects
    (``meshio.Mesh``, pyvista, trimesh; see :mod:`predicates.registration.io.convert`).

    The simulation mesh decides the dimension: tetrahedra make it 3D (the cutting mesh
    then contributes its triangles), triangles make it 2D (the cutting mesh's lines).
    """
    from predicates.registration.io.convert import convert_pair

    s, c = convert_pair(sim, cut, sim_region, cut_region)
    return Arrays((s.points, s.cells, c.points, c.cells), s.notes + c.notes, s.plane)


def mesh_arrays(args: tuple, sim_region=None, cut_region=None) -> Arrays:
    """(sim_points, sim_cells, cut_points, cut_cells) from the positional arguments of
    :func:`~predicates.registration.intersect`: four arrays, two mesh objects
    (``meshio.Mesh``, pyvista ``UnstructuredGrid``/``PolyData``, trimesh ``Trimesh``) or
    two ``(points, cells)`` tuples. ``sim_region``/``cut_region`` select a gmsh physical
    group or cell block of a mesh object (tag, name or block index)."""
    if len(args) == 4:
        _no_region(sim_region, cut_region)
        return _in_a_plane(*args)
    if len(args) != 2:
        raise TypeError("intersect(sim_points, sim_cells, cut_points, cut_cells) or "
                        f"intersect(sim_mesh, cut_mesh); got {len(args)} positional arguments")
    tuples = [isinstance(m, (tuple, list)) for m in args]
    for role, m, t in zip(("simulation", "cutting"), args, tuples):
        if t and len(m) != 2:
            raise TypeError(f"the {role} mesh as a tuple must be (points, cells), got "
                            f"{len(m)} items")
    if all(tuples):
        _no_region(sim_region, cut_region)
        return _in_a_plane(*args[0], *args[1])
    if any(tuples):
        raise TypeError("pass both meshes as mesh objects or both as (points, cells)")
    return from_meshio(args[0], args[1], sim_region, cut_region)


def _in_a_plane(sp, sc, cp, cc) -> Arrays:
    """Arrays as given, except 2D meshes (triangles and segments) whose points have three
    coordinates: registered in 2D in their common plane z = c, as mesh objects are
    (:func:`~predicates.registration.io.convert.plane_of`, one rule for both)."""
    shapes = [np.shape(a) for a in (sp, sc, cp, cc)]
    if not (all(len(s) == 2 for s in shapes) and shapes[0][1] == 3 and shapes[1][1] == 3
            and shapes[3][1] == 2):
        return Arrays((sp, sc, cp, cc))
    from predicates.registration.io.convert import Converted, common_plane, plane_of

    ps, zs = plane_of(np.asarray(sp), "simulation")
    pc, zc = plane_of(np.asarray(cp), "cutting")
    s, c = Converted(ps, np.asarray(sc), [], zs), Converted(pc, np.asarray(cc), [], zc)
    plane = common_plane(s, c)
    return Arrays((s.points, sc, c.points, cc),
                  [f"2D meshes given with 3 coordinates: registered in their plane z = {plane:g}"],
                  plane)


def _no_region(*regions):
    if any(r is not None for r in regions):
        raise TypeError("sim_region/cut_region select a region of a mesh object (meshio, "
                        "pyvista); with arrays, pass the cells of the region instead")


def max_box_edge(points: np.ndarray, cells: np.ndarray) -> float:
    """Largest bounding-box edge of any cell, in binary64, rounded up one ulp (an upper
    bound of the exact value: hi − lo is correctly rounded)."""
    if len(cells) == 0:
        return 0.0
    lo, hi = boxes_of(points, cells)  # no (n, k, d) gather: ~3x faster, 1/k the memory
    d = (hi - lo).max()
    return float(np.nextafter(d, np.inf)) if d > 0 else 0.0


def run_vertices(cells: np.ndarray, n_points: int) -> np.ndarray:
    """The vertex ids ``cells`` use, ascending (a mask of the points: no sort of the
    ids)."""
    return np.flatnonzero(_marked(cells, n_points))


def _marked(cells: np.ndarray, n_points: int) -> np.ndarray:
    """The mask of the ``n_points`` points the (checked) ``cells`` use: one scatter per
    block of 2^16 rows read as laid out (a strided column's scatter cost 3× on W4's
    10 M tetrahedra: 330 vs 110 ms), no copy of the cells beyond a block."""
    used = np.zeros(n_points, dtype=bool)
    for a in range(0, len(cells), 1 << 16):
        used[cells[a:a + (1 << 16)].reshape(-1)] = True
    return used


def renumbered(cells: np.ndarray, vertices: np.ndarray, fast: bool = False) -> np.ndarray:
    """``cells`` in the positions of their ids in ``vertices`` (ascending, holding every id
    of the cells): monotone, so every comparison of vertex ids (orders, tie-breaks) is
    unchanged; ``fast``: searched by buckets (:mod:`predicates.compiled.renumber`)."""
    if fast and len(vertices) and cells.dtype.kind == "i" and vertices.dtype == np.int64:
        from predicates.compiled.renumber import searched
        return searched(vertices, cells)
    out = np.searchsorted(vertices, cells)
    return out.astype(np.int32) if len(vertices) < 2 ** 31 else out


def check_extent(name: str, mesh: MeshInput, given, dtype, hull=None) -> None:
    """Refuse a mesh whose cells' vertices are all one point in the working dtype
    (ValueError saying why and what to do); ``given``: its points as the caller gave
    them; ``hull``: (lo_min, hi_max) of its cells' boxes if known."""
    if len(mesh.cells) and _one_point(mesh, hull):
        raise ValueError(_collapse_reason(name, given, mesh, dtype))


def hull_of(lo: np.ndarray, hi: np.ndarray):
    """(lo_min, hi_max) of boxes (n, d) for :func:`check_extent` (None when n = 0)."""
    return (colmin(lo), colmax(hi)) if len(lo) else None


def _one_point(mesh, hull=None) -> bool:
    """Every vertex of the mesh's cells is the same point (in the working dtype): the
    hull of the cells' boxes (``hull`` = (lo_min, hi_max), or computed) is one point —
    it is the hull of the vertices the cells use; exact, no sort of the cells' ids."""
    hull = hull_of(*boxes_of(mesh.points, mesh.cells)) if hull is None else hull
    return bool(np.array_equal(*hull))


def _collapse_reason(name: str, given, mesh, dtype) -> str:
    """Why every vertex of a mesh is one point, and what to do: the input's vertices are
    one point, or they differ by less than the working format's spacing at their
    magnitude (a large offset), or they underflow in float32."""
    used = np.unique(np.asarray(mesh.cells))
    G = np.asarray(given, dtype=np.float64)[used] if np.asarray(given).dtype.kind == "f" \
        else np.asarray(given)[used].astype(np.float64)
    mag = float(np.abs(G).max())
    head = f"every vertex of the {name} mesh is the same point"
    if (G == G[0]).all():
        far = "" if mag < 2.0 ** 20 else (
            f"; at magnitude {mag:.3g} float64 numbers are {float(np.spacing(mag)):.3g} "
            "apart: a mesh translated this far from the origin collapses, translate it back")
        return f"{head} ({', '.join(f'{x:.6g}' for x in G[0])}): a mesh needs extent{far}"
    if dtype == np.float32 and mag < float(np.finfo(np.float32).tiny) * 2 ** 23:
        return (f"{head} in float32: its coordinates (magnitude {mag:.3g}) underflow to "
                "zero or subnormals; use float64 (--dtype float64) or scale the meshes")
    ext = float((G.max(axis=0) - G.min(axis=0)).max())
    return (f"{head} in {dtype.name}: its coordinates span {ext:.3g} at magnitude {mag:.3g}, "
            f"less than {dtype.name}'s spacing there ({float(np.spacing(dtype.type(mag))):.3g}); "
            "translate the meshes near the origin before registering")
