"""Sorted unique rows of vertex ids (the simplicial complexes' faces,
:func:`predicates.registration.levels.complex.unique_rows`; the registered pairs'
final order is :mod:`predicates.compiled.hitorder`),
compiled. The unique rows: one counting pass on the first id (radix n, the number of
vertices), each row inserted into its first id's run on the rest packed into an int64
(a complex's runs are a few rows); pairs of ids by a stamp per second id, sorting
only each run's distinct ones; single ids by flags, with no sort; a stable
least-significant-column counting sort when a run is long or the rest does not pack.
Then one pass marking each row that differs from the previous — which, when a whole
row packs by shifts into an int64 (ids < 2^sh, sh·w ≤ 63), keeps each distinct row
packed, unpacked in sequence after: no gather through the rows (benchmarks/README.md,
"W1's complexes, stage 1 and the plan's sweep, new angles"). The unique rows come
out sorted lexicographically with the same inverse map as numpy's argsort of the packed
keys — one answer, whatever the sort — so the complexes are identical. A complex's
faces are read from its simplices' rows in the kernel (no gathered copy), and its face
tables via a middle level gathered in one pass (docs/design.md, "Compiled candidate
chain"). Also each cell's sorted vertex ranks and the used vertices (``Side``).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["any_flagged", "faces_via", "looked_up", "ranked_rows", "unique_faces", "unique_rows",
           "used_flags"]


@njit(**JIT_OPTIONS)
def _lex_order(rows, n):
    """Stable lexicographic order of the rows (ids < n), column by column from the last
    (each pass a stable counting sort, so earlier columns decide first)."""
    m, w = rows.shape
    order = np.arange(m)
    tmp = np.empty(m, dtype=np.int64)
    count = np.empty(n + 1, dtype=np.int64)
    for c in range(w - 1, -1, -1):
        count[:] = 0
        for i in range(m):
            count[rows[i, c] + 1] += 1
        for v in range(n):
            count[v + 1] += count[v]
        for i in range(m):
            r = order[i]
            v = rows[r, c]
            tmp[count[v]] = r
            count[v] += 1
        order, tmp = tmp, order
    return order


@njit(**JIT_OPTIONS)
def _mark(rows, order, first, inv):
    """Walk the sorted rows: ``first`` the first row of each distinct value, ``inv``
    each row's rank among the distinct values. Returns the number of distinct rows."""
    m, w = rows.shape
    nu = 0
    for i in range(m):
        r = order[i]
        new = i == 0
        if not new:
            p = order[i - 1]
            for c in range(w):
                if rows[r, c] != rows[p, c]:
                    new = True
                    break
        if new:
            first[nu] = r
            nu += 1
        inv[r] = nu - 1
    return nu


#: the longest run of rows sharing a first id that :func:`_by_first` sorts by insertion
_RUN = 64


@njit(**INLINE_OPTIONS)
def _run_starts(rows, combos, n, start):
    """Each first id's run start into ``start`` (n + 1, zeros on entry) for rows
    i·g + p = rows[i, combos[p]]; returns the longest run's length."""
    for r in range(rows.shape[0]):
        for p in range(combos.shape[0]):
            start[np.uint64(rows[r, combos[p, 0]]) + np.uint64(1)] += 1
    most = 0
    for v in range(n):
        most = max(most, start[v + 1])
        start[v + 1] += start[v]
    return most


