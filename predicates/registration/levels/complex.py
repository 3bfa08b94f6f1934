"""Rank space (step 3 of :mod:`predicates.registration.pipeline`, section 1 of the paper):
each mesh's vertices ordered lexicographically by coordinates, and the simplicial complex
of its cells — every vertex, edge, face (and cell) once, with the map from each simplex
to its faces.

Ordering the vertices of every primitive by coordinates makes the predicates see the
same numbers in the same order whatever the vertex numbering, cell order or orientation.
"""
from __future__ import annotations

import itertools
from math import comb

import numpy as np

__all__ = ["Complex", "Side", "any_flagged", "distinct_lex_order", "lex_order", "packed_keys",
           "row_ids", "single_rows", "sorted_rows", "unique_rows"]


def any_flagged(flags: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Per row of ids (a cell's vertices, a simplex's faces): is one of them flagged —
    ``flags[rows].any(axis=1)`` column by column (``take``; numpy's reduction along
    short rows is ~5x slower)."""
    out = flags.take(rows[:, 0])
    for col in range(1, rows.shape[1]):
        out |= flags.take(rows[:, col])
    return out


def packed_keys(rows: np.ndarray, n: int) -> list:
    """The rows (ids < n) as few int64 keys, the first most significant: consecutive
    columns a, b, c → (a·n + b)·n + c while n^columns < 2^62 — injective and
    order-preserving, so sorting the keys lexicographically sorts the rows."""
    w = rows.shape[1]
    per = 1  # columns per int64 key: n^per < 2^62
    while per < w and n ** (per + 1) < 2 ** 62:
        per += 1
    keys = []
    for start in range(0, w, per):
        key = rows[:, start].astype(np.int64)
        for c in range(start + 1, min(w, start + per)):
            key *= n
            key += rows[:, c]
        keys.append(key)
    return keys


def lex_order(keys: list) -> np.ndarray:
    """``np.lexsort(keys[::-1])`` (the first key most significant; stable), as one
    stable argsort when there is one key."""
    return np.argsort(keys[0], kind="stable") if len(keys) == 1 else np.lexsort(keys[::-1])


def distinct_lex_order(keys: list) -> np.ndarray:
    """:func:`lex_order` of keys whose rows are distinct (a kind's registered pairs: no
    pair twice), the same permutation: with no two rows equal, stability cannot matter.
    One argsort of the first key, then a lexsort of only the rows sharing their first
    key (their positions hold those runs, so sorting them in place finishes the
    order): np.lexsort's every-key stable passes cost ~5x one argsort."""
    first = keys[0]
    order = np.argsort(first)
    if len(keys) == 1 or len(order) < 2:
        return order
    ranked = first.take(order)
    tie = ranked[1:] == ranked[:-1]
    if not tie.any():
        return order
    tied = np.zeros(len(order), dtype=bool)
    tied[1:] |= tie
    tied[:-1] |= tie
    pos = np.flatnonzero(tied)
    rows = order.take(pos)
    order[pos] = rows.take(np.lexsort([k.take(rows) for k in keys[::-1]]))
    return order


#: compare-exchange networks sorting 2, 3, 4 values (optimal for these sizes)
_NETWORKS = {1: (), 2: ((0, 1),), 3: ((0, 1), (1, 2), (0, 1)),
             4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2))}


def sorted_rows(rows: np.ndarray) -> np.ndarray:
    """``np.sort(rows, axis=1)`` for rows of 1–4 ids, by a sorting network over the
    columns (min/max of whole columns: numpy sorts each short row in a call of its
    own, ~5x slower); wider rows by np.sort."""
    w = rows.shape[1]
    if w not in _NETWORKS:
        return np.sort(rows, axis=1)
    cols = [rows[:, c].copy() for c in range(w)]
    for a, b in _NETWORKS[w]:
        low = np.minimum(cols[a], cols[b])
        np.maximum(cols[a], cols[b], out=cols[b])
        cols[a] = low
    out = np.empty_like(rows)
    for c in range(w):
        out[:, c] = cols[c]
    return out


