"""A kind's registered pairs in their final order (``loop._output``), compiled: the
keys packed from each pair's sorted input ids
(:func:`~predicates.registration.levels.complex.packed_keys`), their lexicographic
order (:func:`~predicates.registration.levels.complex.distinct_lex_order`'s
permutation: the rows are distinct, so any exact sort gives it), and the id rows
gathered in that order. The order: the first key by stable least-significant-digit
radix passes (a kind's hits: ~5 passes of 11 bits, no comparison sort) — over the
heads of the runs of hits sharing their simulation simplex when they arrive in runs
(stage 1's order), then expanded — then each run of equal first keys (one simplex met
by a few others) sorted in place by the others (benchmarks/README.md, "W1's kinds
after the fused kernels"). Simplices of 1–3 ids packing into one key a side: each key's
sort and packing written out (benchmarks/README.md, "W1's validation, complexes, stage 1
and hits' order").
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["distinct_lex_order", "hits_in_order", "rows_in_order"]

#: a run of equal first keys longer than this is sorted by np.lexsort (a face met by many)
_SHORT = 32
#: digit bits of the radix passes at most (a pass's counts: 2^11 int64, in L1)
_DIGIT = 11


@njit(**INLINE_OPTIONS)
def _before(keys, x, y):
    """Row x of the (rows, keys) array before row y on keys 1…, lexicographically."""
    for k in range(1, keys.shape[1]):
        if keys[x, k] != keys[y, k]:
            return keys[x, k] < keys[y, k]
    return False


@njit(**JIT_OPTIONS)
def _sort_runs(order, keys, ranked, long_runs):
    """``order`` sorted by keys[:, 0] (``ranked``: keys[:, 0] in that order, read in
    sequence to find the runs): every run of equal first keys of up to _SHORT rows
    sorted by keys 1… in place (insertion); longer runs' (start, end) written to
    ``long_runs`` for the caller. Returns their number."""
    n, nl, i = order.shape[0], 0, 0
    while i < n:
        j = i + 1
        while j < n and ranked[np.uint64(j)] == ranked[np.uint64(i)]:  # (unsigned: no
            j += 1  # wraparound tests, in this loop and the insertion's)
        if j - i > _SHORT:
            long_runs[nl, 0] = i
            long_runs[nl, 1] = j
            nl += 1
        elif j - i > 1:
            for u in range(np.uint64(i + 1), np.uint64(j)):
                x = order[u]
                v = u
                while v > np.uint64(i) and _before(keys, np.uint64(x), np.uint64(order[v - np.uint64(1)])):
                    order[v] = order[v - np.uint64(1)]
                    v -= np.uint64(1)
                order[v] = x
        i = j
    return nl


@njit(**INLINE_OPTIONS)
def _passes(keys, order, ranked, scratch, lo, bits, shift):
    """The stable LSD radix passes of :func:`_radix_first` over bits [shift, bits) of
    key − lo (``bits`` its bit length), ending in (order, ranked)."""
    n = keys.shape[0]
    npass = (bits - shift + _DIGIT - 1) // _DIGIT
    b = (bits - shift + npass - 1) // npass if npass else 0
    mask = (1 << b) - 1
    count = np.zeros((max(npass, 1), 1 << b), dtype=np.int64)
    o1, val, o2, tv = order, ranked, scratch[0], scratch[1]
    if npass % 2:
        o1, val, o2, tv = o2, tv, o1, val
    for q in range(n):
        o1[q] = q
        val[q] = keys[q, 0] - lo
        for p in range(npass):
            count[p, np.uint64(((val[q] >> shift) >> (p * b)) & mask)] += 1
    for p in range(npass):
        acc = 0
        for d in range(1 << b):  # starts of the digits' slots
            t = count[p, d]
            count[p, d] = acc
            acc += t
        for q in range(n):  # stable scatter, carrying the value with the row
            d = np.uint64(((val[q] >> shift) >> (p * b)) & mask)
            at = np.uint64(count[p, d])
            count[p, d] += 1
            tv[at] = val[q]
            o2[at] = o1[q]
        val, tv = tv, val
        o1, o2 = o2, o1


@njit(**INLINE_OPTIONS)
def _low_bits(order, ranked, shift, most):
    """Finish a stable order by the bits above ``shift`` of ``ranked`` (key − lo, in
    that order) into a stable order by the whole value: each run of equal high bits
    sorted by insertion (strict: equal values keep their order). False (the arrays part
    sorted) at a run longer than ``most``: then the passes are redone over every bit."""
    n, i = order.shape[0], 0
    for q in range(1, n):
        if (ranked[q] >> shift) != (ranked[q - 1] >> shift):
            i = q
            continue
        if q - i >= most:
            return False
        x, o, v = ranked[q], order[q], np.uint64(q)
        while v > np.uint64(i) and ranked[v - np.uint64(1)] > x:  # unsigned: no
            ranked[v] = ranked[v - np.uint64(1)]  # wraparound tests
            order[v] = order[v - np.uint64(1)]
            v -= np.uint64(1)
        ranked[v] = x
        order[v] = o
    return True


@njit(**JIT_OPTIONS)
def _radix_first(keys, order, ranked, scratch):
    """``order`` (filled): the rows stably sorted by keys[:, 0], least significant
    digit first over the key's range (key - min), as many passes of up to _DIGIT bits
    as its bit length needs, all the passes' counts in one read; ``ranked`` (filled):
    keys[:, 0] in that order. A key over more than two digits: the passes over its two
    highest only, then each run of equal high bits by insertion on the rest (a kind's
    keys spread: W1's triangle_edge heads 5 passes -> 2; benchmarks/README.md, "W1's
    validation, complexes, stage 1 and hits' order"),
    or, at a run over 2·_SHORT rows, every digit's pass after all. The passes alternate
    between (order, ranked) and the two rows of ``scratch``, ending in (order, ranked):
    no fresh memory (first touches cost as much as the passes here). Exact integer
    passes: the permutation of a stable sort."""
    n = keys.shape[0]
    lo, hi = keys[0, 0], keys[0, 0]
    for q in range(n):
        lo = min(lo, keys[q, 0])
        hi = max(hi, keys[q, 0])
    bits = 0
    while ((hi - lo) >> bits) > 0:  # packed keys < 2^62: no overflow
        bits += 1
    shift = max(bits - 2 * _DIGIT, 0)
    _passes(keys, order, ranked, scratch, lo, bits, shift)
    if shift and not _low_bits(order, ranked, shift, 2 * _SHORT):
        _passes(keys, order, ranked, scratch, lo, bits, 0)
    for q in range(n):
        ranked[q] += lo


@njit(**JIT_OPTIONS)
def _run_heads(s, heads):
    """heads[:m]: where each run of equal consecutive ``s`` starts, heads[m] = len(s).
    Returns m."""
    m = 0
    for q in range(s.shape[0]):
        if q == 0 or s[q] != s[q - 1]:
            heads[m] = q
            m += 1
    heads[m] = s.shape[0]
    return m


@njit(**JIT_OPTIONS)
def _expand(heads, m, order, ranked):
    """The runs (``heads``) in the order order[-m:] of their heads, first keys
    ranked[-m:], expanded in place into order, ranked: each run's rows ascending (what
    a stable pass over every row gives). The writes of the k-th head's run end at or
    before its own slot (each later run holds a row), read before them."""
    n, p = order.shape[0], 0
    for i in range(n - m, n):
        r, key = np.uint64(order[i]), ranked[i]
        for q in range(heads[r], heads[r + np.uint64(1)]):
            order[np.uint64(p)] = q
            ranked[np.uint64(p)] = key
            p += 1


def _order_of(keys: np.ndarray, scratch=None, heads=None) -> np.ndarray:
    """:func:`distinct_lex_order` of a (rows, keys) int64 array: the first key by
    radix passes, runs of equal first keys compiled, the long ones by np.lexsort in
    place (their rows in row order: the radix passes are stable). ``scratch``: (2,
    rows) int64 to use, or None. ``heads`` = (heads, m): runs of rows known to share
    their first key (:func:`_run_heads`: a simulation simplex's hits arrive together),
    radix-sorted by their first rows' keys only, then expanded (W1's triangle_edge:
    34,801 runs for 71,982 hits)."""
    n = len(keys)
    order, ranked = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    scratch = np.empty((2, n), dtype=np.int64) if scratch is None else scratch
    if heads is not None:
        heads, m = heads
        _radix_first(keys[heads[:m], :1], order[n - m:], ranked[n - m:],
                     scratch.reshape(-1)[:2 * m].reshape(2, m))
        _expand(heads, m, order, ranked)
    elif n:
        _radix_first(keys, order, ranked, scratch)
    if keys.shape[1] > 1 and n > 1:
        long_runs = np.empty((n // (_SHORT + 1) + 1, 2), dtype=np.int64)
        for i, j in long_runs[:_sort_runs(order, keys, ranked, long_runs)].tolist():
            run = order[i:j]
            run[:] = run.take(np.lexsort(keys.take(run, axis=0).T[:0:-1]))
    return order


def distinct_lex_order(keys: list) -> np.ndarray:
    """:func:`predicates.registration.levels.complex.distinct_lex_order` (the order of
    np.lexsort with the first key most significant, for distinct rows), compiled."""
    return _order_of(np.ascontiguousarray(np.stack(keys, axis=1), dtype=np.int64))


@njit(**INLINE_OPTIONS)
def _pack_row(S, ids, r, n, per, keys, k0, q, row):
    """keys[q, k0…]: the input ids of simplex row r (``ids[S[r]]``), sorted (in the
    scratch ``row``), packed as
    :func:`~predicates.registration.levels.complex.packed_keys` packs them. Returns the
    next key column."""
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
        keys[np.uint64(q), k] = key
        k += 1
        start = stop
    return k


@njit(**INLINE_OPTIONS)
def _pack_one(S, ids, r, n, w):
    """The one key of simplex row r of 1–3 ids (n^w < 2^62: :func:`_pack_row`'s
    packing), its sorted input ids written out: compare-exchanges in the insertion's
    outcome (the same sorted values), no loops with runtime trip counts."""
    a = ids[np.uint64(S[r, 0])]
    if w == 1:
        return a
    b = ids[np.uint64(S[r, 1])]
    if a > b:
        a, b = b, a
    if w == 2:
        return a * n + b
    x = ids[np.uint64(S[r, 2])]
    if b > x:
        b, x = x, b
        if a > b:
            a, b = b, a
    return (a * n + b) * n + x


@njit(**JIT_OPTIONS)
def _hit_keys(S1, ids1, s, n1, per1, S2, ids2, c, n2, per2, keys):
    row = np.empty(S1.shape[1] + S2.shape[1], dtype=np.int64)
    w1, w2 = S1.shape[1], S2.shape[1]
    if w1 <= 3 and w2 <= 3 and per1 >= w1 and per2 >= w2:  # one key a side
        for q in range(s.shape[0]):
            keys[q, 0] = _pack_one(S1, ids1, np.uint64(s[q]), n1, w1)
            keys[q, 1] = _pack_one(S2, ids2, np.uint64(c[q]), n2, w2)
        return
    for q in range(s.shape[0]):
        k = _pack_row(S1, ids1, np.uint64(s[q]), n1, per1, keys, 0, q, row)
        _pack_row(S2, ids2, np.uint64(c[q]), n2, per2, keys, k, q, row)


@njit(**JIT_OPTIONS)
def _ids_in_order(S, ids, s, order, out):
    w = S.shape[1]
    for q in range(order.shape[0]):
        r = np.uint64(s[np.uint64(order[q])])  # unsigned: no wraparound test a gather
        if w == 1:  # 1–3 ids written out: no inner trip count (W1 ~0.8 -> 0.64 ms, s23-w1)
            out[q, 0] = ids[np.uint64(S[r, 0])]
        elif w == 2:
            out[q, 0], out[q, 1] = ids[np.uint64(S[r, 0])], ids[np.uint64(S[r, 1])]
        elif w == 3:
            out[q, 0], out[q, 1], out[q, 2] = (ids[np.uint64(S[r, 0])], ids[np.uint64(S[r, 1])],
                                               ids[np.uint64(S[r, 2])])
        else:
            for p in range(w):
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
    n, w1, w2 = len(s), S1.shape[1], S2.shape[1]
    nk = -(-w1 // per1) - (-w2 // per2)
    # one block: the keys and the sort's scratch, then (overwritten) the two id
    # rows returned — fresh memory's first touch costs as much as the sort
    work = np.empty(n * max(w1 + w2, nk + 2), dtype=np.int64)
    keys = work[:n * nk].reshape(n, nk)
    _hit_keys(S1, ids1, s, np.int64(n1), per1, S2, ids2, c, np.int64(n2), per2, keys)
    heads = np.empty(n + 1, dtype=np.int64)
    m = _run_heads(s, heads)  # few runs: the radix passes over their heads only
    order = _order_of(keys, work[n * nk:n * (nk + 2)].reshape(2, n), (heads, m) if 4 * m < 3 * n else None)
    out1, out2 = work[:n * w1].reshape(n, w1), work[n * w1:n * (w1 + w2)].reshape(n, w2)
    _ids_in_order(S1, ids1, s, order, out1)
    _ids_in_order(S2, ids2, c, order, out2)
    return order, out1, out2


@njit(**JIT_OPTIONS)
def _rows_in_order(W, order, out):
    w = W.shape[1]
    for q in range(order.shape[0]):
        r = np.uint64(order[q])  # unsigned: no wraparound test a gather
        if w == 2:  # a simplex's weights written out: no inner trip count
            out[q, 0], out[q, 1] = W[r, 0], W[r, 1]
        elif w == 3:
            out[q, 0], out[q, 1], out[q, 2] = W[r, 0], W[r, 1], W[r, 2]
        else:
            for p in range(w):
                out[q, p] = W[r, p]


def rows_in_order(W: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``W.take(order, axis=0)`` (a kind's weights in the pairs' final order, loop._output;
    ``order`` a permutation of W's rows: in range), copied compiled — numpy's take
    copies a short row per call (W1's six kinds ~0.5 -> 0.3 ms; benchmarks/README.md,
    "s23-w1")."""
    W = np.ascontiguousarray(W)
    out = np.empty((len(order),) + W.shape[1:], dtype=W.dtype)
    if len(order):
        _rows_in_order(W.reshape(len(W), -1), order, out.reshape(len(order), -1))
    return out
