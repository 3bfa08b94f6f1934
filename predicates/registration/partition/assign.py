"""Spatial partitions of a registration (section 1 of the paper, run in pieces): which
simulation cells, cutting cells and vertices each partition receives, which pairs it
owns, and how the owned pairs merge back into the serial result. Pure numpy; the Dask
execution is :mod:`predicates.registration.partition.run`, the argument that the merged
result is the serial one is docs/partitioned.md.

* cells are ordered by the Morton code of their centroids and cut into ``k`` contiguous
  runs of (nearly) equal size: partition r *owns* run r;
* a vertex is owned by the partition owning the smallest-index cell that contains it;
* partition r receives its cells plus a halo (every cell sharing a vertex with them),
  and every cutting cell whose box, enlarged by the largest reach, shares a grid cell
  with the box of one of those cells (:mod:`.partition_slices`);
* a registered pair belongs to the partition owning the smallest-id vertex of its
  simulation primitive: every cell containing that primitive shares that vertex with an
  owned cell, so the owner holds the primitive, all its faces and every cutting
  primitive within reach — every sub-pair its suppression looks at.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxgrid import colmax, colmin, rowwise
from predicates.registration.spatial.broadphase import boxes_of
from predicates.registration.partition.slices import cut_near, halos, owner_halos, wide
from predicates.registration.result.intersection import KindPairs

__all__ = ["CutSide", "Layout", "Part", "assign", "cut_slice", "merge", "morton_order",
           "owned", "split"]


@dataclass
class Part:
    """What one partition receives: its slice of both meshes in local ids.

    ``sim_ids`` / ``cut_ids``: the global vertex ids of the local vertices (int32 below
    2^31 vertices), increasing
    (local order = global order, so ties in the lexicographic vertex order break the
    same way as in the serial run); ``own_vertex``: per local simulation vertex, owned
    by this partition. ``sim_coords`` / ``cell_ids``: for a run that writes one file
    per partition on the workers (:mod:`.outputs`), the local vertices' coordinates as
    given (not scaled) and each local cell's index among all simulation cells."""

    index: int
    P_sim: np.ndarray
    sim_cells: np.ndarray
    sim_ids: np.ndarray
    own_vertex: np.ndarray
    P_cut: np.ndarray
    cut_cells: np.ndarray
    cut_ids: np.ndarray
    owned_cells: int
    sim_coords: np.ndarray | None = None
    cell_ids: np.ndarray | None = None
    cut_pending: bool = False  # its cutting slice is cut in the task (:func:`cut_slice`)

    @property
    def nbytes(self) -> int:
        """Bytes of array data sent to the worker."""
        return sum(a.nbytes for a in (self.P_sim, self.sim_cells, self.sim_ids,
                                      self.own_vertex, self.P_cut, self.cut_cells,
                                      self.cut_ids, self.sim_coords, self.cell_ids)
                   if a is not None)


def _spread(v: np.ndarray, dim: int) -> np.ndarray:
    """Bits of v (uint64, < 2^21 in 3D, < 2^31 in 2D) spaced ``dim`` apart."""
    v = v.astype(np.uint64)
    if dim == 2:
        masks = [(16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF), (4, 0x0F0F0F0F0F0F0F0F),
                 (2, 0x3333333333333333), (1, 0x5555555555555555)]
    else:
        masks = [(32, 0x1F00000000FFFF), (16, 0x1F0000FF0000FF), (8, 0x100F00F00F00F00F),
                 (4, 0x10C30C30C30C30C3), (2, 0x1249249249249249)]
    for shift, m in masks:
        v = (v | (v << np.uint64(shift))) & np.uint64(m)
    return v


