"""A kind's registered pairs in their final order, compiled (``Registration._output``,
:mod:`predicates.registration.levels.loop`): per pair the simulation and cutting
simplices' input ids, sorted and packed into few int64 keys as
:func:`~predicates.registration.levels.complex.packed_keys` packs them, ordered by
:func:`~predicates.compiled.rows.distinct_lex_order`'s route (the pairs are distinct:
one lexicographic permutation, numpy's), then the id rows gathered in that order
(docs/design.md, "Compiled candidate chain").
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS
from .rows import _order_of

__all__ = ["hits_in_order"]


@njit(**INLINE_OPTIONS)
def _pack_row(S, ids, r, n, per, keys, k0, q, row):
    """keys[k0…, q]: the input ids of simplex row r (``ids[S[r]]``), sorted (in the
    scratch ``row``), packed as
    :func:`~predicates.registration.levels.complex.packed_keys` packs them. Returns the
    next key row."""
    w = S.shape[1]
    for p in range(w):  # insertion sort of a few ids
        v = ids[np.uint64(S[r, p])]
        u = p
        while u > 0 and row[u - 1] > v:
            row[u] = row[u - 1]
            u -= 1
        row[u] = v
    k = k0
    start = 0
    while start < w:  # not range(0, w, per): its trip count divides by per, per row
        stop = min(w, start + per)  # (W1's triangle_edge keys 5.9 -> 2.4 ms)
        key = row[start]
        for col in range(start + 1, stop):
            key = key * n + row[col]
        keys[k, np.uint64(q)] = key
        k += 1
        start = stop
    return k


@njit(**JIT_OPTIONS)
def _hit_keys(S1, ids1, s, n1, per1, S2, ids2, c, n2, per2, keys):
    row = np.empty(S1.shape[1] + S2.shape[1], dtype=np.int64)
    for q in range(s.shape[0]):
        k = _pack_row(S1, ids1, np.uint64(s[q]), n1, per1, keys, 0, q, row)
        _pack_row(S2, ids2, np.uint64(c[q]), n2, per2, keys, k, q, row)


@njit(**JIT_OPTIONS)
def _ids_in_order(S, ids, s, order, out):
    for q in range(order.shape[0]):
        r = np.uint64(s[np.uint64(order[q])])  # unsigned: no wraparound test a gather
        for p in range(S.shape[1]):
            out[q, p] = ids[np.uint64(S[r, p])]


def _per_key(n: int, w: int) -> int:
    """Columns per int64 key (complex.packed_keys' rule: n^per < 2^62)."""
    per = 1
    while per < w and n ** (per + 1) < 2 ** 62:
        per += 1
    return per


def hits_in_order(first: tuple, second: tuple) -> tuple:
    """A kind's registered pairs in their final order (loop._output), compiled: per
    side ``(S, ids, s, n)`` (the simplices' rank rows, rank -> input id, the pairs'
    simplices, the input id bound). Returns (order, the first side's input id rows,
    the second's) in that order — the keys of packed_keys(sorted rows) and
    :func:`distinct_lex_order`'s permutation, without the unordered id rows, their
    sorted copies or the key list (a large kind's hits: ~4x their size in fresh
    memory less)."""
    (S1, ids1, s, n1), (S2, ids2, c, n2) = first, second
    per1, per2 = _per_key(n1, S1.shape[1]), _per_key(n2, S2.shape[1])
    nk = -(-S1.shape[1] // per1) - (-S2.shape[1] // per2)
    keys = np.empty((nk, len(s)), dtype=np.int64)
    _hit_keys(S1, ids1, s, np.int64(n1), per1, S2, ids2, c, np.int64(n2), per2, keys)
    order = _order_of(keys)
    out1 = np.empty((len(s), S1.shape[1]), dtype=np.int64)
    out2 = np.empty((len(s), S2.shape[1]), dtype=np.int64)
    _ids_in_order(S1, ids1, s, order, out1)
    _ids_in_order(S2, ids2, c, order, out2)
    return order, out1, out2
