"""The refinement's one pass over all simulation cells (:mod:`.refine`; benchmarks/README.md, "Refinement"): in
blocks of :data:`BLOCK` rows with reused buffers (no temporary the size of the mesh),
it gathers what the marks need from the whole mesh (the smallest and largest box edge,
the binade of the median box edge, the coordinate range) and the cells whose boxes may
meet a query box — a superset, found with one look-up per cell; everything after it
costs O(those cells), not O(the mesh).

**The test.** The reach boxes (each holds every query box refinement can make inside
one input cutting cell) are marked on a grid of cell size h, a power of two, with a
margin of :data:`CAP` + 1 empty cells around them; ``D`` is each grid cell's Chebyshev
distance in cells to a marked one, capped at CAP. A box meeting a reach box R has its
centre ``mid`` within ext/2 of a point y of R (ext: its largest edge; plus roundings
far below a cell, h being at least 2^-40 of every coordinate); y's grid cell is marked,
and f(x) = floor((x − o)/h) is monotone with |f(a) − f(b)| ≤ |a − b|/h + 1 (+ 2^-11),
so ``D[f(mid)] < ext/(2h) + 2.5`` holds for it. Cells whose bound reaches CAP are
tested against the reach boxes directly (:func:`~.broadphase.near_flags`); centres
outside the grid clip to its margin, where D = CAP. A point test (ext = 0) needs
``D[f(mid)] = 0``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from predicates.registration.spatial.blocks import BLOCK  # rows per block: every per-block temporary stays in cache
from predicates.registration.spatial.boxes import box_extent
from predicates.registration.spatial.broadphase import near_flags
from predicates.registration.spatial.gridsums import occupancy

__all__ = ["BLOCK", "CAP", "CellScan", "ReachGrid", "centre_ids", "near_pieces", "none_longer",
           "points_near", "scan_cells", "stats_from"]

CAP = 8  # distances counted up to this many grid cells (cells wider: tested directly)
_MAX_GRID = 1 << 22  # grid cells at most (the distance table: one byte each)


class ReachGrid:
    """Boxes ``lo``, ``hi`` (m, d), finite, m ≥ 1, marked on a grid of at most
    ``budget`` cells (h doubled until it fits: the grid costs a fraction of the pass
    over the cells it serves), h at least ``cell`` (the size of the boxes to be tested:
    wider ones take the direct test); ``D``: the capped Chebyshev distance of every
    grid cell to a marked one (module docstring)."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, budget: int = _MAX_GRID,
                 cell: float = 0.0):
        d = lo.shape[1]
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
            raise ValueError("refine: the cutting mesh's coordinates (and the boxes "
                             "around its cells) must be finite; validate the cutting mesh")
        lo_min = np.array([lo[:, ax].min() for ax in range(d)])
        hi_max = np.array([hi[:, ax].max() for ax in range(d)])
        span = float((hi_max - lo_min).max())
        size = max(float(np.median(box_extent(lo, hi))) / 4, cell)  # a few per box
        mag = float(max(np.abs(lo_min).max(), np.abs(hi_max).max()))
        h = max(size, span * 2.0 ** -12, mag * 2.0 ** -40, np.finfo(np.float64).tiny)
        h = math.ldexp(1.0, math.frexp(h)[1] - 1)  # a power of two: x·(1/h) is exact
        while True:
            self.h, self.s = h, 1.0 / h
            self.o = lo_min - (CAP + 1) * h  # CAP + 1 empty cells below every box
            self.G = np.floor((hi_max - self.o) * self.s).astype(np.int64) + CAP + 2
            if float(np.prod(self.G.astype(float))) <= budget:
                break
            h *= 2
        i0, i1 = self._cells(lo), self._cells(hi)
        occ = occupancy(i0, i1, self.G)[(slice(None, -1),) * d]  # shape reversed(G)
        self.D = _distance(occ).ravel()
        self.stride = np.cumprod(np.concatenate([[1], self.G[:-1]])).astype(np.int64)

    def _cells(self, x):
        i = np.floor((x - self.o) * self.s)
        return np.clip(i, 0, self.G - 1).astype(np.int64)

    def lookup(self, mid_cols, b: int, buf, key) -> np.ndarray:
        """D at the grid cell of each of ``b`` points given by coordinate columns (the
        centres, one float array per axis, each overwritten); ``key`` an int64 buffer."""
        k = key[:b]
        k[:] = 0
        for ax, x in enumerate(mid_cols):
            np.subtract(x, self.o[ax], out=x)
            np.multiply(x, self.s, out=x)
            np.floor(x, out=x)
            np.clip(x, 0, self.G[ax] - 1, out=x)
            buf[:b] = x
            buf[:b] *= self.stride[ax]
            k += buf[:b]
        return self.D[k]


