"""Stage 1 of the face pairs (:mod:`predicates.registration.levels.facepairs`), compiled:
per simulation level, the pairs (f, C) of every face f a cell T owns and every cutting
cell C paired with T whose box is within the level's reach of f's — the exact test of
:mod:`.boxtest` (per axis ``F[lo_b − hi_a] ≤ pad`` and ``F[lo_a − hi_b] ≤ pad``), the
same pairs as the numpy owned-table expansion, listed per run of cell pairs sharing T,
face by face.

The faces' boxes are folded from the coordinates of T's own vertices, read once per run
for every level: a face owned by T is T's vertices at one combination of its columns
(the complex's face map lists a cell's faces in the order of
``itertools.combinations``, and every row ascends), so its vertices are those of its
row of the level's simplices, in the same order, and the minimum/maximum fold is the
same — without a gather of the face's row and of its vertices per face (W1: 182 k faces,
~3 ms of gathers; benchmarks/README.md, "W1's broad phase, complexes and stage 1").
A face whose box the run's envelope shows within reach of every cell of the run, or of
none, skips the tests (the same answers: x − b and a − y are monotone; benchmarks/
README.md, "W1's validation, complexes, stage 1 and hits' order").
"""
from __future__ import annotations

import itertools

import numpy as np
from numba import njit

from .build import INLINE_OPTIONS, JIT_OPTIONS

__all__ = ["owned_levels"]

_NO_FACES = np.zeros(1, dtype=np.int64)
_NO_COLUMNS = np.zeros(1, dtype=np.uint8)


@njit(**INLINE_OPTIONS)
def _hold_boxes(t, start, cols, combos, V, held):
    """The boxes of the faces cell t owns into ``held`` rows (lo on columns 0–2, hi on
    3–5): face u is the cell's vertices ``combos[cols[u]]`` (``V``: their coordinates,
    rows of the cell's columns), folded by boxes_of's minimum/maximum in that order —
    exact, the same boxes (up to a zero's sign, which no box test sees)."""
    e0 = start[t]  # t unsigned (the caller's): no wraparound test
    w = combos.shape[1]
    for u in range(start[t + np.uint64(1)] - e0):
        k = np.uint64(cols[e0 + u])
        if w == 3:  # (a triangle's, an edge's fold written out: no inner trip count)
            i, j, m = np.uint64(combos[k, 0]), np.uint64(combos[k, 1]), np.uint64(combos[k, 2])
            for ax in range(V.shape[1]):
                a = b = V[i, ax]
                x = V[j, ax]
                a = a if (a < x) | (a != a) else x  # np.minimum: a NaN propagates
                b = b if (b > x) | (b != b) else x
                x = V[m, ax]
                a = a if (a < x) | (a != a) else x
                b = b if (b > x) | (b != b) else x
                held[u, ax], held[u, 3 + ax] = a, b
            continue
        if w == 2:
            i, j = np.uint64(combos[k, 0]), np.uint64(combos[k, 1])
            for ax in range(V.shape[1]):
                a = b = V[i, ax]
                x = V[j, ax]
                a = a if (a < x) | (a != a) else x
                b = b if (b > x) | (b != b) else x
                held[u, ax], held[u, 3 + ax] = a, b
            continue
        for ax in range(V.shape[1]):
            a = b = V[np.uint64(combos[k, 0]), ax]
            for v in range(1, w):
                x = V[np.uint64(combos[k, v]), ax]
                a = a if (a < x) | (a != a) else x  # np.minimum: a NaN propagates
                b = b if (b > x) | (b != b) else x
            held[u, ax], held[u, 3 + ax] = a, b


@njit(**INLINE_OPTIONS)
def _owned_run(t, C, q0, q1, start, faces, pad, held, run, env, three, out_f, out_c, n):
    """Append (f, C[q]) for each face f cell t owns (boxes in ``held``), then each pair
    q0 ≤ q < q1 of the run sharing t, when f's box is within ``pad`` of cell C[q]'s
    (``run`` row q − q0: lo on columns 0–2, hi on 3–5; axis 2 only if ``three``):
    :func:`.boxtest._near`'s subtractions and comparisons, in its order, written out (a
    loop over the axes was ~40 % slower). Face by face: the fused kernels then fold each
    face's box once per run, not once per pair (benchmarks/README.md, "Part 2,
    eleventh pass")."""
    e0 = start[t]  # t unsigned (the caller's): no wraparound test
    for u in range(start[t + np.uint64(1)] - e0):
        f = faces[e0 + u]
        a0, a1, a2 = held[u, 0], held[u, 1], held[u, 2]
        b0, b1, b2 = held[u, 3], held[u, 4], held[u, 5]
        # every cell of the run passes, or none does, decided from the run's envelope
        # (``env``): x − b and a − y are monotone in x and y, so these are the tests'
        # own answers (a NaN bound makes both False: the tests below decide)
        every = ((env[0] - b0 <= pad) & (a0 - env[3] <= pad)
                 & (env[1] - b1 <= pad) & (a1 - env[4] <= pad))
        none = ((env[6] - b0 > pad) | (a0 - env[9] > pad)
                | (env[7] - b1 > pad) | (a1 - env[10] > pad))
        if three:
            every &= (env[2] - b2 <= pad) & (a2 - env[5] <= pad)
            none |= (env[8] - b2 > pad) | (a2 - env[11] > pad)
        if none:
            continue
        if every:
            for q in range(q0, q1):
                un = np.uint64(n + q - q0)
                out_f[un] = f
                out_c[un] = C[np.uint64(q)]
            n += q1 - q0
            continue
        for q in range(q0, q1):
            r = np.uint64(q - q0)  # unsigned: no wraparound test an index (W1 -1.1 ms)
            ok = ((run[r, 0] - b0 <= pad) & (a0 - run[r, 3] <= pad)
                  & (run[r, 1] - b1 <= pad) & (a1 - run[r, 4] <= pad))
            if three:
                ok &= (run[r, 2] - b2 <= pad) & (a2 - run[r, 5] <= pad)
            # written always, kept when ok: no branch to mispredict (in bounds: n is at
            # most the tests so far, and the outputs hold one slot per test)
            un = np.uint64(n)
            out_f[un] = f
            out_c[un] = C[np.uint64(q)]
            n += ok
    return n


