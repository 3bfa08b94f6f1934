"""One file per partition, written by the workers (docs/partitioned.md 6): a run given
``partitions=PartFiles("hits_{part}.vtu")`` gives partition r every cell with a vertex
that file r's rule assigns to r (the owners of :func:`.files.vertex_owners` over every
simulation cell, the rule of :func:`.files.write_parts`; :func:`.files.owners_of` for
the run's vertices), so the pairs task r owns are
exactly file r's; the task writes its file from them where it runs, under a staged
name, and the client renames the k files once every partition has succeeded (removes
them otherwise). The files are byte for byte those :func:`.files.write_parts` writes
from the merged result; the client computes neither their cells (``sim_cell``: the
lowest cell holding each pair's primitive, found among the task's cells — every cell
holding a registered primitive can meet the cut, so it is a run cell, and it contains
the pair's owned vertex) nor their points, nor writes them."""
from __future__ import annotations

import contextlib
import os
import secrets
from dataclasses import dataclass, field

import numpy as np

from predicates.registration.partition.files import owners_of, part_paths

__all__ = ["FileSpec", "PartFiles", "Staged", "write_part"]


@dataclass(frozen=True)
class PartFiles:
    """``partitions=`` of :func:`predicates.intersect` for a run that writes one file
    per partition on the workers: ``pattern`` with ``{part}`` (``"hits_{part}.vtu"``),
    ``partitions`` the count (an int or "auto"); ``inputs`` ({"SIM": path, ...}) and
    ``others`` ({(option, "mesh"|"plot"): path}) are checked against the k paths before
    any task (never overwrite an input, no two outputs the same file); ``plane``: z of a
    2D mesh's points in the files (None: the run's own)."""

    pattern: str
    partitions: int | str = "auto"
    inputs: dict = field(default_factory=dict)
    others: dict = field(default_factory=dict)
    plane: float | None = None


@dataclass(frozen=True)
class FileSpec:
    """What every partition's writer needs besides its Part: the run's kinds, dtype,
    tolerances, exponent, L, the cutting mesh's refinement (the files map cutting
    points back to the mesh as given) and the plane."""

    dim: int
    dtype: np.dtype
    kinds: tuple
    tol: object
    e: int
    ts: float
    L_a: float
    L_b: float
    refinement: object
    plane: float | None
    live: str  # the run's marker: a task keeps its file only while it exists


class Staged:
    """A run's k per-partition files: checked and their owners computed before any task
    (:meth:`__init__`), each written under a staged name beside its path by its task,
    then all renamed (:meth:`commit`) or all removed (:meth:`discard`).

    A task cannot be stopped once it runs (a timeout cancels only the others), so one
    may write its file after the run was abandoned: the run's hidden marker file
    (``spec.live``) is removed *before* the staged files, and a task removes its file
    when the marker is gone after writing it — whichever comes last removes the file.
    The client and the workers must therefore see the same directory (always so on
    one machine; a cluster of several hosts needs a shared filesystem for ``-o``)."""

    def __init__(self, files: PartFiles, k: int, plan, scheduler=None):
        from predicates.registration.io.write import check_outputs

        self.paths = part_paths(files.pattern, k)
        check_outputs(files.inputs, {**{(f"-o (partition {r})", "mesh"): p
                                        for r, p in enumerate(self.paths)}, **files.others})
        token = secrets.token_hex(6)
        self.staged = [_staged_name(p, token, "staged") for p in self.paths]
        live = _staged_name(self.paths[0], token, "live")
        sc = plan.scale
        self.spec = FileSpec(plan.dim, plan.dtype, plan.kinds, plan.tol, sc.e, plan.ts,
                             sc.L_a, sc.L_b, plan.refinement,
                             plan.arrays.plane if files.plane is None else files.plane,
                             live)
        run_vertices = np.zeros(len(plan.sim.points), dtype=bool)
        # the only owners the split reads (the plan's run vertices when it kept only
        # those, else the vertices of its run cells)
        run_vertices[plan.sim_cells.ravel() if plan.sim_vertex_ids is None
                     else plan.sim_vertex_ids] = True
        self.owner = owners_of(plan.sim.points, plan.sim.cells, k, run_vertices, scheduler)
        # the run's cells are the rows of the masks: a part's cells' indices among all
        self.write = (plan.sim.points, np.flatnonzero(sc.masks[0]))
        open(live, "x").close()  # last: a refusal above leaves nothing

    def commit(self, ran) -> None:
        """Write the files of the partitions that ran no task (no pairs: the legend
        only) and rename every staged file to its path."""
        ran = set(ran)
        for r, path in enumerate(self.staged):
            if r not in ran:
                write_part(path, self.spec, None, {})
        for tmp, path in zip(self.staged, self.paths):
            os.replace(tmp, path)
        os.remove(self.spec.live)

    def discard(self) -> None:
        """Remove the marker, then every staged file (a failed or refused run writes
        nothing; a task still running removes its own: the class's note)."""
        for tmp in (self.spec.live, *self.staged):
            with contextlib.suppress(OSError):
                os.remove(tmp)