def _distance(occ: np.ndarray) -> np.ndarray:
    """Chebyshev distance (grid cells) of every cell to an occupied one, capped at CAP:
    CAP dilations by one cell along every axis (separable)."""
    D = np.full(occ.shape, CAP, dtype=np.uint8)
    cur = occ.copy()
    for k in range(CAP):
        D[cur & (D == CAP)] = k
        for ax in range(cur.ndim):
            a = np.moveaxis(cur, ax, 0)  # a view: the shifted ORs write into cur
            up = a[:-1].copy()
            a[:-1] |= a[1:]
            a[1:] |= up
    return D


@dataclass
class CellScan:
    """What the marks need from all n simulation cells (:func:`scan_cells`):
    ``ext_min``, ``ext_max`` of the box edges; ``fine``: the median box edge, or when
    cheaper a number in the same binade (only its binade is ever used: it is compared
    with powers of two and passed to frexp); ``mag``: the largest |coordinate|;
    ``near``: ascending ids of the cells whose boxes may meet a reach box (a superset)."""

    n: int
    ext_min: float
    ext_max: float
    fine: float
    mag: float
    near: np.ndarray


def stats_from(n: int, emin: float, emax: float, mag: float, hist: np.ndarray) -> "_Stats":
    """The statistics :func:`scan_cells` gathers, given (e.g. from the plan's summary of
    the same boxes, :mod:`.cellboxes`): the box edges' min, max and biased-exponent
    histogram (of ``box_extent + 0.0``), the largest |coordinate|, the count."""
    st = _Stats()
    st.n, st.emin, st.emax, st.mag, st.hist = n, emin, emax, mag, hist
    return st


def none_longer(boxes, stats) -> bool:
    """Is no cutting cell's box edge (``boxes``: their (lo, hi)) above the least
    simulation box edge of ``stats`` (:func:`stats_from`; False when there are none or
    :func:`scan_cells` would refuse them)? Then the scan reads no cell (its near set is
    needed only below that edge) and round one marks no edge (``refine._can_mark``): the
    refinement is the input mesh, without the reach boxes or the scan (W1: ~0.4 ms,
    benchmarks/README.md "s19-wplan")."""
    if stats is None or stats.n == 0 or not (math.isfinite(stats.emax) and stats.emin >= 0):
        return False
    return not float(box_extent(*boxes).max()) > stats.emin


def scan_cells(lo: np.ndarray, hi: np.ndarray, reach, longest: float = math.inf,
               stats=None) -> CellScan:
    """:func:`_scan`; ``stats`` (:func:`stats_from`, of these boxes): no statistics pass,
    and no pass at all when no cell's box edge is below ``longest`` (the same result:
    the near set, gathered from every block either way, does not depend on where the
    pass starts)."""
    if stats is None or stats.n == 0:
        return _scan(lo, hi, reach, longest)
    if not (math.isfinite(stats.emax) and stats.emin >= 0):
        raise ValueError("refine: the simulation cells' boxes must be finite with "
                         "sim_lo <= sim_hi; validate the simulation mesh's coordinates")
    pieces, big = [], []
    if reach is not None and stats.emin < longest:
        grid = ReachGrid(*reach, _budget(len(lo)), _cell_size(lo, hi))
        # cells held elsewhere (the workers: partition/remote.py) scan there, same grid
        remote = getattr(getattr(lo, "owner", None), "near_pieces", None)
        pieces, big = remote(grid) if remote is not None else near_pieces(grid, lo, hi)
    return _finish(lo, hi, reach, stats, pieces, big)


def near_pieces(grid: "ReachGrid", lo, hi):
    """(pieces, big): ids of the cells that may meet ``grid``'s reach boxes and of those
    too wide for its capped distances (:func:`_near_block`), over every block."""
    n = len(lo)
    pieces, big = [], []
    buf = [np.empty(BLOCK) for _ in range(lo.shape[1] + 2)]
    ib, key = np.empty(BLOCK, dtype=np.int64), np.empty(BLOCK, dtype=np.int64)
    for s0 in range(0, n, BLOCK):
        s1 = min(n, s0 + BLOCK)
        e = box_extent(lo[s0:s1], hi[s0:s1], buf[-1][:s1 - s0], buf[-2][:s1 - s0])
        _near_block(grid, lo, hi, s0, s1, e, buf, ib, key, pieces, big)
    return pieces, big