@njit(**INLINE_OPTIONS)
def _envelope(run, m, d, env):
    """The envelope of the run's m cell boxes: per axis the largest lower bound
    (env[ax]), least upper (env[3 + ax]), least lower (env[6 + ax]) and largest upper
    (env[9 + ax]), numpy's NaN-propagating minimum/maximum (a NaN bound: NaN)."""
    for ax in range(d):
        x, y, lo, hi = run[0, ax], run[0, 3 + ax], run[0, ax], run[0, 3 + ax]
        for r in range(1, m):
            a, b = run[r, ax], run[r, 3 + ax]
            x = x if (x > a) | (x != x) else a
            y = y if (y < b) | (y != y) else b
            lo = lo if (lo < a) | (lo != lo) else a
            hi = hi if (hi > b) | (hi != hi) else b
        env[ax], env[3 + ax], env[6 + ax], env[9 + ax] = x, y, lo, hi


@njit(**INLINE_OPTIONS)
def _widest(start):
    most = 1
    for t in range(start.shape[0] - 1):
        most = max(most, start[t + 1] - start[t])
    return most


@njit(**JIT_OPTIONS)
def _owned_levels(T, C, lo_c, hi_c, P, cells, levels, s0, f0, k0, m0, pad0, o0, p0,
                  s1, f1, k1, m1, pad1, o1, p1, s2, f2, k2, m2, pad2, o2, p2, counts):
    """Stage 1 of the first ``levels`` (1–3) levels given, per run of cell pairs
    (T[q], C[q]) sharing T[q]: the cell's vertices read once, its faces' boxes folded
    from them into small arrays, the run's cell boxes copied unless the previous run
    listed the same cells (:func:`_same_cells`), then :func:`_owned_run` per level."""
    three = lo_c.shape[0] == 3
    h0 = np.zeros((_widest(s0), 6))
    h1 = np.zeros((_widest(s1) if levels > 1 else 1, 6))
    h2 = np.zeros((_widest(s2) if levels > 2 else 1, 6))
    V = np.empty((cells.shape[1], P.shape[1]))  # the cell's vertices' coordinates
    n0 = n1 = n2 = 0
    d = lo_c.shape[0]
    run = np.empty((64, 6))  # the run's cell boxes, rows read in sequence
    env = np.zeros(12)  # their envelope (_envelope)
    q0 = r0 = r1 = 0  # [r0, r1): the previous run, whose boxes ``run`` holds
    while q0 < T.shape[0]:
        t, q1 = np.uint64(T[q0]), _run_end(T, q0)  # unsigned: no wraparound test
        if q1 - q0 > run.shape[0]:  # (then longer than the previous run)
            run = np.empty((2 * (q1 - q0), 6))
        if not _same_cells(C, r0, r1, q0, q1):
            for q in range(q0, q1):
                c = np.uint64(C[q])  # unsigned: no wraparound test a gather
                for ax in range(d):
                    run[q - q0, ax], run[q - q0, 3 + ax] = lo_c[ax, c], hi_c[ax, c]
            _envelope(run, q1 - q0, d, env)
        r0, r1 = q0, q1
        for v in range(cells.shape[1]):  # each coordinate converted to binary64 exactly
            p = np.uint64(cells[t, v])
            for ax in range(P.shape[1]):
                V[v, ax] = np.float64(P[p, ax])
        _hold_boxes(t, s0, k0, m0, V, h0)
        n0 = _owned_run(t, C, q0, q1, s0, f0, pad0, h0, run, env, three, o0, p0, n0)
        if levels > 1:
            _hold_boxes(t, s1, k1, m1, V, h1)
            n1 = _owned_run(t, C, q0, q1, s1, f1, pad1, h1, run, env, three, o1, p1, n1)
        if levels > 2:
            _hold_boxes(t, s2, k2, m2, V, h2)
            n2 = _owned_run(t, C, q0, q1, s2, f2, pad2, h2, run, env, three, o2, p2, n2)
        q0 = q1
    counts[0], counts[1], counts[2] = n0, n1, n2


