"""The Morton split from per-chunk summaries (docs/partitioned.md 3, "The split where
the cells are"): the run cells stay in the chunks that hold them, and the client
finds the k runs of the Morton order from small per-chunk answers.

* each chunk keeps its run cells (:class:`ChunkRun`: global cell index, global vertex
  ids, its vertices' scaled coordinates — the plan's ``P_sim`` rows, bit for bit) and
  the first vertices' coordinates, and reports their hull; the client's min and max
  of the hulls is the box :func:`.assign.morton_order` takes over all run cells (exact);
* each chunk computes its cells' codes in that box (:func:`.assign.morton_codes`,
  element-wise: the client's codes);
* the k − 1 boundaries — the keys (code, global cell index) at the positions
  ⌈r·m/k⌉ of the stable Morton order — are selected exactly (:func:`select_boundaries`):
  per round each chunk returns the sparse histogram of the next 16 bits of its codes
  under each boundary's prefix, or, once a prefix holds few cells, their keys. So cell
  c is in partition r exactly when :func:`.assign.assign` says ``pos[c]·k // m = r``:
  the split does not depend on the chunking.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from predicates.registration.partition.assign import morton_codes
from predicates.registration.plan.inputs import times_pow2

__all__ = ["ChunkRun", "chunk_run", "first_hull", "partition_of", "select_boundaries",
           "with_codes"]

#: bits of each histogram round; a prefix holding at most FETCH cells sends its keys
STEP, FETCH = 16, 4096


class ChunkRun(NamedTuple):
    """A chunk's run cells: ``rows`` their global cell indices (ascending), ``vids``
    their vertices' global ids (ascending) with their scaled coordinates ``coords``,
    ``at`` the cells in rows of ``vids``, ``first_row`` per vertex the position of its
    first (smallest) cell here, ``first`` the cells' first vertices' coordinates as
    float64, one row per axis, ``codes`` their Morton codes (None until known); ``cpu``:
    the thread CPU seconds spent on them so far (the split's share of the critical
    path)."""

    rows: np.ndarray
    vids: np.ndarray
    coords: np.ndarray
    at: np.ndarray
    first_row: np.ndarray
    first: np.ndarray
    codes: np.ndarray | None = None
    cpu: float = 0.0


def chunk_run(source, points, rowbits: np.ndarray, offset: int, e: int, dtype,
              piece: bool) -> ChunkRun:
    """A chunk's :class:`ChunkRun` (on its worker). ``source``: the chunk's cells
    (global vertex ids; ``points`` every point in the working dtype) or, ``piece``, a
    piece's own (points as given, cells in its numbering, cells in global ids; its
    points cast to ``dtype`` as the plan casts every point); ``rowbits``: the plan's run
    mask over the chunk's rows, packed. The coordinates are scaled by 2^-e as
    ``inputs.scale_points`` does (element-wise: the plan's ``P_sim`` rows). Marks over
    the chunk's points, no sort of the cells' vertex ids."""
    c = time.thread_time()
    cells = source[2] if piece else np.asarray(source)
    rows = np.flatnonzero(np.unpackbits(rowbits, count=len(cells)).view(bool))
    # the run cells in the numbering of the points at hand: the piece's own or global
    # (take: a row gather ~8x faster than fancy indexing on W4's chunks)
    run = np.take(source[1] if piece else cells, rows, axis=0)
    n_here = len(source[0]) if piece else len(points)
    used = np.zeros(n_here, dtype=bool)
    used[run.ravel()] = True
    here = np.flatnonzero(used)
    if piece:  # their global ids, ascending (the piece's numbering is not monotone)
        gid = np.empty(n_here, dtype=np.int64)
        gid[run.ravel()] = np.take(cells, rows, axis=0).ravel()
        here = here[np.argsort(gid[here], kind="stable")]
        vids = gid[here]
        with np.errstate(all="ignore"):  # the plan's cast (checked there)
            given = source[0][here].astype(dtype, copy=False)
    else:
        vids = here.astype(np.int64)
        given = np.asarray(points[here])
    pos = np.empty(n_here, dtype=np.int32 if len(here) < 2 ** 31 else np.int64)
    pos[here] = np.arange(len(here))
    at = np.take(pos, run)
    m, w = at.shape
    first_row = np.full(len(vids), m, dtype=np.int64)
    np.minimum.at(first_row, at.ravel(), np.repeat(np.arange(m, dtype=np.int64), w))
    coords = times_pow2(given, -e)
    # the first vertices' coordinates, one row per axis: a gather per axis (the values
    # of coords[at[:, 0]] as float64, transposed)
    axes = np.ascontiguousarray(coords.T, dtype=np.float64)
    first = np.empty((axes.shape[0], m))
    for a, column in enumerate(axes):
        np.take(column, at[:, 0], out=first[a])
    return ChunkRun(rows + offset, vids, coords, at, first_row, first, None,
                    time.thread_time() - c)


def first_hull(run: ChunkRun):
    """(min, max per axis of the first vertices, or None; the run cell count)."""
    if len(run.rows) == 0:
        return None, 0
    return (run.first.min(axis=1), run.first.max(axis=1)), len(run.rows)


def with_codes(run: ChunkRun, lo: np.ndarray, hi: np.ndarray) -> ChunkRun:
    """``run`` with its Morton codes in the box [lo, hi] of every run cell's first
    vertex (the client's codes: :func:`.assign.morton_codes` is element-wise)."""
    return run._replace(codes=morton_codes(run.first, lo[:, None], hi[:, None]))


def _under(codes: np.ndarray, bits: int, depth: int, prefix: int) -> np.ndarray:
    """The rows whose code's top ``depth`` of ``bits`` bits are ``prefix``."""
    if depth == 0:
        return np.arange(len(codes))
    return np.flatnonzero((codes >> np.uint64(bits - depth)) == np.uint64(prefix))


def answer(run: ChunkRun, bits: int, queries: list) -> list:
    """A chunk's answers to a selection round's ``queries`` (:func:`select_boundaries`):
    per ("hist", depth, prefix, step) the sorted distinct next ``step`` bits of the
    codes under the prefix with their counts; per ("keys", depth, prefix) those cells'
    (codes, global cell indices)."""
    out = []
    for kind, depth, prefix, *step in queries:
        at = _under(run.codes, bits, depth, prefix)
        if kind == "keys":
            out.append((run.codes[at], run.rows[at]))
            continue
        shift = np.uint64(bits - depth - step[0])
        bucket = (run.codes[at] >> shift) & np.uint64((1 << step[0]) - 1)
        out.append(np.unique(bucket, return_counts=True))
    return out


def _summed(hists: list):
    """The chunks' sparse histograms summed: (buckets ascending, counts)."""
    buckets = np.concatenate([h[0] for h in hists] + [np.zeros(0, np.uint64)])
    counts = np.concatenate([h[1] for h in hists] + [np.zeros(0, np.int64)])
    keys, inverse = np.unique(buckets, return_inverse=True)
    return keys, np.bincount(inverse.ravel(), weights=counts, minlength=len(keys)
                             ).astype(np.int64)


def select_boundaries(ask, m: int, k: int, bits: int) -> list:
    """The keys (code, global cell index) at the positions ⌈r·m/k⌉, r = 1 … k − 1, of
    the stable Morton order of the m run cells (None where the position is m or more:
    no cell starts that partition), exactly. ``ask(queries)``: every chunk's
    :func:`answer`, in the chunks' order. Each boundary narrows a prefix of its code by
    :data:`STEP` bits a round, counting the cells under it before (``below``), until its
    prefix holds at most :data:`FETCH` cells (or all the bits): then the keys under it,
    sorted, give the boundary. Rounds: about ⌈bits / 16⌉ at most, typically two."""
    want = {r: -(-r * m // k) for r in range(1, k)}
    # per distinct position: [depth, prefix, cells with a smaller code, cells under it]
    state = {p: [0, 0, 0, m] for p in set(want.values()) if p < m}
    found = {}
    while len(found) < len(state):
        groups = sorted({tuple(s[:2]) + (s[3],) for p, s in state.items()
                         if p not in found})
        queries = [("keys", d, pre) if n <= FETCH or d == bits else
                   ("hist", d, pre, min(STEP, bits - d)) for d, pre, n in groups]
        got = ask(queries)
        for q, (d, pre, _n) in enumerate(groups):
            here = [g[q] for g in got]
            for p, s in state.items():
                if p in found or (s[0], s[1]) != (d, pre):
                    continue
                rank = p - s[2]
                if queries[q][0] == "keys":
                    codes = np.concatenate([h[0] for h in here])
                    rows = np.concatenate([h[1] for h in here])
                    order = np.lexsort((rows, codes))[rank]
                    found[p] = (int(codes[order]), int(rows[order]))
                    continue
                step = queries[q][3]
                buckets, counts = _summed(here)
                below = np.cumsum(counts) - counts
                j = int(np.searchsorted(below + counts, rank, side="right"))
                s[:] = [d + step, (pre << step) | int(buckets[j]), s[2] + int(below[j]),
                        int(counts[j])]
    return [found.get(want[r]) for r in range(1, k)]


def partition_of(codes: np.ndarray, rows: np.ndarray, boundaries: list) -> np.ndarray:
    """Each cell's partition: how many boundaries (keys of :func:`select_boundaries`)
    its key (code, global cell index) reaches — ``pos·k // m`` (the count of r ≥ 1
    with ⌈r·m/k⌉ ≤ pos)."""
    part = np.zeros(len(codes), dtype=np.int64)
    for b in boundaries:
        if b is None:
            continue
        code, row = np.uint64(b[0]), b[1]
        part += (codes > code) | ((codes == code) & (rows >= row))
    return part
