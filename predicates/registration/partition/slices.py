"""What each partition receives (docs/partitioned.md, section 3): its halo
cells, for all k partitions in one pass, and its cutting slice, in time proportional
to the partition.

Cutting each partition took a pass over every run cell (its halo) and a broad-phase
grid over every cutting cell (its slice): O(k·n) for k partitions, 6 ms a partition on
W1 and ~0.15 s on W4, so the client's split grew with the number of workers (W1, k =
128: 0.8 s, more than the serial registration).

* **halo** (:func:`halos`): cell X is in partition r's halo when X shares a vertex with
  a cell r owns. Most vertices have all their cells in one partition; only the cells
  with a vertex of several partitions ("border" vertices) join other halos. One pass,
  O(n log n) for any k; grouped by partition, ascending, as CSR arrays
  (``ids[starts[r]:starts[r + 1]]``).
* **cutting slice** (:func:`cut_near`): the cutting cells whose doubly padded box
  meets the halo's bounding box and shares a cell of a grid over that box with one of
  the halo's cell boxes (docs/partitioned.md 3).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxgrid import (
    BITS, cell_index, cells_per_axis, colmax, colmin, enlarge, expand)
from predicates.registration.spatial.broadphase import runs
from predicates.registration.spatial.gridsums import any_in, occupancy

__all__ = ["cut_near", "halos", "owner_halos", "wide"]


def _unique(keys: np.ndarray) -> np.ndarray:
    """np.unique of int64 keys, by a sort and its runs (numpy's hash-based unique is ~5x
    slower on these arrays)."""
    return runs(np.sort(keys))[0]


def _grouped(keys: np.ndarray, k: int, width: int):
    """Sorted unique keys ``r·width + id`` as (ids, starts): partition r's ids are
    ``ids[starts[r]:starts[r + 1]]``, ascending."""
    keys = _unique(keys)
    starts = np.searchsorted(keys, np.arange(k + 1, dtype=np.int64) * width)
    return keys % width, starts


def halos(cells: np.ndarray, part: np.ndarray, k: int, n_points: int):
    """(halo cell ids, starts): partition r's halo — every cell sharing a vertex with a
    cell of partition ``part[cell]`` = r, its own cells included — is
    ``ids[starts[r]:starts[r + 1]]``, ascending. ``cells`` (m, d+1) vertex ids <
    ``n_points``; ``part`` (m,) in [0, k)."""
    m, width = cells.shape
    V = cells.ravel()
    R = np.repeat(part.astype(np.int64), width)
    lo = np.full(n_points, k, dtype=np.int64)
    hi = np.full(n_points, -1, dtype=np.int64)
    np.minimum.at(lo, V, R)
    np.maximum.at(hi, V, R)
    border = lo != hi  # a vertex in no cell has lo = k, hi = -1, and is never read
    at = np.flatnonzero(border[V])  # entries (cell, vertex) at a border vertex
    own = part.astype(np.int64) * m + np.arange(m, dtype=np.int64)
    if at.size == 0:
        return _grouped(own, k, m)
    # the partitions of each border vertex: sorted (vertex, partition) pairs
    vr = _unique(V[at].astype(np.int64) * k + R[at])
    vb = vr // k
    first = np.searchsorted(vb, V[at], side="left")
    count = np.searchsorted(vb, V[at], side="right") - first
    entry, idx = expand(first, count)
    return _grouped(np.concatenate([own, (vr[idx] % k) * m + at[entry] // width]), k, m)


def owner_halos(cells: np.ndarray, owner: np.ndarray, k: int):
    """(cell ids, starts): partition r's cells when the vertices' owners are given
    (``owner``: a partition in [0, k) per vertex of ``cells``; the per-partition files'
    rule over every simulation cell, docs/partitioned.md 6): every cell with a vertex r
    owns, ``ids[starts[r]:starts[r + 1]]``, ascending. That is all section 4 needs:
    r holds every cell containing a vertex it owns."""
    m, width = cells.shape
    rows = np.repeat(np.arange(m, dtype=np.int64), width)
    return _grouped(owner[cells.ravel()].astype(np.int64) * m + rows, k, m)


def wide(clo: np.ndarray, chi: np.ndarray, pad: float, accelerate: bool = False):
    """The cutting boxes enlarged by 2·pad, rounded outwards: :func:`cut_near`'s
    boxes (a cutting cell within pad of a cell meets this box with room to spare for
    the float test's rounding). ``accelerate``: one compiled pass (the same values)."""
    return enlarge(clo, chi, 2 * pad, accelerate)


def cut_near(lo, hi, wide_lo, wide_hi, blocks: Blocks = SERIAL) -> np.ndarray:
    """Indices (ascending) of the cutting cells whose :func:`wide` boxes ``wide_lo``,
    ``wide_hi`` meet the bounding box of the halo cells' boxes ``lo``, ``hi`` and
    share a cell of a grid over that bounding box with one of them: a superset of the
    cutting cells within pad of a halo cell (docs/partitioned.md 3: such a cell's wide
    box meets the halo cell's box; a box's cells are its corners' cells and the cell
    index is monotone, so two boxes that meet share a cell), and a tight one — the
    grid's cell is about the largest halo cell (:func:`_halo_grid`), so a partition
    gets the cutting cells over its own region plus a border. The bounding-box test
    first makes the grid's work proportional to the partition, not to the whole
    cutting mesh; the grid test is two passes per box and a summed-area table
    (:mod:`~predicates.registration.spatial.gridsums`), no pair and no mean extent.
    ``blocks``: compiled passes in a task of a compiled run (the same flags)."""
    if len(wide_lo) == 0 or len(lo) == 0:
        return np.zeros(0, dtype=np.int64)
    blo, bhi = colmin(lo), colmax(hi)
    meets = np.ones(len(wide_lo), dtype=bool)
    for ax in range(lo.shape[1]):
        meets &= wide_lo[:, ax] <= bhi[ax]
        meets &= wide_hi[:, ax] >= blo[ax]
    cand = np.flatnonzero(meets)
    if cand.size == 0:
        return cand
    h, G = _halo_grid(lo, hi, blo, bhi, len(cand))
    occ = occupancy(*(cell_index(x, blo, h, G, blocks) for x in (lo, hi)), G, blocks)
    ib0, ib1 = (cell_index(np.take(x, cand, axis=0), blo, h, G, blocks)
                for x in (wide_lo, wide_hi))
    return cand[any_in(occ, ib0, ib1, G, blocks)]


def _halo_grid(lo, hi, blo, bhi, n_cut: int):
    """(cell size, cells per axis) of :func:`cut_near`'s grid over the halo's bounding
    box [``blo``, ``bhi``]: the largest extent of a halo box (so each covers at most
    two cells per axis), doubled while the grid has more cells than twice the boxes
    (halo and ``n_cut`` cutting ones; at least 2^16): its summed-area table costs
    about the boxes' passes. Any positive size gives a superset of
    the cells within pad; this one only bounds the work, from exact maxima (the same
    grid for the same boxes in any order, on the client and in the task)."""
    with np.errstate(over="ignore", invalid="ignore"):
        span = bhi - blo
        h = float(colmax(hi - lo).max())
        top = float(span.max())
    if not np.isfinite(top):
        raise ValueError("coordinates too large for the cutting slices (their range "
                         "overflows the floating-point format)")
    h = max(h, top * 2.0 ** -BITS, np.finfo(np.float64).tiny)
    budget = max(1 << 16, 2 * (len(lo) + n_cut))
    while True:
        G = cells_per_axis(span, h)
        if float(np.prod(G.astype(float))) <= budget or np.all(G == 1):
            return h, G
        h *= 2