def _finish(lo, hi, reach, st, pieces, big) -> CellScan:
    """The :class:`CellScan` from the statistics and the near pieces of a scan."""
    near = np.sort(np.concatenate(pieces)) if pieces else np.zeros(0, dtype=np.int64)
    if big:
        big = np.concatenate(big)
        near = np.union1d(near, big[near_flags(lo[big], hi[big], *reach, 0.0, sides="a")[0]])
    fine = st.median_binade()
    if fine is None:  # the two middle box edges straddle binades: the exact median
        fine = float(np.median(box_extent(np.asarray(lo), np.asarray(hi))))
    return CellScan(len(lo), st.emin, st.emax, fine, st.mag,
                    near.astype(np.int64, copy=False))


def _scan(lo: np.ndarray, hi: np.ndarray, reach, longest: float = math.inf) -> CellScan:
    """The pass (module docstring): statistics of all cells' boxes ``lo``, ``hi`` (n, d)
    and the cells that may meet the boxes ``reach`` = (rlo, rhi) (or None: no cell).
    ``longest``: the largest box edge any query can have; the near set is only needed
    when it exceeds the smallest cell box edge (no edge is queried otherwise: its
    marks would need ext > a box edge ≥ ext_min), so it is gathered from the first
    block whose running minimum falls below ``longest`` on (earlier blocks are read
    again only then), and is empty when no block does — one statistics pass when the
    cutting mesh is as fine as the simulation mesh."""
    n = len(lo)
    if n == 0:
        return CellScan(0, 0.0, 0.0, 0.0, 0.0, np.zeros(0, dtype=np.int64))
    grid = None
    st = _Stats()
    pieces, big = [], []
    buf = [np.empty(BLOCK) for _ in range(lo.shape[1] + 2)]
    ib, key = np.empty(BLOCK, dtype=np.int64), np.empty(BLOCK, dtype=np.int64)
    start = 0  # the first block whose near cells were gathered in the pass
    for s0 in range(0, n, BLOCK):
        s1 = min(n, s0 + BLOCK)
        e = st.add(lo[s0:s1], hi[s0:s1], buf[-1][:s1 - s0], buf[-2][:s1 - s0], ib)
        if reach is None or not st.emin < longest:
            continue
        if grid is None:
            grid, start = ReachGrid(*reach, _budget(n), _cell_size(lo, hi)), s0
        _near_block(grid, lo, hi, s0, s1, e, buf, ib, key, pieces, big)
    for s0 in range(0, start, BLOCK):  # blocks read before the near set was needed
        s1 = min(start, s0 + BLOCK)
        e = box_extent(lo[s0:s1], hi[s0:s1], buf[-1][:s1 - s0], buf[-2][:s1 - s0])
        _near_block(grid, lo, hi, s0, s1, e, buf, ib, key, pieces, big)
    return _finish(lo, hi, reach, st, pieces, big)  # near: sorted there


def _near_block(grid, lo, hi, s0, s1, e, buf, ib, key, pieces, big) -> None:
    """Rows [s0, s1) (box edges ``e``): the cells that may meet a reach box into
    ``pieces``, the ones too wide for the grid's capped distances into ``big``."""
    b = s1 - s0
    mids = [_centre(lo[s0:s1, ax], hi[s0:s1, ax], buf[ax][:b]) for ax in range(lo.shape[1])]
    dist = grid.lookup(mids, b, ib, key)
    bound = buf[-2][:b]  # ext/(2h) + 2.5, rounded up (module docstring)
    np.multiply(e, 0.5 * grid.s * (1 + 2.0 ** -40), out=bound)
    bound += 2.5
    wide = bound > CAP - 0.5  # D is capped: such cells are tested directly
    pieces.append(np.flatnonzero((dist < bound) & ~wide) + s0)
    if wide.any():
        big.append(np.flatnonzero(wide) + s0)