@njit(**JIT_OPTIONS)
def _by_first(rows, combos, n, sh, start, key, idx, first, inv):
    """Unique rows in one counting pass on the first column: each row placed in its
    first id's run by insertion on the packed rest (``key``: columns 1… as one int64,
    read in sequence) — the run's rows stay a few cache lines, where every column's
    pass of :func:`_lex_order` reads the rows through the order. Row i·g + p is
    rows[i, combos[p]] (g = len(combos): a simplex's faces, not gathered first). Then
    ``first`` and ``inv`` as :func:`_mark` writes them (``inv`` empty: not written) —
    or, ``sh`` > 0 (ids < 2^sh, sh·w ≤ 63), the rest packed by shifts (the same order)
    and ``first`` each distinct row packed whole, for :func:`_unpack`. Returns the
    number of distinct rows, or −1 (nothing written) when a run is longer than ``_RUN``."""
    g, w = combos.shape
    if _run_starts(rows, combos, n, start) > _RUN:
        return -1
    end = start[:n].copy()  # the next free slot of each run
    i = 0  # the row's number: r·g + p
    for r in range(rows.shape[0]):
        for p in range(g):
            v = np.uint64(rows[r, combos[p, 0]])
            q = np.uint64(end[v])  # unsigned: no wraparound test an index
            end[v] = q + np.uint64(1)
            if w == 3 and sh:  # a triangle's rest written out: no inner trip count
                k = (np.int64(rows[r, combos[p, 1]]) << sh) | rows[r, combos[p, 2]]
            elif w == 3:  # (w = 4 written out too: slower)
                k = rows[r, combos[p, 1]] * n + rows[r, combos[p, 2]]
            else:
                k = 0
                for c in range(1, w):
                    k = ((k << sh) | rows[r, combos[p, c]]) if sh else k * n + rows[r, combos[p, c]]
            s = np.uint64(start[v])
            while q > s and key[q - np.uint64(1)] > k:  # strict: equal rows keep order
                key[q] = key[q - np.uint64(1)]
                idx[q] = idx[q - np.uint64(1)]
                q -= np.uint64(1)
            key[q] = k
            idx[q] = i
            i += 1
    m = i
    nu = 0
    v = 0
    for q in range(m):
        r = np.uint64(idx[q])
        while q >= start[v + 1]:  # q's run: its first id (no read of rows)
            v += 1
        if q == start[v] or key[q] != key[q - 1]:
            # the row itself when it packs: no gather of its columns afterwards
            first[nu] = (np.int64(v) << (sh * (w - 1))) | key[q] if sh else np.int64(r)
            nu += 1
        if inv.shape[0]:
            inv[r] = nu - 1
    return nu


@njit(**JIT_OPTIONS)
def _unpack(first, sh, out):
    """Row u of ``out`` (nu, w): first[u]'s w fields of ``sh`` bits, the first the
    highest (:func:`_by_first`'s and :func:`_pairs_by_first`'s packed rows)."""
    w, mask = out.shape[1], (np.int64(1) << sh) - 1
    for u in range(out.shape[0]):
        x = first[u]
        if w == 2:  # written out: no inner trip count
            out[u, 0], out[u, 1] = x >> sh, x & mask
        elif w == 3:
            out[u, 0], out[u, 1], out[u, 2] = x >> (2 * sh), (x >> sh) & mask, x & mask
        else:
            for c in range(w - 1, -1, -1):
                out[u, c] = x & mask
                x >>= sh


