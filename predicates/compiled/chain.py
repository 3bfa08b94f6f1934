"""The compiled candidate chain of one registration kind: gather → predicate → output,
fused in one loop over the candidates (:mod:`predicates.compiled.build`), no temporaries
the size of the batch besides the accepted lanes.

:func:`evaluate` is :meth:`predicates.catalogue.Kind.evaluate` followed by the
selection of the hits, with the same values bit for bit (docs/design.md): the
registration (:mod:`predicates.registration.levels.loop`) calls one or the other.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from predicates.catalogue import _split_weights

from .buffers import buffer as _buffer
from .boxtest import _fill_boxes
from .build import JIT_OPTIONS, kernel

__all__ = ["box_rows", "evaluate", "fused", "point_box_rows", "registered_any",
           "run_predicate"]

_TOL_CACHE: dict = {}


def _tolerance_array(pred, names, tol, dtype) -> np.ndarray:
    """The tolerances ``names`` of ``tol`` as a ``dtype`` array, converted as the numpy
    path converts them (:meth:`predicates.core.Predicate._tolerances_for`)."""
    from fperr.contexts import NumpyContext

    key = (id(tol), names, dtype.name)
    hit = _TOL_CACHE.get(key)
    if hit is not None and hit[0] is tol:
        return hit[1]
    run = NumpyContext(dtype).fresh(len(pred.weight_names), 1)
    conv = pred._tolerances_for(tol, run)
    arr = np.array([conv.values[n] for n in names], dtype=dtype)
    if len(_TOL_CACHE) > 64:
        _TOL_CACHE.clear()
    _TOL_CACHE[key] = (tol, arr)
    return arr


def run_predicate(pred, first: tuple, second: tuple, tol, n_first: int | None = None):
    """The predicate on the lanes ``first = (P, R, I)`` × ``second``: point p of the
    first primitive of lane q is ``P[R[I[q], p]]``. Returns (positions of the hits,
    their weights (hits, k)), as the numpy batch path's ``hit`` and ``weights[hit]``."""
    P1, R1, I1 = first
    P2, R2, I2 = second
    dtype = P1.dtype
    chain, names = kernel(pred, dtype.name, n_first)
    tv = _tolerance_array(pred, names, tol, dtype)
    n = len(I1)
    pos = np.empty(n, dtype=np.int64)
    out = np.empty((n, len(pred.weight_names)), dtype=dtype)
    count = chain(P1, R1, I1, P2, R2, I2, tv, pos, out)
    return pos[:count], out[:count]


def evaluate(kind, sim, cut, s: np.ndarray, c: np.ndarray, tol):
    """Kind ``kind`` on the candidates (s, c) (indices of the sides' i- and
    j-simplices; ``sim``, ``cut``: :class:`~predicates.registration.levels.complex.Side`).
    Returns (s, c, sim weights, cut weights) of the registered pairs."""
    a = (sim.P, sim.cx.S[kind.i], s)
    b = (cut.P, cut.cx.S[kind.j], c)
    first, second = (b, a) if kind.swapped else (a, b)
    pos, w = run_predicate(kind.predicate, first, second, tol)
    w_first, w_second = _split_weights(kind.predicate, w, len(pos))
    sw, cw = (w_second, w_first) if kind.swapped else (w_first, w_second)
    return s.take(pos), c.take(pos), sw, cw


_NO_TAB = np.zeros(2, dtype=np.int64)
_NO_FLAGS = np.zeros(1, dtype=bool)
def fused(kind, sim, cut, F, C, owned, pad: float, boxes: tuple, flags, tol):
    """The fused per-kind chain (:func:`predicates.compiled.emit.fused_lines`) on one
    block of stage-1 pairs (F[q], C[q]): ``owned`` the cutting cells' owned j-faces as
    (start, faces, the most one cell owns) (:func:`~.boxtest.owned_lists_of`; None: the
    cells themselves), ``boxes`` = (P, R, B): the simulation points and
    i-simplices' vertex ids (the kernel computes their boxes), the cutting
    j-simplices' boxes as rows (:func:`box_rows`, :func:`point_box_rows`; a vertex's lane
    reads its point there, :func:`predicates.compiled.emit._cut_points`), ``flags`` =
    (flag_s, flag_c) of the suppression pre-filter or None. Returns (candidates, (s, c, sim weights, cut weights) of the
    registered pairs, (s, c) of the pairs to look up before evaluating them)."""
    pred = kind.predicate
    dtype = sim.P.dtype
    n1 = len(pred.sim)
    run, names = kernel(pred, dtype.name, n1, "fused")
    tv = _tolerance_array(pred, names, tol, dtype)
    a = (sim.P, sim.cx.S[kind.i])
    b = (cut.P, cut.cx.S[kind.j])
    (P1, R1), (P2, R2) = (b, a) if kind.swapped else (a, b)
    n = len(F) * (1 if owned is None else max(1, owned[2]))  # at most this many tested
    out_s, out_c, maybe_s, maybe_c = (_buffer(name, n, np.int64) for name in "scSC")
    out_w = _buffer("w", n, dtype, len(pred.weight_names))
    counts = np.zeros(3, dtype=np.int64)
    fs, fc = (_NO_FLAGS, _NO_FLAGS) if flags is None else flags
    start, faces = (_NO_TAB, _NO_TAB) if owned is None else owned[:2]
    run(F, C, start, faces, owned is not None, float(pad), *boxes, fs, fc,
        flags is not None, kind.swapped, P1, R1, P2, R2, tv, out_s, out_c, out_w, maybe_s,
        maybe_c, counts)
    ncand, nh, nm = (int(x) for x in counts)
    w_first, w_second = _split_weights(pred, out_w[:nh].copy(), nh)
    sw, cw = (w_second, w_first) if kind.swapped else (w_first, w_second)
    return (ncand, (out_s[:nh].copy(), out_c[:nh].copy(), sw, cw),
            (maybe_s[:nm].copy(), maybe_c[:nm].copy()))