def _staged_name(path: str, token: str, what: str) -> str:
    """A hidden name beside ``path`` with its extension (the format stays the one the
    name says)."""
    d, base = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(base)
    return os.path.join(d, f".{stem}.{token}.{what}{ext}")


def write_part(path: str, spec: FileSpec, part, local: dict) -> int:
    """Write the pairs ``part`` owns (``local``: its run's pairs in local ids) as the
    file :func:`.files.write_parts` writes for its partition; ``part`` None: an empty
    file. Returns the file's bytes (0: the run was abandoned, nothing written)."""
    from predicates.registration.io.write import write_meshio
    from predicates.registration.result.intersection import IntersectionResult
    from predicates.registration.result.pairs import KindPairs
    from predicates.registration.spatial.boxgrid import rowwise

    dim = spec.dim
    pairs = {}
    for kind in spec.kinds:
        p = local.get(kind.name)
        if p is None or not len(p):
            pairs[kind.name] = KindPairs(
                kind.name, np.zeros((0, kind.i + 1), np.int64),
                np.zeros((0, kind.j + 1), np.int64), np.zeros((0, kind.i + 1), spec.dtype),
                np.zeros((0, kind.j + 1), spec.dtype))
            continue
        keep = part.own_vertex[rowwise(np.minimum, p.sim)]
        # cutting ids global (the refinement's map takes them); simulation ids local
        # until the mesh is built: its points and cells are the part's
        pairs[kind.name] = KindPairs(kind.name, p.sim[keep],
                                     part.cut_ids[p.cut[keep]].astype(np.int64),
                                     p.sim_weights[keep], p.cut_weights[keep])
    if part is None:
        coords, cells = np.zeros((0, dim)), np.zeros((0, dim + 1), np.int64)
        ids, cell_ids = np.zeros(0, np.int64), np.zeros(0, np.int64)
    else:
        coords, cells, ids, cell_ids = (part.sim_coords, part.sim_cells, part.sim_ids,
                                        part.cell_ids)
    res = IntersectionResult(
        dim=dim, dtype=spec.dtype, kinds=tuple(k.name for k in spec.kinds), pairs=pairs,
        tolerances=spec.tol, scale_exponent=spec.e, tolerance_scale=spec.ts,
        L_a=spec.L_a, L_b=spec.L_b, sim_points=coords, sim_cells=cells,
        cut_points=np.zeros((0, dim)), cut_cells=np.zeros((0, dim), np.int64),
        refinement=spec.refinement, plane=spec.plane)
    mesh = res.to_meshio()
    data = mesh.point_data
    data["sim_ids"] = _global(data["sim_ids"], ids)
    data["sim_cell"] = _global(data["sim_cell"], cell_ids)
    if not os.path.exists(spec.live):
        return 0
    write_meshio(path, mesh)
    size = os.path.getsize(path)
    if not os.path.exists(spec.live):  # abandoned while writing (Staged's note)
        with contextlib.suppress(OSError):
            os.remove(path)
        return 0
    return size


def _global(local: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Local indices (−1: none) as global ones (int64, −1 kept)."""
    ids = np.asarray(ids, dtype=np.int64)
    if len(ids) == 0:
        return local.astype(np.int64)
    return np.where(local >= 0, ids[np.maximum(local, 0)], -1).astype(np.int64)