def unique_rows(rows: np.ndarray, n: int, accelerate: bool = False, inverse: bool = True):
    """Unique rows (sorted lexicographically) and the inverse map, for ids < n.
    ``accelerate``: by the compiled counting sort (:mod:`predicates.compiled.rows`; the
    same rows and map) when the id range is not much larger than the rows; there
    ``inverse`` False makes no map (None)."""
    if accelerate and len(rows) and n <= 4 * len(rows) + (1 << 16):
        from predicates.compiled.rows import unique_rows as compiled_unique

        return compiled_unique(rows, n, inverse)
    return _unique_keys(packed_keys(rows, n), rows)


def row_ids(rows: np.ndarray) -> np.ndarray:
    """``np.unique(rows, axis=0, return_inverse=True)[1]`` for rows of non-negative ids:
    each row's rank among the distinct rows in lexicographic order, by packed int64 keys
    (:func:`unique_rows`; np.unique's structured view of the rows sorts ~10x slower)."""
    rows = np.asarray(rows, dtype=np.int64)
    if len(rows) == 0:
        return np.zeros(0, dtype=np.int64)
    return unique_rows(rows, int(rows.max()) + 1)[1]


def single_rows(rows: np.ndarray) -> np.ndarray:
    """(n,) bool: the rows of non-negative ids that occur exactly once (np.unique's
    counts of 1: a mesh's boundary faces among all its cells' faces, sorted)."""
    ids = row_ids(rows)
    return np.bincount(ids)[ids] == 1 if len(ids) else np.zeros(0, dtype=bool)


def _unique_faces(rows: np.ndarray, combos: list, n: int, accelerate: bool):
    """:func:`unique_rows` of the faces ``rows[:, combos]`` (one row per simplex and
    combination); compiled (``accelerate``, as there) without gathering them first."""
    m = len(rows) * len(combos)
    if accelerate and m and n <= 4 * m + (1 << 16):
        from predicates.compiled.rows import unique_faces

        return unique_faces(rows, np.array(combos, dtype=np.int64), n)
    return unique_rows(rows[:, combos].reshape(m, -1), n, accelerate)


def _unique_keys(keys: list, rows: np.ndarray):
    """``np.unique`` of the rows encoded by ``keys`` (lexicographic: the first key
    most significant), with the inverse map, without np.unique's stable (merge) sort or
    its structured view of the rows: equal keys are equal rows, so any representative
    will do, and the unique rows and inverse map are the same."""
    order = np.argsort(keys[0]) if len(keys) == 1 else np.lexsort(keys[::-1])
    new = np.zeros(len(order), dtype=bool)
    new[:1] = True
    for key in keys:
        ks = key[order]
        new[1:] |= ks[1:] != ks[:-1]
    inv = np.empty(len(order), dtype=np.int64)
    inv[order] = np.cumsum(new) - 1
    return rows[order[new]], inv


class Complex:
    """The simplices of a mesh, all dimensions, in rank space.

    ``S[k]`` (n_k, k+1): the k-simplices, rows of increasing rank; ``face(k, j)``
    (n_k, C(k+1, j+1)): indices into ``S[j]`` of the j-faces of each k-simplex.
    """

    def __init__(self, cells: np.ndarray, n: int, unique: bool = False,
                 accelerate: bool = False):
        self.top = cells.shape[1] - 1
        self.accelerate = accelerate
        top = self.top
        self.S = {}
        self.F = {}
        # unique: the caller's cells are already unique_rows' output
        self.S[top] = cells if unique else unique_rows(cells, n, accelerate)[0]
        for k in range(top, 0, -1):
            rows = self.S[k]
            combos = list(itertools.combinations(range(k + 1), k))
            self.S[k - 1], inv = _unique_faces(rows, combos, n, accelerate)
            self.F[k, k - 1] = inv.reshape(len(rows), k + 1)
        # vertices: a rank -> vertex id table (rows ascend, so do their ids): no sort
        vid = np.zeros(n, dtype=np.int64)
        vid[self.S[0][:, 0]] = np.arange(len(self.S[0]))
        for k in range(2, top + 1):
            if accelerate:  # the same table, compiled (no per-id bound test)
                from predicates.compiled.rows import looked_up

                self.F[k, 0] = looked_up(vid, self.S[k])
            else:
                self.F[k, 0] = vid.take(self.S[k])
            for j in range(k - 2, 0, -1):
                self.F[k, j] = self._faces_via(k, j)
                assert self.F[k, j].shape[1] == comb(k + 1, j + 1)

    def _faces_via(self, k: int, j: int) -> np.ndarray:
        """F[k, j] from F[k, k−1] and F[k−1, j]: the j-faces of each k-simplex, ascending.
        A row's vertices ascend and S[j] is sorted lexicographically, so its j-faces'
        ids ascend in the order of ``combinations(range(k + 1), j + 1)``; each is
        looked up in one (k−1)-face holding it (the one without its largest missing
        vertex): gathers of columns, no sort."""
        faces_k = list(itertools.combinations(range(k + 1), k))
        sub_j = list(itertools.combinations(range(k), j + 1))
        via, local = [], []
        for P in itertools.combinations(range(k + 1), j + 1):
            out = max(set(range(k + 1)) - set(P))
            face = tuple(v for v in range(k + 1) if v != out)
            via.append(faces_k.index(face))
            local.append(sub_j.index(tuple(face.index(v) for v in P)))
        upper, lower = self.F[k, k - 1], self.F[k - 1, j]
        if self.accelerate:  # the same gathers in one compiled pass
            from predicates.compiled.rows import faces_via

            return faces_via(upper, lower, via, local)
        return np.stack([lower[:, b].take(upper[:, a]) for a, b in zip(via, local)], axis=1)

    def face(self, k: int, j: int) -> np.ndarray:
        if j == k:
            return np.arange(len(self.S[k]))[:, None]
        return self.F[k, j]


