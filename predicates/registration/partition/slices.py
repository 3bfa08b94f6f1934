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
* **cutting slice** (:func:`cut_near`): the broad phase's grid test of the halo's boxes
  against the cutting boxes enlarged by the pad, on the cutting cells whose box (wider
  still) meets the halo's bounding box.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxgrid import colmax, colmin, enlarge, expand
from predicates.registration.spatial.broadphase import near_flags, runs

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


def wide(clo: np.ndarray, chi: np.ndarray, pad: float):
    """The cutting boxes enlarged by 2·pad, rounded outwards: :func:`cut_near`'s
    first, coarse test (a cutting cell within pad of a cell meets this box with room
    to spare for the float test's rounding)."""
    return enlarge(clo, chi, 2 * pad)


def cut_near(lo, hi, clo, chi, wide_lo, wide_hi, pad: float,
             blocks: Blocks = SERIAL) -> np.ndarray:
    """Indices (ascending) of the cutting cells (boxes ``clo``, ``chi``; ``wide`` of
    them: ``wide_lo``, ``wide_hi``) that share a broad-phase grid cell with one of the
    halo cells' boxes ``lo``, ``hi``, the cutting boxes enlarged by ``pad``
    (:func:`~predicates.registration.spatial.broadphase.near_flags`), among those whose wide box
    meets the halo's bounding box: a superset of the cutting cells within ``pad`` of a
    halo cell (the same float test), and a tight one — the grid is about a cell's size,
    so a partition gets the cutting cells over its own region plus a border. The
    bounding-box test first makes the grid's work proportional to the partition, not
    to the whole cutting mesh. ``blocks``: near_flags' passes (compiled in a task of a
    compiled run: the same flags)."""
    if len(clo) == 0 or len(lo) == 0:
        return np.zeros(0, dtype=np.int64)
    blo, bhi = colmin(lo), colmax(hi)
    meets = np.ones(len(clo), dtype=bool)
    for ax in range(lo.shape[1]):
        meets &= wide_lo[:, ax] <= bhi[ax]
        meets &= wide_hi[:, ax] >= blo[ax]
    cand = np.flatnonzero(meets)
    if cand.size == 0:
        return cand
    _, near = near_flags(lo, hi, clo[cand], chi[cand], pad, sides="b", blocks=blocks)
    return cand[near]