@njit(**JIT_OPTIONS)
def _box_rows(lo, hi, out):
    d = lo.shape[0]
    for g in range(lo.shape[1]):
        for a in range(d):
            out[g, a] = lo[a, g]
            out[g, d + a] = hi[a, g]


def box_rows(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The boxes (lo, hi), (d, n) columns each, as (n, 2d) rows (lo, hi) — copies, the
    same values: the fused kernels read a face's box from one row (one or two cache
    lines instead of 2d; W1's triangle_edge kernels −1.7 ms, benchmarks/README.md,
    "W1's fused kernels and kinds (s21-kinds)")."""
    out = np.empty((lo.shape[1], 2 * lo.shape[0]), dtype=np.float64)
    _box_rows(lo, hi, out)
    return out


def point_box_rows(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """:func:`box_rows` of :func:`predicates.compiled.boxtest.boxes` (P, R) in one pass,
    no (d, n) columns between: the same fold, the same bits (the cutting levels whose
    columns nothing else reads; benchmarks/README.md, "W1's fused chain and validation,
    new angles (s24-w1)")."""
    R, d = np.ascontiguousarray(R), P.shape[1]
    out = np.empty((len(R), 2 * d), dtype=np.float64)
    if len(R):  # boxtest's fold itself, writing lo and hi through (d, n) views of the rows
        _fill_boxes(np.ascontiguousarray(P), R, out[:, :d].T, out[:, d:].T)
    return out


@njit(**JIT_OPTIONS)
def _registered_any(s, c, A, a_self, B, b_self, nb, R, in_a, in_b, hit):
    """hit[q] |= some face pair (A's faces of s[q], B's of c[q]; the simplex itself
    when ``*_self``) has its key fa·nb + fb in the sorted keys ``R`` — searched only
    when in_a[fa] and in_b[fb] (every registered key's faces are flagged)."""
    ka = 1 if a_self else A.shape[1]
    kb = 1 if b_self else B.shape[1]
    for q in range(s.shape[0]):
        if hit[q]:
            continue
        for u in range(ka):
            fa = s[q] if a_self else A[s[q], u]
            if not in_a[fa]:  # no registered pair has this face: no key to search
                continue
            for v in range(kb):
                fb = c[q] if b_self else B[c[q], v]
                if not in_b[fb]:
                    continue
                key = fa * nb + fb
                lo, hi = 0, R.shape[0]
                while lo < hi:  # np.searchsorted(R, key), left
                    mid = (lo + hi) >> 1
                    if R[mid] < key:
                        lo = mid + 1
                    else:
                        hi = mid
                if lo < R.shape[0] and R[lo] == key:
                    hit[q] = True
                    break
            if hit[q]:
                break


def registered_any(s: np.ndarray, c: np.ndarray, faces_a, faces_b, nb: int,
                   keys: np.ndarray, hit: np.ndarray, in_a: np.ndarray,
                   in_b: np.ndarray) -> None:
    """:meth:`predicates.registration.levels.loop.Registration._blocked`'s look-up of
    one lower kind, compiled: ``hit[q]`` set when a pair of the faces (tables
    ``faces_a``, ``faces_b``, None: the simplex itself) of (s[q], c[q]) is among the
    registered ``keys`` (sorted fa·nb + fb) — exact integers, the same answer.
    ``in_a``, ``in_b``: per a-face and b-face, True at least for the faces of every
    registered key (the registration's involved flags): a face pair with a face not
    flagged has no key, so it is not searched (W1's triangle_edge: 11,532 pairs, 11
    face pairs each against three lower kinds; benchmarks/README.md, "W1's fused chain
    and validation, new angles (s24-w1)")."""
    none = np.zeros((1, 1), dtype=np.int64)
    _registered_any(s, c, none if faces_a is None else faces_a, faces_a is None,
                    none if faces_b is None else faces_b, faces_b is None, np.int64(nb),
                    keys, in_a, in_b, hit)