class Side:
    """One mesh in rank space: coordinates by rank (of the vertices the cells use),
    the cells (rows of increasing rank), the simplicial complex of the cells that
    matter (built by :meth:`build`), and the map back to the input's vertex ids."""

    def __init__(self, P: np.ndarray, cells: np.ndarray, accelerate: bool = False):
        # rank only the vertices the cells use (the plan's cells near the cut: a small
        # share of a large mesh's vertices); their relative order is that of ranking
        # all of them, so every complex, simplex order and result is the same
        if accelerate:  # the same flags, order and rows compiled
            from predicates.compiled.pointorder import lex_point_order
            from predicates.compiled.rows import ranked_rows, used_flags

            used = used_flags(cells, len(P))
        else:
            used = np.zeros(len(P), dtype=bool)
            used[cells.ravel()] = True
        vids = np.flatnonzero(used)
        near = P.take(vids, axis=0)  # x primary; ties: ids
        order = vids.take(lex_point_order(near) if accelerate else np.lexsort(near.T[::-1]))
        n = len(order)
        # int32 ranks when they fit: the cells in rank space take half the memory
        rank = np.zeros(len(P), dtype=np.int32 if n < 2 ** 31 else np.int64)
        rank[order] = np.arange(n, dtype=rank.dtype)
        self.order = order  # rank -> input vertex id
        self.n_input = len(P)  # input ids are < n_input (the output's packed keys)
        self.P = np.ascontiguousarray(P.take(order, axis=0))
        # np.sort(axis=1) of the ranks: a sorting network (~5x faster) or compiled
        self.cells = (ranked_rows(rank, cells) if accelerate
                      else sorted_rows(rank.take(cells)))
        self.cx = None
        self.accelerate = accelerate  # complexes by the compiled unique_rows (same rows)

    def build(self, mask):
        """The complex of the cells selected by ``mask`` (all their faces)."""
        self.cx = Complex(self.cells[mask], len(self.P))

    def unique_cells(self, mask: np.ndarray | None = None):
        """The distinct cells selected by ``mask`` (None: all), sorted (rows of ranks)."""
        cells = self.cells if mask is None else self.cells[mask]
        return unique_rows(cells, len(self.P), self.accelerate, inverse=False)[0]

    def build_unique(self, cells):
        """The complex of ``cells``, rows of :meth:`unique_cells` (the top simplices
        are then exactly these rows, in this order)."""
        self.cx = Complex(cells, len(self.P), unique=True, accelerate=self.accelerate)

    def count(self, k):
        return len(self.cx.S[k])

    def coords(self, k, idx):
        """Coordinates (n, k+1, d) of the k-simplices ``idx`` (``take``, not fancy
        indexing: ~3x faster on these gathers, same values)."""
        rows = self.cx.S[k].take(idx, axis=0)
        return self.P.take(rows.ravel(), axis=0).reshape(rows.shape + self.P.shape[1:])

    def ids(self, k, idx):
        return self.order.take(self.cx.S[k].take(idx, axis=0))
