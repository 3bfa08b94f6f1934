"""The query behind the refinement's marks (:mod:`.refine`, docs/resolution.md), answered with a
constant number of look-ups per query: for a query box Q and a threshold e, is

    e > thr > 0,   thr = max(0, max{val_b : box b meets Q})

(closed boxes: ``lo_b <= hi_Q`` and ``lo_Q <= hi_b`` on every axis)? This is the
test :func:`~.broadphase.box_pairs` with pad 0 would decide pair by pair; here it is
decided from counts, exactly (section 4.1's broad phase gives the meaning of "meets").

**Levels.** Each box goes to the level ``h = 2^l`` with ``ext_b < h`` (its largest
box edge, strictly: then the exact edge is < h too, rounding being monotone), at least
``span·2^-20``. A level bins its boxes by the grid cell of their *lower corner*,
``f(x) = floor((x − o)/hg)`` with ``hg ≈ h/2`` (coarsened while the grid would have
more than a few cells per box), a monotone map. Per axis, a box meeting Q has
``lo_Q − h < lo_b ≤ hi_Q``, so its cell lies in the *outer* range
``f(fl(lo_Q − h)) … f(hi_Q)``; a box whose cell lies in the *inner* range
``f(y) + 1 … f(hi_Q) − 1``, ``y ≥ lo_Q − m`` (m: a lower bound of the level's box
edges on that axis), certainly meets Q (``lo_b > y`` gives ``hi_b ≥ lo_b + m ≥ lo_Q``,
and ``lo_b < hi_Q``). Counts of boxes in both ranges come from a summed-area table
(2^d look-ups each), so with vmin, vmax the level's smallest and largest value:

* marked if no level with vmax ≥ e has a box in its outer range, and some level with
  vmin > 0 has one in its inner range;
* not marked if some level with vmin ≥ e has a box in its inner range, or no level with
  vmax > 0 has one in its outer range;
* otherwise (a value straddling e near Q's boundary, or Q only grazing the boxes) the
  boxes of the outer ranges are listed (rows of the grid are contiguous runs of the
  sorted boxes) and tested one by one: thr is then the exact maximum.

Either way the answer is the one of the exact maximum. Building costs O(n + grid cells),
O(n) memory; a query O(levels · 2^d) plus the boxes listed for undecided queries.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.boxes import box_extent
from predicates.registration.spatial.broadphase import cell_entries

__all__ = ["LevelIndex", "max_over_bruteforce"]

_BITS = 20  # grid cell at least span·2^-20: cell indices fit comfortably in int64 keys
_CHUNK = 1 << 20  # grid cells per batch of undecided queries


def max_over_bruteforce(lo, hi, val, qlo, qhi) -> np.ndarray:
    """max(0, max val over the boxes meeting each query box): the reference, O(n·m)."""
    out = np.zeros(len(qlo))
    for i in range(len(qlo)):
        meet = np.all((lo <= qhi[i]) & (qlo[i] <= hi), axis=1)
        if meet.any():
            out[i] = max(0.0, float(val[meet].max()))
    return out


def _cols(red, x) -> np.ndarray:
    """red(x, axis=0) column by column (min / max: exact, the same values; several
    times faster than a reduction over axis 0 of an (n, d) array)."""
    return np.array([red(x[:, ax]) for ax in range(x.shape[1])])


class _Level:
    """The boxes of one level: sorted by the linear key of their lower corner's cell,
    the start of each cell's run (CSR) and a summed-area table of the counts."""

    def __init__(self, lo, hi, val, ids, h: float, per_box: int):
        if len(ids) == len(lo):  # one level: no copy before the sort below
            self.lo, self.hi, self.val = lo, hi, val
        else:
            self.lo, self.hi, self.val = lo[ids], hi[ids], val[ids]
        self.h = h
        self.vmin, self.vmax = float(self.val.min()), float(self.val.max())
        d = lo.shape[1]
        # exact hi − lo ≥ nextafter(fl(hi − lo), 0) (round to nearest): a lower bound
        m = np.array([(self.hi[:, ax] - self.lo[:, ax]).min() for ax in range(d)])
        self.m = np.where(m > 0, np.nextafter(m, 0.0), 0.0)
        self.o, top = _cols(np.min, self.lo), _cols(np.max, self.lo)
        self.lomax, self.himin, self.himax = top, _cols(np.min, self.hi), _cols(np.max, self.hi)
        hg = h / 2
        while True:
            self.hg = hg
            G = self._cell(top, np.full(d, 1 << 40)) + 1
            if float(np.prod(G.astype(float))) <= per_box * len(ids) + 4096:
                break
            hg *= 2
        self.G = G
        c = self._cell(self.lo, G)
        key = self._linear(c)
        order = np.argsort(key, kind="stable")
        self.lo, self.hi, self.val = self.lo[order], self.hi[order], self.val[order]
        ncell = int(np.prod(G))
        cnt = np.bincount(key, minlength=ncell)
        self.start = np.concatenate([[0], np.cumsum(cnt)])
        # per non-empty grid cell (slot): the hull of its boxes' lower and upper corners
        # and their largest value
        nz = np.flatnonzero(cnt)
        st = self.start[nz]
        self.slot = np.full(ncell, -1, dtype=np.int64)
        self.slot[nz] = np.arange(nz.size)
        self.hull = np.stack([red.reduceat(x, st, axis=0) for x, red in
                              [(self.lo, np.minimum), (self.lo, np.maximum),
                               (self.hi, np.minimum), (self.hi, np.maximum)]])
        self.cvmax = np.maximum.reduceat(self.val, st)
        # counts ≤ n: int32 halves the table below 2^31 boxes
        S = np.zeros(tuple(int(g) + 1 for g in G[::-1]),
                     dtype=np.int32 if len(ids) < 1 << 31 else np.int64)
        S[(slice(1, None),) * d] = cnt.reshape(tuple(G[::-1]))
        for ax in range(d):
            np.cumsum(S, axis=ax, out=S)
        self.S = S.ravel()
        # flat strides of S per (our) axis: S's axes are reversed
        self.sstride = np.array([int(np.prod(G[:ax] + 1)) for ax in range(d)], dtype=np.int64)

    def _cell(self, x, G):
        """f(x) clipped to [-1, G]: monotone, and f(lo_b) ∈ [0, G−1] for our boxes."""
        with np.errstate(all="ignore"):
            i = np.floor((x - self.o) / self.hg)
        i[np.isnan(i)] = -1  # a NaN query meets nothing: any range will do
        return np.clip(i, -1, G).astype(np.int64)

    def _linear(self, c):
        key = c[:, -1].copy()
        for ax in range(c.shape[1] - 2, -1, -1):
            key *= self.G[ax]
            key += c[:, ax]
        return key

    def ranges(self, qlo, qhi):
        """Outer and inner cell ranges (a, b) of each query, clipped to the grid
        (empty where a > b on some axis)."""
        G = self.G
        with np.errstate(all="ignore"):
            lo_out = qlo - self.h  # lo_b > lo_Q − h exactly, so lo_b ≥ fl(lo_Q − h)
            y = np.nextafter(qlo - self.m, np.inf)  # ≥ lo_Q − m exactly
        top = self._cell(qhi, G)
        # the level's own hull settles an axis whatever the cells: qlo > max hi_b (no
        # box reaches Q), qlo ≤ min hi_b or qhi ≥ max lo_b (every box does, on that side)
        outer = (np.where(qlo > self.himax, G, np.maximum(self._cell(lo_out, G), 0)),
                 np.minimum(top, G - 1))
        inner = (np.where(qlo <= self.himin, 0, np.maximum(self._cell(y, G) + 1, 0)),
                 np.where(qhi >= self.lomax, G - 1, np.minimum(top - 1, G - 1)))
        return outer, inner

    def count(self, a, b):
        """Boxes whose cell lies in [a, b] per query (0 for empty ranges)."""
        d = a.shape[1]
        empty = np.any(a > b, axis=1)
        a, b = np.clip(a, 0, self.G), np.clip(b, -1, self.G - 1)  # in S's index range
        tot = np.zeros(len(a), dtype=np.int64)
        for corner in range(1 << d):
            flat = np.zeros(len(a), dtype=np.int64)
            sign = 1
            for ax in range(d):
                if corner >> ax & 1:
                    flat += (b[:, ax] + 1) * self.sstride[ax]
                else:
                    flat += a[:, ax] * self.sstride[ax]
                    sign = -sign
            tot += sign * self.S[flat]
        tot[empty] = 0
        return tot

    def max_over(self, qlo, qhi, out) -> None:
        """out = max(out, val of every box of this level meeting the query), exactly:
        per grid cell of the outer range, a cell whose boxes' corner hull shows that all
        of them meet Q adds its largest value, one that shows none does nothing, and the
        boxes of the others are tested one by one. In batches of about ``_CHUNK``
        grid cells."""
        (a, b), _ = self.ranges(qlo, qhi)
        q = np.flatnonzero(np.all(a <= b, axis=1))
        ends = np.cumsum(np.prod(b[q] - a[q] + 1, axis=1))
        i = 0
        while i < q.size:
            j = max(int(np.searchsorted(ends, (ends[i - 1] if i else 0) + _CHUNK)), i + 1)
            r, key = cell_entries(a[q[i:j]], b[q[i:j]], self.G, sort=False)
            qi = q[i:j][r]
            s0, s1 = self.start[key], self.start[key + 1]
            qi, key, s0, s1 = qi[s1 > s0], key[s1 > s0], s0[s1 > s0], s1[s1 > s0]
            sl = self.slot[key]
            h = self.hull[:, sl]
            lq, hq = qlo[qi], qhi[qi]
            every = np.all((h[1] <= hq) & (lq <= h[2]), axis=1)
            some = np.all((h[0] <= hq) & (lq <= h[3]), axis=1)
            np.maximum.at(out, qi[every], self.cvmax[sl[every]])
            part = some & ~every
            qi, s0, n = qi[part], s0[part], (s1 - s0)[part]
            row = np.repeat(np.arange(qi.size), n)
            pos = np.arange(row.size, dtype=np.int64) + np.repeat(s0 - (np.cumsum(n) - n), n)
            qi = qi[row]
            meet = np.all((self.lo[pos] <= qhi[qi]) & (qlo[qi] <= self.hi[pos]), axis=1)
            np.maximum.at(out, qi[meet], self.val[pos[meet]])
            i = j