@njit(**JIT_OPTIONS)
def _pairs_by_first(rows, combos, n, sh, start, second, idx, stamp, first, inv):
    """:func:`_by_first` for rows of two ids (a complex's edges): rows put in their first
    id's run unsorted, then per run only its distinct second ids (``stamp[x] == v``: seen
    in run v) sorted by insertion (W1: runs of ≤ ~40 rows, ~7 distinct); ids unsigned (no
    wraparound test). ``first``, ``inv`` as :func:`_mark` (``inv`` empty: not written),
    or, ``sh`` > 0, ``first`` the distinct rows packed (v << sh | x, for
    :func:`_unpack`); −1: a run > 4·``_RUN``."""
    g = combos.shape[0]
    most = _run_starts(rows, combos, n, start)
    if most > 4 * _RUN:  # a hub vertex: its distinct ids' insertion would be quadratic
        return -1
    end = start[:n].copy()  # the next free slot of each run
    i = 0  # the row's number: r·g + p
    for r in range(rows.shape[0]):
        for p in range(g):
            v = np.uint64(rows[r, combos[p, 0]])
            q = np.uint64(end[v])
            end[v] = q + np.uint64(1)
            second[q] = rows[r, combos[p, 1]]
            idx[q] = i
            i += 1
    ids = np.empty(most, dtype=np.int64)  # the run's distinct second ids, sorted
    nu = 0
    for v in range(n):
        d = 0
        for q in range(np.uint64(start[v]), np.uint64(start[v + 1])):
            x = np.uint64(second[q])
            if stamp[x] != v:
                stamp[x] = v
                u = d
                while u > 0 and ids[u - 1] > x:
                    ids[u] = ids[u - 1]
                    if not sh:
                        first[nu + u] = first[nu + u - 1]
                    u -= 1
                ids[u] = x
                if not sh:
                    first[nu + u] = idx[q]
                d += 1
        for u in range(d):  # each distinct id's rank, through its stamp
            stamp[ids[u]] = -2 - nu - u  # (v ≥ 0 never equals it; reset by the next run)
            if sh:  # the row itself: no gather of its columns afterwards
                first[nu + u] = (np.int64(v) << sh) | ids[u]
        if inv.shape[0]:
            for q in range(np.uint64(start[v]), np.uint64(start[v + 1])):
                inv[np.uint64(idx[q])] = -2 - stamp[np.uint64(second[q])]
        nu += d
    return nu


@njit(**JIT_OPTIONS)
def _by_flags(rows, combos, n, seen, rank, ids, inv):
    """Unique single ids (w = 1; row r·g + p is rows[r, combos[p, 0]]): flagged, then
    numbered in ascending order into ``ids`` — the sorted unique rows and the map with
    no sort. Returns their number."""
    g = combos.shape[0]
    for r in range(rows.shape[0]):
        for p in range(g):
            seen[np.uint64(rows[r, combos[p, 0]])] = True
    nu = 0
    for v in range(n):
        if seen[v]:
            rank[v] = nu
            ids[nu] = v
            nu += 1
    i = 0
    for r in range(rows.shape[0] if inv.shape[0] else 0):
        for p in range(g):
            inv[i] = rank[np.uint64(rows[r, combos[p, 0]])]
            i += 1
    return nu