@njit(**INLINE_OPTIONS)
def _same_cells(C, p0, p1, q0, q1):
    """Do the runs [p0, p1) and [q0, q1) list the same cutting cells in the same order?
    (A structured mesh's cells sharing a box get the same run from the join — W1:
    36,680 of 44,016 runs — whose boxes are then not copied again.)"""
    if p1 - p0 != q1 - q0:
        return False
    for r in range(q1 - q0):
        if C[p0 + r] != C[q0 + r]:
            return False
    return True


@njit(**INLINE_OPTIONS)
def _run_end(T, q0):
    """The end of the run of cell pairs sharing T[q0] (T ascends)."""
    q1 = q0 + 1
    while q1 < T.shape[0] and T[np.uint64(q1)] == T[np.uint64(q0)]:  # unsigned: no
        q1 += 1  # wraparound test
    return q1


@njit(**JIT_OPTIONS)
def _owned_counts(T, levels, s0, s1, s2, out):
    """out[k] = the faces the cells T[q] own at level k, summed over q (stage 1's most
    pairs), for the first ``levels`` levels in one pass over the runs of equal T[q]."""
    q0 = 0
    while q0 < T.shape[0]:
        q1 = _run_end(T, q0)
        t = np.uint64(T[q0])  # unsigned: no wraparound test the look-ups (ids ≥ 0)
        u = t + np.uint64(1)
        out[0] += (q1 - q0) * (s0[u] - s0[t])
        if levels > 1:
            out[1] += (q1 - q0) * (s1[u] - s1[t])
        if levels > 2:
            out[2] += (q1 - q0) * (s2[u] - s2[t])
        q0 = q1


def owned_levels(T: np.ndarray, C: np.ndarray, boxes_c: tuple, P: np.ndarray,
                 cells: np.ndarray, levels: list) -> list:
    """Stage 1 for up to three simulation levels in one pass over the cell pairs (T[q],
    C[q]): ``P`` (N, d) the simulation points, ``cells`` (n, k + 1) the rows of its
    top simplices (T's ids: rows of ``cells``, each ascending); per level ``(i, start,
    faces, cols, pad)`` — the level i (< k), the cells' owned-face lists
    (:func:`.boxtest.owned_lists_of` with ``columns``: each face's column in the
    complex's face map, whose faces are the cells' vertices at
    ``combinations(range(k + 1), i + 1)``) and the level's reach. The pairs (f, C[q])
    of every face f that T[q] owns whose box is within pad of C[q]'s (``boxes_c``, (d,
    n) columns) — :func:`.boxtest.owned_pairs` ("a") on the owned table, in another
    order: per run of pairs sharing T[q], face by face, each face with the run's cells
    in order (every kind's registered pairs are sorted before they are kept or
    returned: the same results). Returns [(f, C)] per level."""
    if not 1 <= len(levels) <= 3 or boxes_c[0].shape[0] not in (2, 3):
        raise ValueError(f"owned_levels takes 1 to 3 levels in 2 or 3 dimensions, got "
                         f"{len(levels)} in {boxes_c[0].shape[0]}")
    args, outs = [], []
    most = np.zeros(3, dtype=np.int64)  # per level at most these pairs (one pass, no
    starts = [levels[min(k, len(levels) - 1)][1] for k in range(3)]  # temporaries)
    _owned_counts(T, len(levels), *starts, most)
    width = cells.shape[1]
    for k in range(3):  # the slots past len(levels) are never read
        if k < len(levels):
            i, start, faces, cols, pad = levels[k]
            n = int(most[k])
        else:  # level 0's types: the same argument types
            i, start, faces, cols, pad, n = 0, _NO_FACES, _NO_FACES, _NO_COLUMNS, 0.0, 0
        combos = np.array(list(itertools.combinations(range(width), i + 1)), np.int64)
        # int32 ids when they fit (every face has one owner: ids < len(faces)): half
        # the fresh memory of the run's largest arrays (W4: 5.6 M pairs at level 2)
        ids = np.int32 if len(faces) < 2 ** 31 else np.int64
        out = (np.empty(max(n, 1), dtype=ids), np.empty(max(n, 1), dtype=C.dtype))
        outs.append(out)
        args += [start, faces, np.ascontiguousarray(cols, np.uint8), combos, float(pad),
                 *out]
    counts = np.zeros(3, dtype=np.int64)
    if len(T):
        _owned_levels(T, C, *boxes_c, np.ascontiguousarray(P),
                      np.ascontiguousarray(cells), len(levels), *args, counts)
    # views: the pages past the count were never written (np.empty touches none)
    return [(f[:m], c[:m]) for (f, c), m in zip(outs[:len(levels)], counts)]
