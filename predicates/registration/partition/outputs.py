"""One file per partition, written by the workers (docs/partitioned.md 6): a run given
``partitions=PartFiles("hits_{part}.vtu")`` gives partition r every cell with a vertex
that file r's rule assigns to r (the owners of :func:`.files.vertex_owners` over every
simulation cell, the rule of :func:`.files.write_parts`), so the pairs task r owns are
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

from predicates.registration.partition.files import part_paths, vertex_owners

__all__ = ["FileSpec", "PartFiles", "Staged", "intersect_files_parts", "write_part"]


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


class Staged:
    """A run's k per-partition files: checked and their owners computed before any task
    (:meth:`__init__`), each written under a staged name beside its path by its task,
    then all renamed (:meth:`commit`) or all removed (:meth:`discard`)."""

    def __init__(self, files: PartFiles, k: int, plan, scheduler=None):
        from predicates.registration.io.write import check_outputs

        self.paths = part_paths(files.pattern, k)
        check_outputs(files.inputs, {**{(f"-o (partition {r})", "mesh"): p
                                        for r, p in enumerate(self.paths)}, **files.others})
        token = secrets.token_hex(6)
        self.staged = [_staged_name(p, token) for p in self.paths]
        sc = plan.scale
        self.spec = FileSpec(plan.dim, plan.dtype, plan.kinds, plan.tol, sc.e, plan.ts,
                             sc.L_a, sc.L_b, plan.refinement,
                             plan.arrays.plane if files.plane is None else files.plane)
        self.owner = vertex_owners(plan.sim.points, plan.sim.cells, k, scheduler)
        # the run's cells are the rows of the masks: a part's cells' indices among all
        self.write = (plan.sim.points, np.flatnonzero(sc.masks[0]))

    def commit(self, ran) -> None:
        """Write the files of the partitions that ran no task (no pairs: the legend
        only) and rename every staged file to its path."""
        ran = set(ran)
        for r, path in enumerate(self.staged):
            if r not in ran:
                write_part(path, self.spec, None, {})
        for tmp, path in zip(self.staged, self.paths):
            os.replace(tmp, path)

    def discard(self) -> None:
        """Remove every staged file (a failed or refused run writes nothing)."""
        for tmp in self.staged:
            with contextlib.suppress(OSError):
                os.remove(tmp)


def _staged_name(path: str, token: str) -> str:
    """A hidden name beside ``path`` with its extension (the format stays the one the
    name says)."""
    d, base = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(base)
    return os.path.join(d, f".{stem}.{token}.staged{ext}")


def write_part(path: str, spec: FileSpec, part, local: dict) -> int:
    """Write the pairs ``part`` owns (``local``: its run's pairs in local ids) as the
    file :func:`.files.write_parts` writes for its partition; ``part`` None: an empty
    file. Returns the file's bytes."""
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
    write_meshio(path, mesh)
    return os.path.getsize(path)


def _global(local: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Local indices (−1: none) as global ones (int64, −1 kept)."""
    ids = np.asarray(ids, dtype=np.int64)
    if len(ids) == 0:
        return local.astype(np.int64)
    return np.where(local >= 0, ids[np.maximum(local, 0)], -1).astype(np.int64)


def intersect_files_parts(sim, cut, pattern: str | os.PathLike, *,
                          partitions: int | str = "auto", scheduler="threads",
                          plot=None, sim_output=None, dtype: str = "float64",
                          naive: bool = False, sim_region=None, cut_region=None,
                          **options):
    """:func:`predicates.registration.intersect_files` with one file per partition
    (``pattern``: ``"hits_{part}.vtu"``), each written by its partition's task
    (:class:`PartFiles`); ``plot`` and ``sim_output`` written by the client as there.
    Every path is checked before any work, and nothing is written when the run is
    refused or fails. Returns the result (its pairs merged as always)."""
    from predicates.registration.io.files import input_roles, load_pair, write_results
    from predicates.registration.io.write import check_outputs
    from predicates.registration.pipeline import intersect

    roles = input_roles(sim, cut)
    others = {("--plot", "plot"): plot, ("--sim-output", "mesh"): sim_output}
    check_outputs(roles, {("-o", "mesh"): part_paths(pattern, 1)[0], **others})
    arrays = load_pair(sim, cut, dtype=dtype, sim_region=sim_region,
                       cut_region=cut_region, scheduler=scheduler)
    if plot is not None and arrays[0].shape[1] != 2:
        raise ValueError("plots are drawn for 2D meshes only (this case is 3D; open the "
                         "output in ParaView instead)")
    files = PartFiles(os.fspath(pattern), partitions, roles, others, arrays.plane)
    res = intersect(*arrays, dtype=np.dtype(dtype), tolerance_scale=0.0 if naive else 1.0,
                    partitions=files, scheduler=scheduler, **options)
    res.notes[:0] = arrays.notes
    res.plane = arrays.plane
    write_results(res, plot=plot, sim_output=sim_output)
    return res