def morton_order(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Position of every cell in the Morton order of its first vertex (a point of the
    cell; cheaper than the centroid and as good for compact runs)."""
    c = first_vertices(points, cells)
    return order_of(morton_codes(c, c.min(axis=1)[:, None], c.max(axis=1)[:, None]))


def first_vertices(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The cells' first vertices' coordinates, one contiguous row per axis (numpy's
    min/max over axis 0 of an (m, 3) array is ~90× slower than over contiguous rows)."""
    return np.ascontiguousarray(points[cells[:, 0]].astype(np.float64).T)


def morton_codes(c: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The Morton codes of the points ``c`` (one row per axis) in the box [lo, hi] of
    all cells' first vertices: element-wise, so any block of cells gets its codes."""
    dim = len(c)
    bits = 21 if dim == 3 else 31
    span = np.where(hi > lo, hi - lo, 1.0)
    q = np.clip(((c - lo) / span * (2 ** bits - 1)), 0, 2 ** bits - 1).astype(np.uint64)
    code = np.zeros(c.shape[1], dtype=np.uint64)
    for ax in range(dim):
        code |= _spread(q[ax], dim) << np.uint64(ax)
    return code


def order_of(code: np.ndarray) -> np.ndarray:
    """Each cell's position in the stable order of ``code``."""
    m = len(code)
    order = np.argsort(code, kind="stable")
    pos = np.empty(m, dtype=np.int64)
    pos[order] = np.arange(m, dtype=np.int64)
    return pos


def _local(P, cells, keep):
    """The rows ``keep`` of ``cells`` renumbered to their vertices (global ids
    increasing) and those vertices' coordinates."""
    sub = np.take(cells, keep, axis=0)  # (take: the rows of fancy indexing, faster)
    used = np.zeros(len(P), dtype=bool)
    used[sub.ravel()] = True
    ids = np.flatnonzero(used)
    # int32 local ids when they fit: fewer bytes to send (the worker widens them)
    loc = np.zeros(len(P), dtype=np.int32 if len(ids) < 2 ** 31 else np.int64)
    loc[ids] = np.arange(len(ids))
    # int32 global ids too: the owned pairs go back in them (a quarter fewer bytes
    # returned; the merge's concatenation with int64 widens them, same values)
    return (np.take(P, ids, axis=0), np.take(loc, sub),
            ids.astype(np.int32) if len(P) <= 2 ** 31 else ids)


def _global(vertex_ids: np.ndarray, sid: np.ndarray) -> np.ndarray:
    """The global ids of a part's rows ``sid`` of the plan's run vertices, int32 when
    they fit (as :func:`_local`'s)."""
    gid = vertex_ids[sid]
    return gid.astype(np.int32) if len(vertex_ids) == 0 or vertex_ids[-1] < 2 ** 31 \
        else gid


def assign(P_sim: np.ndarray, sim_cells: np.ndarray, k: int):
    """(position of every cell in Morton order, owner partition of every vertex): cell
    c is owned by partition pos[c]·k // m; a vertex by the partition owning the
    smallest-index cell that contains it (−1: in no cell)."""
    n = len(P_sim)
    pos = morton_order(P_sim, sim_cells)
    return pos, owners_from(pos, first_cells(sim_cells, n), k)


def first_cells(cells: np.ndarray, n: int, offset: int = 0, none: int | None = None):
    """Per vertex of n, the smallest index (``offset`` + row) of the cells containing
    it, ``none`` (default: offset + the rows) where none does."""
    m = len(cells)
    first = np.full(n, offset + m if none is None else none, dtype=np.int64)
    np.minimum.at(first, cells.ravel(),
                  np.repeat(np.arange(offset, offset + m, dtype=np.int64), cells.shape[1]))
    return first


def owners_from(pos: np.ndarray, first: np.ndarray, k: int) -> np.ndarray:
    """Each vertex's owner partition of k: the partition owning its first cell (−1: in
    no cell), from the cells' Morton positions ``pos``."""
    m = len(pos)
    return np.where(first < m, pos[np.minimum(first, m - 1)] * k // m, -1)


class CutSide:
    """The run's cutting mesh (scaled points, cells) and the pad, sent once to each
    worker: each task cuts its own slice from it (:func:`cut_slice`) instead of the
    client cutting every partition's (docs/partitioned.md 3). The boxes are computed
    where they are first needed and kept with the object (a worker's tasks share it)."""

    def __init__(self, P_cut: np.ndarray, cut_cells: np.ndarray, pad: float):
        if len(P_cut) < 2 ** 31:  # int32 ids: half the bytes sent (the slices the same)
            cut_cells = cut_cells.astype(np.int32, copy=False)
        self.P_cut, self.cut_cells, self.pad = P_cut, cut_cells, pad
        self._boxes = None

    @property
    def nbytes(self) -> int:
        """Bytes of array data sent to each worker."""
        return self.P_cut.nbytes + self.cut_cells.nbytes

    def __getstate__(self):
        return {"P_cut": self.P_cut, "cut_cells": self.cut_cells, "pad": self.pad}

    def __setstate__(self, state):
        self.__init__(state["P_cut"], state["cut_cells"], state["pad"])

    def boxes(self, blocks: Blocks = SERIAL):
        """(wide lo, wide hi) of every cutting cell (:func:`.slices.wide`); ``blocks``:
        compiled or not, the same boxes."""
        if self._boxes is None:  # exact (min, max) and elementwise: the client's values
            clo, chi = boxes_of(self.P_cut, self.cut_cells, blocks)
            self._boxes = wide(clo, chi, self.pad, blocks.accelerate)
        return self._boxes


def cut_slice(part: Part, side: CutSide, blocks: Blocks = SERIAL) -> Part:
    """``part`` with its cutting slice (the cells :func:`.slices.cut_near` keeps for its
    halo, renumbered) taken from ``side``: the same slice the client's
    :meth:`Layout.part` cuts — the halo's boxes are exact functions of its cells'
    coordinates, which renumbering does not change, in the same order. ``blocks``: the
    boxes' and the grid test's passes (compiled in a compiled run's task: the same
    boxes and flags)."""
    if not part.cut_pending:
        return part
    lo, hi = boxes_of(part.P_sim, part.sim_cells, blocks)
    keep = cut_near(lo, hi, *side.boxes(blocks), blocks)
    Pc, cc, cid = _local(side.P_cut, side.cut_cells, keep)
    # a new Part: the one received may be a scattered object the worker keeps
    return replace(part, P_cut=Pc, cut_cells=cc, cut_ids=cid, cut_pending=False)


def split(P_sim, sim_cells, P_cut, cut_cells, k: int, pad: float, owner=None,
          write=None, cut_in_task: bool = False, vertex_ids=None):
    """Yield the :class:`Part` of each non-empty partition of k (cells in Morton
    order, cut into k runs of equal size ± 1); ``pad``: the largest broad-phase reach.
    Any assignment of cells to partitions gives the serial result; Morton runs keep them
    compact, so halos and cutting slices stay small. ``owner``: each vertex's partition
    given and ``write`` (per-partition files), ``cut_in_task`` (the cutting slices cut
    by the tasks), ``vertex_ids`` (the plan's run vertices): :class:`Layout`."""
    layout = Layout(P_sim, sim_cells, P_cut, cut_cells, k, pad, owner, write, cut_in_task,
                    vertex_ids)
    for r in range(k):
        part = layout.part(r)
        if part is not None:
            yield part


class Layout:
    """The split's global side (Morton order, vertex owners, every partition's halo:
    :mod:`~predicates.registration.partition.slices`, cutting boxes), from which
    :meth:`part` cuts any one partition — the client cuts them all, or each worker
    its own from the same arrays (the same Part, bit for bit: a pure function of the
    arrays, k, r and pad).

    ``owner`` given (a partition per vertex: the per-partition files' owners over
    every simulation cell, :func:`~predicates.registration.partition.files.vertex_owners`),
    partition r receives every cell with a vertex it owns (:func:`owner_halos`): it
    owns the pairs of its file, and section 4's lemma holds as it is stated (r holds
    every cell containing a vertex it owns); ``owned_cells`` then counts the cells whose
    first vertex r owns. ``write`` (the points as given, each run cell's index among
    all cells): each Part also carries its vertices' coordinates and its cells' indices
    (``sim_coords``, ``cell_ids``), for its file. ``cut_in_task``: the parts leave their
    cutting slices to the task (``cut_pending``: :func:`cut_slice` with a
    :class:`CutSide` sent once per worker); a part whose halo's bounding box misses the
    hull of the cutting cells' wide boxes is still cut here (empty: no task).
    ``vertex_ids``: the global id of each row of ``P_sim`` (ascending; ``sim_cells`` in
    those rows: the plan's run vertices, ``Plan.sim_vertex_ids``) — ``owner`` and
    ``write``'s points are then indexed by global id, and each Part's ``sim_ids`` are
    global ids (a monotone map: the local order is still the global order)."""

    def __init__(self, P_sim, sim_cells, P_cut, cut_cells, k: int, pad: float,
                 owner: np.ndarray | None = None, write=None, cut_in_task: bool = False,
                 vertex_ids: np.ndarray | None = None):
        self.write, self.cut_in_task, self.vertex_ids = write, cut_in_task, vertex_ids
        if owner is not None and vertex_ids is not None:
            owner = owner[vertex_ids]  # indexed as P_sim's rows
        self.P_sim, self.sim_cells, self.P_cut, self.cut_cells = (P_sim, sim_cells, P_cut,
                                                                  cut_cells)
        self.k, self.pad = k, pad
        m = len(sim_cells)
        if owner is None:
            pos, self.owner = assign(P_sim, sim_cells, k)
            part = pos * k // m  # cell c is owned by partition pos[c]·k // m (assign)
            self.owned = np.bincount(part, minlength=k)
            self.halo, self.halo_at = halos(sim_cells, part, k, len(P_sim))
        else:
            self.owner = owner
            self.owned = np.bincount(owner[sim_cells[:, 0]], minlength=k)
            self.halo, self.halo_at = owner_halos(sim_cells, owner, k)
        self.lo = self.hi = None  # the run cells' boxes, once, when a part is cut here
        if cut_in_task:  # only the hull of the cutting cells' wide boxes
            used = np.zeros(len(P_cut), dtype=bool)  # each used point once, not per corner
            used[cut_cells.ravel()] = True
            used = P_cut[used]
            self.hull = None if len(used) == 0 else wide(colmin(used)[None],
                                                         colmax(used)[None], pad)
        else:
            self.wide = wide(*boxes_of(P_cut, cut_cells), pad)

    def part(self, r: int) -> Part | None:
        """Partition r's :class:`Part` (None: it holds no cell)."""
        if self.halo_at[r + 1] == self.halo_at[r]:  # (the default: owns no cell)
            return None
        halo = self.halo[self.halo_at[r]: self.halo_at[r + 1]]  # includes own cells
        Ps, cs, sid = _local(self.P_sim, self.sim_cells, halo)
        pending = self.cut_in_task and self._meets_hull(Ps)
        if self.cut_in_task:  # the task cuts it, or it is empty (no wide box meets it)
            cut_keep = np.zeros(0, dtype=np.int64)
        else:
            if self.lo is None:
                self.lo, self.hi = boxes_of(self.P_sim, self.sim_cells)
            cut_keep = cut_near(self.lo[halo], self.hi[halo], *self.wide)
        Pc, cc, cid = _local(self.P_cut, self.cut_cells, cut_keep)
        gid = sid if self.vertex_ids is None else _global(self.vertex_ids, sid)
        part = Part(r, Ps, cs, gid, self.owner[sid] == r, Pc, cc, cid, int(self.owned[r]),
                    cut_pending=pending)
        if self.write is not None:
            points, rows = self.write
            part.sim_coords, part.cell_ids = points[gid], rows[halo]
        return part


    def _meets_hull(self, points: np.ndarray) -> bool:
        """The bounding box of ``points`` (a halo's vertices: the hull of its cells'
        boxes) meets the hull of the cutting cells' wide boxes — a superset of
        :func:`.slices.cut_near`'s first test (each wide box lies in the hull: rounding
        is monotone), so a part that fails it has an empty cutting slice."""
        if len(points) == 0 or self.hull is None:
            return False
        lo, hi = colmin(points), colmax(points)
        return bool(np.all(self.hull[0][0] <= hi) and np.all(self.hull[1][0] >= lo))


def owned(part: Part, pairs: dict) -> dict:
    """The pairs of a partition's run (local ids) that it owns, in global ids: those
    whose simulation primitive's smallest vertex id (local order = global order) is an
    owned vertex."""
    out = {}
    for kind, p in pairs.items():
        keep = part.own_vertex[rowwise(np.minimum, p.sim)] if len(p) else np.zeros(0, dtype=bool)
        # compress and take: the rows and ids of fancy indexing, in half its time
        sim, cut, sw, cw = (np.compress(keep, a, axis=0)
                            for a in (p.sim, p.cut, p.sim_weights, p.cut_weights))
        out[kind] = KindPairs(kind, np.take(part.sim_ids, sim), np.take(part.cut_ids, cut),
                              sw, cw, candidates=p.candidates, suppressed=p.suppressed)
    return out


def merge(kinds, results: list[dict], dtype, fast: bool = False) -> dict:
    """{kind: KindPairs}: the partitions' owned pairs in the serial run's order (by
    sorted sim ids, then sorted cut ids). Each partition's pairs come in that order
    already (its run sorts by local ids, and local order is global order) and all pairs
    with the same smallest sim id belong to one partition (its owner), so the serial
    order is the merge of k sorted runs by the smallest sim id alone — the stable sort
    by that key, with no tie between partitions (refused: an ownership bug). The merge
    is found run by run (:func:`merge_runs`) and copied slice by slice into the result's
    arrays, no reorder of every row (docs/partitioned.md 5). ``candidates`` and
    ``suppressed`` are summed: per-run work statistics (halo pairs are counted by every
    partition that proposed them), not part of the result. ``fast``: the runs found by
    a compiled loop (:func:`predicates.compiled.mergeruns.merge_runs`: the same runs)."""
    out = {}
    for k in kinds:
        got = [r[k.name] for r in results if k.name in r]
        keys = [rowwise(np.minimum, g.sim) if len(g.sim) else np.zeros(0, np.int64)
                for g in got]
        how = merge_runs(keys, MERGE_RUNS + sum(map(len, keys)) // 256, k.name, fast)
        if how is None:  # partitions interleaved row by row: one sort, then a gather
            how = _merge_order(keys, k.name)
        arrays = []  # the serial run's int64 ids (the partitions send int32 when they fit)
        for name, base in (("sim", np.int64), ("cut", np.int64), ("sim_weights", dtype),
                           ("cut_weights", dtype)):
            parts = [getattr(g, name) for g in got]
            width = (k.i if name.startswith("sim") else k.j) + 1
            arrays.append(_merged(parts, how, width,
                                  np.result_type(base, *(a.dtype for a in parts))))
        out[k.name] = KindPairs(k.name, *arrays,
                                candidates=sum(g.candidates for g in got),
                                suppressed=sum(g.suppressed for g in got))
    return out


#: The merge copies slices while it finds at most this many runs (plus one per 256 pairs)
#: of consecutive pairs of one partition; beyond (partitions interleaved pair by pair)
#: one stable sort of every key and a gather cost less than a slice per run.
MERGE_RUNS = 4096


def _shared(kind: str) -> RuntimeError:
    return RuntimeError(f"{kind}: two partitions kept pairs of the same vertex (an "
                        "ownership bug; please report it)")


def merge_runs(keys: list[np.ndarray], limit: int, kind: str = "pairs", fast: bool = False):
    """The stable merge of the ascending arrays ``keys`` (one per partition) as runs
    ``(partition, start, stop)`` of consecutive rows of one partition, in merged order;
    None when it needs more than ``limit`` runs. Each step takes the partition whose
    next key is the smallest, and its rows up to the next key of any other partition (a
    binary search). A key in two partitions raises RuntimeError: when the merge reaches
    it, both partitions' next keys are that key (all smaller ones are taken)."""
    # one dtype, and the needle in it: a Python int against int32 keys casts the whole
    # array per search (~60 µs a run at W4's 370 k pairs instead of O(log n))
    common = np.result_type(np.int32, *keys)
    if fast and common.kind == "i":  # the same loop compiled, over the keys joined
        from predicates.compiled.mergeruns import merge_runs as kernel

        starts = np.cumsum([0] + [len(key) for key in keys], dtype=np.int64)
        runs = np.empty((limit, 3), dtype=np.int64)
        n = kernel(np.concatenate(keys + [np.zeros(0, common)], dtype=common), starts,
                   limit, runs)
        if n == -2:
            raise _shared(kind)
        return None if n < 0 else [tuple(r) for r in runs[:n].tolist()]
    keys = [np.asarray(key, dtype=common) for key in keys]
    heads = [0] * len(keys)
    runs = []
    while True:
        live = sorted((int(key[h]), p) for p, (key, h) in enumerate(zip(keys, heads))
                      if h < len(key))
        if not live:
            return runs
        if len(runs) == limit:
            return None
        p = live[0][1]
        if len(live) == 1:
            stop = len(keys[p])
        else:  # (equal next keys: stop is the head, and the test below refuses it)
            stop = int(np.searchsorted(keys[p], keys[p].dtype.type(live[1][0]),
                                       side="left"))
            if stop < len(keys[p]) and keys[p][stop] == live[1][0]:
                raise _shared(kind)
        runs.append((p, heads[p], stop))
        heads[p] = stop


def _merge_order(keys: list[np.ndarray], kind: str) -> np.ndarray:
    """The rows of the concatenated ``keys`` in their stable sorted order (the merge's
    fallback), after refusing a key held by two partitions."""
    first = np.concatenate(keys + [np.zeros(0, np.int64)])
    order = np.argsort(first, kind="stable")
    part = np.repeat(np.arange(len(keys)), [len(key) for key in keys])[order]
    first = first[order]
    if np.any((first[1:] == first[:-1]) & (part[1:] != part[:-1])):
        raise _shared(kind)
    return order


def _merged(parts: list[np.ndarray], how, width: int, dtype) -> np.ndarray:
    """The rows of ``parts`` (one array per partition) in the merged order ``how``:
    runs (partition, start, stop) copied as slices, or an order of the concatenated
    rows (``take``: a row gather, half of fancy indexing's time)."""
    if isinstance(how, np.ndarray):
        rows = np.concatenate(parts + [np.zeros((0, width), dtype)])
        return np.take(rows, how, axis=0)
    out = np.empty((sum(len(a) for a in parts), width), dtype=dtype)
    at = 0
    for p, start, stop in how:
        out[at: at + stop - start] = parts[p][start:stop]
        at += stop - start
    return out