class LevelIndex:
    """Fixed boxes ``lo``, ``hi`` (n, d) with values ``val`` (n,), all finite binary64,
    queried by other boxes: :meth:`marks` (e > thr > 0) and :meth:`max_over` (thr),
    exactly as the pairwise test would give them. See the module docstring."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, val: np.ndarray, per_box: int = 4):
        lo = np.asarray(lo, dtype=np.float64)
        hi = np.asarray(hi, dtype=np.float64)
        val = np.asarray(val, dtype=np.float64)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.isfinite(val).all()):
            raise ValueError("LevelIndex needs finite boxes and values: validate the "
                             "simulation mesh's coordinates first")
        self.levels: list[_Level] = []
        if len(lo) == 0:
            return
        ext = box_extent(lo, hi)  # column by column: the same values as (hi - lo).max(1)
        span = float((_cols(np.max, hi) - _cols(np.min, lo)).max())
        if not np.isfinite(ext).all() or not np.isfinite(span):
            raise ValueError("LevelIndex: box extents overflow binary64; rescale the input")
        emin = int(np.frexp(max(span * 2.0 ** -_BITS, np.finfo(np.float64).tiny))[1])
        e = np.frexp(ext)[1]  # ext = μ·2^e, μ ∈ [0.5, 1): ext < 2^e
        e = np.where(ext > 0, np.maximum(e, emin), emin)
        for lev in np.unique(e):
            ids = np.flatnonzero(e == lev)
            self.levels.append(_Level(lo, hi, val, ids, float(np.ldexp(1.0, int(lev))), per_box))

    def marks(self, qlo, qhi, qext) -> np.ndarray:
        """Per query: qext > thr > 0 (thr: :meth:`max_over`)."""
        qlo = np.asarray(qlo, dtype=np.float64)
        qhi = np.asarray(qhi, dtype=np.float64)
        e = np.asarray(qext, dtype=np.float64)
        # a NaN corner meets no box (every comparison is false), a NaN e marks nothing
        ok = ~(np.isnan(qlo).any(axis=1) | np.isnan(qhi).any(axis=1) | np.isnan(e))
        yes_block = np.zeros(len(e), dtype=bool)  # a box of value ≥ e may meet Q
        some = np.zeros(len(e), dtype=bool)  # a box of value > 0 certainly meets Q
        no = ~ok  # a box of value ≥ e certainly meets Q (or the query has a NaN)
        maybe = np.zeros(len(e), dtype=bool)  # a box of value > 0 may meet Q
        for lv in self.levels:
            (a, b), (ia, ib) = lv.ranges(qlo, qhi)
            n_out = lv.count(a, b) > 0
            n_in = lv.count(ia, ib) > 0
            yes_block |= n_out & (lv.vmax >= e)
            no |= n_in & (lv.vmin >= e)
            some |= n_in & (lv.vmin > 0)
            maybe |= n_out & (lv.vmax > 0)
        no |= ~maybe
        out = ~yes_block & some & ~no
        rest = np.flatnonzero(~out & ~no)
        if rest.size:
            thr = self.max_over(qlo[rest], qhi[rest])
            out[rest] = (thr > 0) & (e[rest] > thr)
        return out

    def max_over(self, qlo, qhi) -> np.ndarray:
        """max(0, max val over the boxes meeting each query box), exactly."""
        qlo = np.asarray(qlo, dtype=np.float64)
        qhi = np.asarray(qhi, dtype=np.float64)
        out = np.zeros(len(qlo))
        for lv in self.levels:
            lv.max_over(qlo, qhi, out)
        return out
