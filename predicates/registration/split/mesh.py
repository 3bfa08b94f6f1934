"""The virtual-node split of the simulation mesh along the cutting surface (docs/split.md).

The paper's registration (section 1) exists to feed a cutting simulation: the virtual
node algorithm (VNA) of Molino, Bao and Fedkiw (2004) and its adaptive, robust version by
Wang, Jiang, Schroeder and Teran. :func:`split_mesh` builds the first thing such a
simulation needs — the material fragments of every cell and the duplicated mesh — from
the registered pairs only, so the split inherits their consistency (a shared edge is
severed in all its cells or in none). Rules (``predicates.registration.split.rules``, docs/split.md):

1. a simulation edge is *severed* when it is the simulation primitive of a registered
   pair (edge_vertex, edge_edge, 3D edge_triangle); a simulation vertex is *on the cut*
   when it is the primitive of one (vertex_vertex, vertex_edge, 3D vertex_triangle);
2. the fragments of a cell are the connected components of its off-cut vertices through
   its unsevered edges; each fragment is a copy of the cell whose material corners are
   that component's vertices plus every on-cut vertex of the cell (virtual otherwise);
3. fragments of neighbouring cells sharing a material (off-cut) vertex on their common
   face are glued there, and all that face's nodes are identified; the nodes are the
   classes of (fragment, corner) slots, the pieces the classes of glued fragments.

A cell only partly cut (a crack tip inside it) keeps its vertices connected and stays
whole. Depends only on the public attributes of ``IntersectionResult``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predicates.registration.split.assemble import hits_csr, split_topology
from predicates.portable import row_norms, weighted_sum

__all__ = ["SplitMesh", "split_mesh"]

#: meshio cell type of the simulation cells, by dimension
CELL_TYPE = {2: "triangle", 3: "tetra"}


@dataclass
class SplitMesh:
    """The split simulation mesh (virtual node algorithm), built by :func:`split_mesh`.

    ``points`` (N', d): the new nodes, copies of simulation vertices (``node_origin``
    (N',): the original vertex of each). ``cells`` (C', d+1): the new cells — an original
    cell cut into k fragments appears k times, its corners in the original order
    (``cell_origin`` (C',): the original cell). ``material`` (C', d+1) bool: whether a
    corner is a real material node of that fragment (else a virtual node). ``piece``
    (C',) in 0..``n_pieces``−1: the connected pieces, numbered by their first new cell.
    Nodes are numbered by original vertex, so an uncut mesh comes back unchanged.

    The intersection points on each cell (for embedding the cut surface): ``hit_points``
    (H, d) float64, Σ wᵢ·xᵢ on the simulation primitive; ``hit_kind`` (H,): index into
    ``kinds``; ``hit_sim`` / ``hit_weights`` (H, d+1): the primitive's vertex ids and the
    registered barycentric weights (−1 / 0 padded). The points on the closure (vertices,
    edges, faces, interior) of new cell f are ``hit_index[hit_offsets[f]:hit_offsets[f+1]]``
    (:meth:`hits_of`). ``on_cut`` (N,) bool and ``severed`` (C, E) bool: the rule inputs.
    """

    dim: int
    kinds: tuple
    points: np.ndarray
    cells: np.ndarray
    cell_origin: np.ndarray
    node_origin: np.ndarray
    material: np.ndarray
    piece: np.ndarray
    n_pieces: int
    hit_points: np.ndarray
    hit_kind: np.ndarray
    hit_sim: np.ndarray
    hit_weights: np.ndarray
    hit_offsets: np.ndarray
    hit_index: np.ndarray
    on_cut: np.ndarray
    severed: np.ndarray
    source: object = None  # the IntersectionResult split (for tetrahedralize)

    def tetrahedralize(self):
        """Every piece as simplices conforming to the cut (2D: triangles): a
        :class:`~predicates.registration.split.conform.ConformingMesh` (docs/split.md,
        "The conforming tetrahedralization")."""
        from predicates.registration.split.conform import conforming_mesh

        return conforming_mesh(self.source, self)

    triangulate = tetrahedralize

    def hits_of(self, cell: int) -> np.ndarray:
        """Indices (into ``hit_points``) of the intersection points on new cell ``cell``."""
        return self.hit_index[self.hit_offsets[cell]: self.hit_offsets[cell + 1]]

    @property
    def cut_cells(self) -> np.ndarray:
        """(C',) bool: the new cells whose original cell was split into several."""
        counts = np.bincount(self.cell_origin)
        return counts[self.cell_origin] > 1

    def material_bitmask(self) -> np.ndarray:
        """(C',) int32: Σ 2^k over the material corners k of each new cell."""
        return (self.material.astype(np.int32) << np.arange(self.dim + 1)).sum(axis=1)

    def explode_offsets(self, factor: float) -> np.ndarray:
        """(n_pieces, d): the displacement of every piece for an exploded view:
        ``factor`` × (piece centroid − mesh centroid), centroids of the nodes. Pieces
        whose centroids nearly coincide with the mesh's (nested: a ball in its cavity,
        which that rule cannot separate) are set side by side along x instead, the k-th
        one (k ≥ 1) moved by k·(1 + factor)·(the mesh's x extent)."""
        node_piece = np.zeros(len(self.points), dtype=np.int64)
        node_piece[self.cells.ravel()] = np.repeat(self.piece, self.dim + 1)
        X = self.points.astype(np.float64)
        cnt = np.bincount(node_piece, minlength=self.n_pieces)[:, None]
        cen = np.stack([np.bincount(node_piece, X[:, k], self.n_pieces)
                        for k in range(self.dim)], 1) / np.maximum(cnt, 1)
        off = float(factor) * (cen - X.mean(axis=0))
        ext = X.max(axis=0) - X.min(axis=0) if len(X) else np.zeros(self.dim)
        nested = row_norms(cen - X.mean(axis=0)) < 0.05 * row_norms(ext[None])[0]
        if factor and nested.sum() > 1:
            off[nested] = 0.0
            off[nested, 0] = np.arange(nested.sum()) * (1 + float(factor)) * ext[0]
        return off

    def exploded_points(self, factor: float) -> np.ndarray:
        """The node coordinates with every piece moved by :meth:`explode_offsets`."""
        node_piece = np.zeros(len(self.points), dtype=np.int64)
        node_piece[self.cells.ravel()] = np.repeat(self.piece, self.dim + 1)
        return self.points.astype(np.float64) + self.explode_offsets(factor)[node_piece]

    def to_meshio(self, explode: float = 0.0, volumes=None):
        """The split mesh as a ``meshio.Mesh`` for ParaView: cell data ``piece``,
        ``cell_origin``, ``material`` (bitmask, :meth:`material_bitmask`) and
        ``material_count``; point data ``node_origin``. With ``volumes`` (a
        :class:`~predicates.registration.split.volume.FragmentVolumes`) also
        ``volume`` (area in 2D), ``volume_fraction`` (of the original cell),
        ``centroid`` (3 components) and ``unclaimed_fraction`` (the original cell's
        material no fragment owns, docs/split.md); NaN for reported cells. 2D points get
        z = 0; ``explode`` moves the pieces apart (:meth:`exploded_points`)."""
        import meshio

        X = self.exploded_points(explode) if explode else self.points.astype(np.float64)
        if self.dim == 2:
            X = np.column_stack([X, np.zeros(len(X))])
        cd = {"piece": [self.piece.astype(np.int32)],
              "cell_origin": [self.cell_origin.astype(np.int64)],
              "material": [self.material_bitmask()],
              "material_count": [self.material.sum(axis=1).astype(np.int32)]}
        if volumes is not None:
            cv = volumes.cell_volume[self.cell_origin]
            with np.errstate(invalid="ignore", divide="ignore"):
                cen = volumes.moment / volumes.volume[:, None]
            if self.dim == 2:
                cen = np.column_stack([cen, np.zeros(len(cen))])
            cd.update({"volume": [volumes.volume], "volume_fraction": [volumes.volume / cv],
                       "centroid": [cen],
                       "unclaimed_fraction": [volumes.unclaimed[self.cell_origin] / cv]})
        return meshio.Mesh(X, [(CELL_TYPE[self.dim], self.cells.astype(np.int64))],
                           cell_data=cd, point_data={"node_origin": self.node_origin})

    def summary(self) -> dict:
        """The sizes of the split (JSON-ready). ``split_cells``: original cells cut into
        several fragments — not the cells the cut merely meets (a cell touched at a
        vertex, or crossed on one edge only, stays one fragment), which is what
        ``IntersectionResult.intersected_cells`` (``fperr intersect --sim-output``)
        counts."""
        return {"dim": self.dim, "cells": len(self.cells),
                "original_cells": int(self.cell_origin.max(initial=-1)) + 1,
                "split_cells": int(np.count_nonzero(np.bincount(self.cell_origin) > 1)),
                "nodes": len(self.points), "vertices": len(self.on_cut),
                "vertices_on_cut": int(self.on_cut.sum()),
                "cells_with_severed_edges": int(self.severed.any(axis=1).sum()),
                "pieces": self.n_pieces, "intersection_points": len(self.hit_points)}

    def __str__(self):
        s = self.summary()
        return (f"{self.dim}D split: {s['cells']} cells from {s['original_cells']} "
                f"({s['split_cells']} split into several fragments), {s['nodes']} nodes "
                f"from {s['vertices']} vertices ({s['vertices_on_cut']} on the cut, "
                f"{s['cells_with_severed_edges']} cells with severed edges), "
                f"{self.n_pieces} piece{'s' if self.n_pieces != 1 else ''}, "
                f"{s['intersection_points']} intersection points")


def _hits(res, d: int):
    """The registered intersection points, every kind: (points, kind, ids, weights)."""
    pts, kind, ids, w = [], [], [], []
    X = np.asarray(res.sim_points, dtype=np.float64)
    for code, k in enumerate(res.kinds):
        p = res[k]
        m, s = p.sim.shape
        if m == 0:
            continue
        wk = np.asarray(p.sim_weights, dtype=np.float64)
        pts.append(weighted_sum(wk, X[p.sim]))
        kind.append(np.full(m, code, dtype=np.int32))
        ids.append(np.pad(p.sim.astype(np.int64), ((0, 0), (0, d + 1 - s)),
                          constant_values=-1))
        w.append(np.pad(wk, ((0, 0), (0, d + 1 - s))))
    if not pts:
        return (np.zeros((0, d)), np.zeros(0, np.int32), np.zeros((0, d + 1), np.int64),
                np.zeros((0, d + 1)))
    return np.concatenate(pts), np.concatenate(kind), np.concatenate(ids), np.concatenate(w)


def split_mesh(res, near_only: bool = True) -> SplitMesh:
    """The virtual-node split of ``res``'s simulation mesh along its cutting mesh.

    ``res``: an :class:`~predicates.result.IntersectionResult` (only its public
    attributes are read: ``dim``, ``sim_points``, ``sim_cells``, ``kinds``, the cutting
    cells and the ``sim`` / ``cut`` ids and ``sim_weights`` of every kind). Rules: module
    docstring and docs/split.md. Vectorised, and only near the cut
    (:mod:`~predicates.registration.split.assemble`): the sorts cost O(cells near the
    cut); the rest of the mesh costs a few O(C) gathers. ``near_only=False`` runs the
    rules on every cell (a check: the same result on a manifold mesh).
    """
    d = int(res.dim)
    if d not in (2, 3):
        raise ValueError(f"split_mesh: dim must be 2 or 3, got {res.dim!r}")
    cells = np.asarray(res.sim_cells, dtype=np.int64)
    P = np.asarray(res.sim_points)
    n = len(P)
    if cells.ndim != 2 or cells.shape[1] != d + 1:
        raise ValueError(f"split_mesh: {d}D simulation cells must have {d + 1} vertices, "
                         f"got shape {cells.shape}")
    top = split_topology(res, cells, n, near_only)
    hp, hk, hs, hw = _hits(res, d)
    offsets, index = hits_csr(cells, top, hs, n)
    points = np.take(P, top.node_origin, axis=0)  # as P[node_origin], a row copy
    return SplitMesh(dim=d, kinds=tuple(res.kinds), points=points,
                     cells=top.cells, cell_origin=top.cell_origin,
                     node_origin=top.node_origin, material=top.material, piece=top.piece,
                     n_pieces=top.n_pieces, hit_points=hp, hit_kind=hk, hit_sim=hs,
                     hit_weights=hw, hit_offsets=offsets, hit_index=index,
                     on_cut=top.on_cut, severed=top.severed, source=res)
