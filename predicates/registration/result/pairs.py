"""The registered pairs of one kind (:class:`KindPairs`) and the kind codes written with
them (section 1 of the paper: the primitive pairs the registration reports)."""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from predicates.portable import weighted_sum
from predicates.registration.spatial.boxgrid import any_corner as corner_flags

__all__ = ["KIND_CODES", "KindPairs", "any_corner", "cells_holding", "pad_rows"]

#: one code per kind name, the same in 2D and 3D (0: none), stored with its legend
KIND_CODES = {"vertex_vertex": 1, "vertex_edge": 2, "edge_vertex": 3, "edge_edge": 4,
              "triangle_vertex": 5, "vertex_triangle": 6, "edge_triangle": 7,
              "triangle_edge": 8, "tetrahedron_vertex": 9}


@dataclass
class KindPairs:
    """The registered pairs of one kind (e.g. ``"edge_triangle"``).

    ``sim`` (m, i+1) and ``cut`` (m, j+1): vertex ids (rows of the input point arrays)
    of the simulation and cutting primitives; ``sim_weights`` / ``cut_weights``: the
    barycentric weights of the intersection point on each primitive, column by column
    for the ids beside them (a vertex has weight [1]). Within a primitive, vertices are
    listed in lexicographic order of their coordinates (the order the predicate saw
    them), rows are sorted by ids.

    ``candidates``: pairs proposed by the broad phase; ``suppressed``: of those, pairs
    skipped because a sub-pair was registered at a lower level; the rest were tested.
    """

    kind: str
    sim: np.ndarray
    cut: np.ndarray
    sim_weights: np.ndarray
    cut_weights: np.ndarray
    candidates: int = 0
    suppressed: int = 0
    _points: tuple | None = field(default=None, repr=False, compare=False)
    _sim_cells: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __len__(self):
        return len(self.sim)

    def __repr__(self):
        return (f"<KindPairs {self.kind}: {len(self)} registered of {self.tested} tested "
                f"({self.candidates} candidates)>")

    @property
    def tested(self) -> int:
        return self.candidates - self.suppressed

    def keys(self) -> set:
        """The pairs as a set of (sorted sim ids, sorted cut ids) tuples."""
        s, c = np.sort(self.sim, axis=1), np.sort(self.cut, axis=1)
        return {(tuple(a), tuple(b)) for a, b in zip(s.tolist(), c.tolist())}

    def points(self, points: np.ndarray | None = None, side: str = "sim") -> np.ndarray:
        """Intersection points Σ wᵢ·xᵢ on the simulation (``side="sim"``) or cutting
        primitive, in float64 (m, dim): from the result's own meshes, or from
        ``points`` (that side's point array) when given."""
        if side not in ("sim", "cut"):
            raise ValueError(f"side must be 'sim' or 'cut', got {side!r}")
        ids, w = (self.sim, self.sim_weights) if side == "sim" else (self.cut, self.cut_weights)
        if points is None:
            if self._points is None:
                raise ValueError("these pairs are not attached to a result: pass the points")
            points = self._points[0 if side == "sim" else 1]
        points = np.asarray(points, dtype=np.float64)
        if len(ids) == 0:
            return np.zeros((0, points.shape[1]))
        return weighted_sum(w, points[ids])

    @property
    def sim_cell(self) -> np.ndarray:
        """(m,) int64: for each pair, a simulation cell whose closure holds the pair's
        simulation primitive (the lowest-numbered one: a vertex, edge or face is shared by
        several cells; ``tetrahedron_vertex``'s primitive is the cell itself)."""
        if self._sim_cells is None:
            raise ValueError("these pairs are not attached to a result")
        return cells_holding(self._sim_cells, self.sim)


def any_corner(mask: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(C,) bool: cells (C, k) with a corner where ``mask`` (a bool per vertex) is set
    (:func:`~predicates.registration.spatial.boxgrid.any_corner`). Cells on Dask workers (a dask array: docs/partitioned.md 6) are scanned there, chunk by
    chunk: one bool per cell comes back, not the cells."""
    if hasattr(cells, "map_blocks"):
        rows = cells.rechunk({1: -1}).map_blocks(_corner_rows, mask, drop_axis=1,
                                                 dtype=bool)
        return np.asarray(rows.compute())
    return corner_flags(mask, cells)


def _corner_rows(block: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """:func:`any_corner` of one chunk of cells (on a Dask worker)."""
    return corner_flags(mask, block)


def cells_holding(cells: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(m,) int64: for each row of vertex ids (a face of some cell), the lowest-numbered
    cell of ``cells`` (C, k) having those vertices; −1 where no cell has them. Only the
    cells with a vertex in ``rows`` are examined."""
    rows = np.sort(np.asarray(rows, dtype=np.int64), axis=1)
    out = np.full(len(rows), -1, dtype=np.int64)
    if len(rows) == 0 or len(cells) == 0:
        return out
    on = np.zeros(int(max(cells.max(), rows.max())) + 1, dtype=bool)
    on[rows.ravel()] = True
    near = np.flatnonzero(any_corner(on, cells))
    r, k = rows.shape[1], cells.shape[1]
    combos = list(itertools.combinations(range(k), r))
    # the faces of a sorted row are sorted
    # (np.asarray: cells kept on Dask workers give their near rows only)
    faces = np.sort(np.asarray(cells[near]), axis=1)[:, combos].reshape(-1, r).astype(np.int64)
    owner = np.repeat(near, len(combos))
    void = np.dtype((np.void, 8 * r))  # a row as one comparable key, no overflow
    fk = np.ascontiguousarray(faces).view(void).ravel()
    order = np.argsort(fk, kind="stable")  # stable: the lowest cell first among equals
    fk = fk[order]
    rk = np.ascontiguousarray(rows).view(void).ravel()
    at = np.minimum(np.searchsorted(fk, rk), len(fk) - 1)
    found = fk[at] == rk
    out[found] = owner[order[at[found]]]
    return out


def pad_rows(a: np.ndarray, width: int, fill) -> np.ndarray:
    """Rows of ``a`` (m, w) right-padded with ``fill`` to ``width`` columns."""
    out = np.full((len(a), width), fill, dtype=a.dtype)
    out[:, : a.shape[1]] = a
    return out