@njit(**JIT_OPTIONS)
def _gather(rows, combos, first, out):
    # row numbers unsigned, divided by a constant for g = 1–4 (a multiply and shifts, not
    # a 64-bit division a row: W1's gathers ~25 % faster; benchmarks/README.md)
    g = combos.shape[0]
    for u in range(out.shape[0]):
        i = np.uint64(first[u])
        r = (i if g == 1 else i // np.uint64(2) if g == 2 else i // np.uint64(3) if g == 3
             else i // np.uint64(4) if g == 4 else i // np.uint64(g))
        p = i - r * np.uint64(g)  # one division, not two (its remainder by a product)
        for c in range(out.shape[1]):
            out[u, c] = rows[r, combos[p, c]]


def unique_faces(rows: np.ndarray, combos: np.ndarray, n: int, inverse: bool = True):
    """:func:`unique_rows` of ``rows[:, combos].reshape(-1, w)`` (ids < n; row i·g + p
    the columns combos[p] of rows[i]: a complex's faces of its simplices) without
    gathering them first: by :func:`_by_first` when the rest of a row packs into an
    int64 and no first id starts more than ``_RUN`` rows (W1's 176 k triangles 6.7 ->
    3.7 ms), pairs of ids by :func:`_pairs_by_first` (300 k edges 8.0 -> 3.2 ms), single
    ids by flags, else by :func:`_lex_order` — the same rows and map either way. When a
    whole row packs into an int64 by shifts, the kernels write each distinct row packed
    and :func:`_unpack` writes the rows in sequence: no gather through the rows (W1's
    complexes ~1.2 ms; benchmarks/README.md, "s23-w1"). ``inverse`` False: the map is
    not made (None; the simulation's distinct cells)."""
    rows, combos = np.ascontiguousarray(rows), np.ascontiguousarray(combos, dtype=np.int64)
    g, w = combos.shape
    m = len(rows) * g
    inv = np.empty(m if inverse else 0, dtype=np.int64)
    if w == 1:
        ids = np.empty(n, dtype=rows.dtype)
        nu = _by_flags(rows, combos, n, np.zeros(n, bool), np.empty(n, np.int64), ids, inv)
        return ids[:nu].reshape(nu, 1).copy(), (inv if inverse else None)
    sh = max(1, int(n - 1).bit_length())  # ids < 2^sh
    sh = sh if sh * w <= 63 else 0  # a whole row by shifts in an int64, else as before
    first, nu = np.empty(m, dtype=np.int64), -1
    if w == 2:
        ids = np.int32 if max(n, m) < 2 ** 31 else np.int64  # the scatter: fewer pages
        nu = _pairs_by_first(rows, combos, n, sh, np.zeros(n + 1, np.int64), np.empty(m, ids),
                             np.empty(m, ids), np.full(n, -1, np.int64), first, inv)
    elif sh or int(n) ** (w - 1) < 2 ** 62:
        # int32 keys and row numbers when they fit: the runs' scatter touches half the
        # bytes (the same comparisons: the packed rest is exact either way)
        small = (sh * (w - 1) <= 31 if sh else int(n) ** (w - 1) < 2 ** 31) and m < 2 ** 31
        key = np.empty(m, np.int32 if small else np.int64)
        idx = np.empty(m, np.int32 if small else np.int64)
        nu = _by_first(rows, combos, n, sh, np.zeros(n + 1, np.int64), key, idx, first, inv)
    out = np.empty((max(nu, 0), w), dtype=rows.dtype)
    if nu >= 0 and sh:
        _unpack(first, sh, out)
        return out, (inv if inverse else None)
    if nu < 0:
        same = g == 1 and np.array_equal(combos[0], np.arange(rows.shape[1]))  # the rows
        flat = rows if same else rows[:, combos].reshape(m, w)
        inv = inv if inverse else np.empty(m, dtype=np.int64)
        nu = _mark(flat, _lex_order(flat, n), first, inv)
        out = np.empty((nu, w), dtype=rows.dtype)
    _gather(rows, combos, first, out)
    return out, (inv if inverse else None)


def unique_rows(rows: np.ndarray, n: int, inverse: bool = True):
    """(unique rows sorted lexicographically, inverse map) of ``rows`` (ids < n), as
    :func:`predicates.registration.levels.complex.unique_rows` returns them
    (:func:`unique_faces` of the rows themselves; ``inverse`` False: the map None)."""
    rows = np.ascontiguousarray(rows)
    return unique_faces(rows, np.arange(rows.shape[1])[None, :], n, inverse)


@njit(**JIT_OPTIONS)
def _any_flagged(flags, rows, out):
    w = rows.shape[1]
    for r in range(rows.shape[0]):  # ids unsigned: no wraparound test
        if w == 3:  # rows of 3 and 4 written out: no inner trip count (W1's six face
            out[r] = (flags[np.uint64(rows[r, 0])] | flags[np.uint64(rows[r, 1])]  # tables
                      | flags[np.uint64(rows[r, 2])])  # ~0.9 -> 0.6 ms, s23-w1)
        elif w == 4:
            out[r] = (flags[np.uint64(rows[r, 0])] | flags[np.uint64(rows[r, 1])]
                      | flags[np.uint64(rows[r, 2])] | flags[np.uint64(rows[r, 3])])
        else:
            hit = False
            for c in range(w):
                hit |= flags[np.uint64(rows[r, c])]
            out[r] = hit


def any_flagged(flags: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """:func:`predicates.registration.levels.complex.any_flagged` (per row of ids: is
    one of them flagged), compiled: one pass over the rows, no column copies."""
    out = np.empty(len(rows), dtype=bool)
    _any_flagged(flags, rows, out)
    return out


@njit(**JIT_OPTIONS)
def _used_flags(cells, used):
    for r in range(cells.shape[0]):
        for c in range(cells.shape[1]):
            used[cells[r, c]] = True


def used_flags(cells: np.ndarray, n: int) -> np.ndarray:
    """Per vertex id < n: does a row of ``cells`` hold it (``used[cells.ravel()] =
    True``, one pass, no flattened copy)."""
    used = np.zeros(n, dtype=bool)
    _used_flags(np.ascontiguousarray(cells), used)
    return used


@njit(**JIT_OPTIONS)
def _ranked_rows(rank, cells, out):
    w = cells.shape[1]
    if w == 3 or w == 4:  # written out: compare-exchanges (the same sorted values)
        for r in range(cells.shape[0]):
            a, b, c = rank[cells[r, 0]], rank[cells[r, 1]], rank[cells[r, 2]]
            if a > b:
                a, b = b, a
            if b > c:
                b, c = c, b
                if a > b:
                    a, b = b, a
            if w == 4:
                x = rank[cells[r, 3]]
                if c > x:
                    c, x = x, c
                    if b > c:
                        b, c = c, b
                        if a > b:
                            a, b = b, a
                out[r, 3] = x
            out[r, 0], out[r, 1], out[r, 2] = a, b, c
        return
    for r in range(cells.shape[0]):
        for p in range(w):  # insertion sort of a few ranks
            v = rank[cells[r, p]]
            u = p
            while u > 0 and out[r, u - 1] > v:
                out[r, u] = out[r, u - 1]
                u -= 1
            out[r, u] = v


def ranked_rows(rank: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``sorted_rows(rank.take(cells))`` (each cell's vertex ranks, ascending; complex.py)
    in one pass: no gathered copy, no column temporaries — integers, the same rows
    (rows of 3 and 4 sorted by written-out compare-exchanges: W1's 71 k cells 0.31 ->
    0.21 ms, benchmarks/README.md "W1's validation, complexes, stage 1 and hits' order")."""
    out = np.empty(cells.shape, dtype=rank.dtype)
    _ranked_rows(rank, np.ascontiguousarray(cells), out)
    return out


@njit(**JIT_OPTIONS)
def _faces_via(upper, lower, via, local, out):
    for r in range(upper.shape[0]):
        for p in range(via.shape[0]):
            out[r, p] = lower[np.uint64(upper[r, via[p]]), local[p]]


def faces_via(upper: np.ndarray, lower: np.ndarray, via: list, local: list) -> np.ndarray:
    """Column p = ``lower[:, local[p]].take(upper[:, via[p]])`` for every p, stacked
    (:meth:`predicates.registration.levels.complex.Complex._faces_via`'s gathers) in
    one pass: no column temporaries, no stack — integers, the same table."""
    out = np.empty((len(upper), len(via)), dtype=np.result_type(lower, np.int64))
    _faces_via(upper, lower, np.asarray(via, np.int64), np.asarray(local, np.int64), out)
    return out


@njit(**JIT_OPTIONS)
def _looked_up(table, ids, out):
    for i in range(ids.shape[0]):
        out[i] = table[np.uint64(ids[i])]  # unsigned: no wraparound test a gather


def looked_up(table: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """``table.take(ids)`` (ids ≥ 0, any shape; the same values and dtype) in one
    compiled pass over the flat ids: numpy's take tests every index's sign and bound
    (the complexes' vertex tables F[k, 0], W1's 476 k ids 0.44 -> 0.22 ms;
    benchmarks/README.md, "s23-w1")."""
    ids = np.ascontiguousarray(ids)
    out = np.empty(ids.shape, dtype=table.dtype)
    _looked_up(table, ids.reshape(-1), out.reshape(-1))
    return out
