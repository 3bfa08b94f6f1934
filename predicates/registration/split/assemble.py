"""The split where the cut is (docs/split.md, "Implementation"): the rules of
:mod:`.rules` run on the cells near the cut only, and the uncut rest of the mesh keeps
one copy of every cell with node = vertex.

*Near* cells have a vertex of a registered simulation primitive; the *local* cells are
the near cells and every cell sharing a vertex with one. Every cell around a vertex of a
near cell is local, so the nodes of those vertices (their classes of (fragment, corner)
slots) are complete in the local problem; every other vertex is off the cut, material in
every cell around it and has one node. The new cells, nodes and pieces are numbered as
if the rules ran on the whole mesh (new cells by (cell, representative corner), nodes by
(original vertex, smallest slot), pieces by their first new cell); pieces are the
connected components of the new cells through shared nodes, which are the classes of
glued fragments when the cells around every vertex are connected through faces (a
manifold mesh). Cost: O(local cells · log) for the rules and O(C) vectorised gathers,
cumulative sums and one union-find round set for the numbering and the pieces.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predicates.registration.spatial.boxgrid import expand
from predicates.registration.split import rules as R
from predicates.registration.split.cover import covered_faces

__all__ = ["Topology", "split_topology", "touched_vertices"]


@dataclass
class Topology:
    """What :func:`split_topology` computes (fields as in ``SplitMesh``)."""

    cells: np.ndarray
    cell_origin: np.ndarray
    node_origin: np.ndarray
    material: np.ndarray
    piece: np.ndarray
    n_pieces: int
    on_cut: np.ndarray
    severed: np.ndarray
    near: np.ndarray
    nfrag: np.ndarray
    start: np.ndarray


def touched_vertices(res, n: int) -> np.ndarray:
    """(n,) bool: the vertices of every registered simulation primitive."""
    t = np.zeros(n, dtype=bool)
    for kind in res.kinds:
        if len(res[kind]):
            t[res[kind].sim.ravel()] = True
    return t


def _zones(res, cells: np.ndarray, n: int, near_only: bool):
    """(used vertices, near cells, vertices of near cells, local cells)."""
    used = np.zeros(n, dtype=bool)
    used[cells.ravel()] = True
    if not near_only:
        everything = np.arange(len(cells))
        return used, everything, used.copy(), everything
    near = np.flatnonzero(R.any_corner(touched_vertices(res, n), cells))
    ring_v = np.zeros(n, dtype=bool)
    ring_v[cells.take(near, axis=0).ravel()] = True
    return used, near, ring_v, np.flatnonzero(R.any_corner(ring_v, cells))


def _nodes(root, origin, ring_v, used):
    """Node ids of the local slots and the node counts per vertex: a vertex of a near
    cell has one node per class of its slots, ordered by the class's smallest slot;
    every other used vertex one node."""
    in_ring = ring_v.take(origin)
    cls = np.flatnonzero((root == np.arange(len(root))) & in_ring)
    cls_origin = origin.take(cls)
    count = np.where(ring_v, 0, used).astype(np.int64)
    count += np.bincount(cls_origin, minlength=len(used))
    offsets = np.cumsum(count) - count
    o = np.lexsort((cls, cls_origin))
    rank = np.empty(len(cls), dtype=np.int64)
    rank[o] = np.arange(len(cls))
    within = rank - np.searchsorted(cls_origin[o], cls_origin, side="left")
    lut = np.zeros(len(root), dtype=np.int64)
    lut[cls] = offsets[cls_origin] + within
    slot_node = np.where(in_ring, lut.take(root), offsets.take(origin))
    return slot_node, count, offsets


def _pieces(new_cells: np.ndarray, n_nodes: int):
    """Pieces: components of the new cells through shared nodes, numbered by their first
    new cell."""
    F, m = new_cells.shape
    root = R.row_components(n_nodes, [new_cells[:, j] for j in range(m)])
    froot = root.take(new_cells[:, 0])
    first = np.full(max(n_nodes, 1), F, dtype=np.int64)
    np.minimum.at(first, froot, np.arange(F))
    first_of = first.take(froot)  # each new cell's piece, as its first new cell
    mark = np.zeros(F + 1, dtype=bool)
    mark[first_of] = True
    rank = np.cumsum(mark) - 1
    return rank.take(first_of), int(mark.sum())


def split_topology(res, cells: np.ndarray, n: int, near_only: bool = True) -> Topology:
    """Fragments, nodes and pieces of the split (docs/split.md, rules 1–3), computed on
    the cells near the cut (module docstring); ``near_only=False`` runs the rules on
    every cell (the same result on a manifold mesh: the tests compare the two)."""
    C, m = cells.shape
    used, near, ring_v, local = _zones(res, cells, n, near_only)
    on_cut = R.on_cut_vertices(res, n)
    sub = cells.take(local, axis=0)  # row copies (take: faster than fancy indexing)
    sev_sub = R.severed_edges(res, sub, n)
    severed = np.zeros((C, sev_sub.shape[1]), dtype=bool)
    severed[local] = sev_sub
    co, frag_of, mat = R.fragments(sub, on_cut, sev_sub)
    Fl = len(co)
    first_l = np.searchsorted(co, np.arange(len(local)))
    (_, _), (s1, s2) = R.glue(sub, frag_of, n, first_l,
                              lambda faces: covered_faces(res, faces))
    root = R.components(Fl * m, s1, s2)
    origin = sub.take(co, axis=0).ravel()
    slot_node, count, offsets = _nodes(root, origin, ring_v, used)
    nfrag = np.ones(C, dtype=np.int64)
    nfrag[local] = np.bincount(co, minlength=len(local))
    start = np.cumsum(nfrag) - nfrag
    F = int(nfrag.sum())
    cell_origin = np.repeat(np.arange(C, dtype=np.int64), nfrag)
    gfrag = start[local][co] + (np.arange(Fl) - first_l[co])
    # rows of cells[cell_origin]; take(axis=0): a row copy, not an element-wise gather
    new_cells = offsets.take(cells.take(cell_origin, axis=0) if F > C else cells)
    new_cells[gfrag] = slot_node.reshape(Fl, m)
    material = np.ones((F, m), dtype=bool)
    material[gfrag] = mat
    n_nodes = int(count.sum())
    piece, n_pieces = _pieces(new_cells, n_nodes)
    node_origin = np.repeat(np.arange(n, dtype=np.int64), count)
    return Topology(new_cells, cell_origin, node_origin, material, piece, n_pieces, on_cut,
                    severed, near, nfrag, start)


def hits_csr(cells: np.ndarray, top: Topology, hit_sim: np.ndarray, n: int):
    """CSR (offsets, index) of the intersection points on the closure of every new cell
    (a point on a face of the original cell belongs to all its fragments), each cell's by
    increasing point; only the near cells carry points. The (cell, point) pairs are
    sorted once as packed int64 keys (distinct: ``np.sort``, no argsort), then each
    cell's run is repeated for its fragments."""
    hh, cc = R.cell_hits(cells.take(top.near, axis=0), hit_sim, n,
                         top.severed.take(top.near, axis=0))
    H = max(len(hit_sim), 1)
    key = cc * H + hh  # near cells are increasing: by (cell, point)
    key.sort()
    hh = key % H
    per_cell = np.bincount(key // H, minlength=len(top.near))
    run = np.cumsum(per_cell) - per_cell
    reps = top.nfrag.take(top.near)
    _, at = expand(np.repeat(run, reps), np.repeat(per_cell, reps))
    F = len(top.cell_origin)
    counts = np.zeros(F, dtype=np.int64)
    counts[expand(top.start.take(top.near), reps)[1]] = np.repeat(per_cell, reps)
    offsets = np.zeros(F + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets, hh.take(at)