def points_near(lo: np.ndarray, hi: np.ndarray, boxes) -> np.ndarray:
    """Ascending ids of the cells whose box centre 0.5·(lo + hi) may lie in one of
    ``boxes`` = (blo, bhi) (a superset; each box's centre tested with one look-up)."""
    grid = ReachGrid(*boxes, _budget(len(lo)))
    remote = getattr(getattr(lo, "owner", None), "centre_ids", None)
    return remote(grid) if remote is not None else centre_ids(grid, lo, hi)


def centre_ids(grid: "ReachGrid", lo, hi) -> np.ndarray:
    """Ascending ids of the cells whose box centre is in a grid cell at distance 0."""
    d = lo.shape[1]
    buf = [np.empty(BLOCK) for _ in range(d)]
    ib, key = np.empty(BLOCK, dtype=np.int64), np.empty(BLOCK, dtype=np.int64)
    pieces = []
    for s0 in range(0, len(lo), BLOCK):
        s1 = min(len(lo), s0 + BLOCK)
        b = s1 - s0
        mids = [_centre(lo[s0:s1, ax], hi[s0:s1, ax], buf[ax][:b]) for ax in range(d)]
        pieces.append(np.flatnonzero(grid.lookup(mids, b, ib, key) == 0) + s0)
    return np.concatenate(pieces) if pieces else np.zeros(0, dtype=np.int64)


def _cell_size(lo, hi) -> float:
    """A quarter of the 90th percentile box edge of up to 4096 evenly spaced cells: a
    grid cell at least that large keeps most cells off the direct test (a box edge up
    to 2·(CAP − 3) grid cells is tested by its centre). A heuristic: any value is sound."""
    ids = np.unique(np.linspace(0, len(lo) - 1, min(len(lo), 4096)).astype(np.int64))
    q = float(np.quantile(box_extent(lo[ids], hi[ids]), 0.9)) / 4
    return q if math.isfinite(q) and q > 0 else 0.0


def _budget(n: int) -> int:
    """Grid cells for a pass over n cells: half of n (at least 2^16, at most
    :data:`_MAX_GRID`), so the grid never dominates the pass."""
    return int(min(_MAX_GRID, max(1 << 16, n // 2)))


def _centre(lo, hi, out):
    """0.5·(lo + hi), the same roundings as the bins' key in :mod:`.refine`."""
    np.add(lo, hi, out=out)
    np.multiply(out, 0.5, out=out)
    return out


class _Stats:
    """Running box-edge statistics of the blocks: min, max, a histogram of the biased
    binary64 exponent (the median's binade), the coordinates' magnitude."""

    def __init__(self):
        self.emin, self.emax, self.mag = np.inf, -np.inf, 0.0
        self.hist = np.zeros(2048, dtype=np.int64)
        self.n = 0

    def add(self, lo, hi, e, tmp, ib) -> np.ndarray:
        """Box edges of one block into ``e`` (the values of :func:`~.boxes.box_extent`)."""
        box_extent(lo, hi, e, tmp)
        e += 0.0  # -0.0 (hi = -0.0, lo = +0.0) to +0.0: its exponent bits are those of 0
        lo_e, hi_e = float(e.min()), float(e.max())
        if not (math.isfinite(hi_e) and lo_e >= 0):  # NaN / inf give a NaN or inf max
            raise ValueError("refine: the simulation cells' boxes must be finite with "
                             "sim_lo <= sim_hi; validate the simulation mesh's coordinates")
        self.emin, self.emax = min(self.emin, lo_e), max(self.emax, hi_e)
        for ax in range(lo.shape[1]):  # lo <= hi: the extremes are min lo and max hi
            self.mag = max(self.mag, -float(lo[:, ax].min()), float(hi[:, ax].max()))
        b = len(e)
        np.right_shift(e.view(np.int64), 52, out=ib[:b])  # e ≥ 0: the biased exponent
        self.hist += np.bincount(ib[:b], minlength=2048)
        self.n += b
        return e

    def median_binade(self):
        """A number in the binade of np.median of the box edges (both middle values in
        one binade of normal numbers), or None when that takes the values themselves."""
        c = np.cumsum(self.hist)
        ranks = {(self.n - 1) // 2, self.n // 2}  # the middle value(s)
        bins = {int(np.searchsorted(c, r, side="right")) for r in ranks}
        if len(bins) != 1 or 0 in bins:  # straddling, or zero / subnormal
            return None
        # the mean of two values in [2^(b-1023), 2^(b-1022)) stays in it (their sum is
        # at most 2^(b-1021) minus two units, and halving is exact)
        return math.ldexp(1.0, bins.pop() - 1023)
