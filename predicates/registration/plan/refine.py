"""Conforming refinement of a cutting mesh that is coarse relative to the simulation
cells it meets (docs/resolution.md; it keeps L of Algorithms 1 and 6 at the simulation mesh's
scale near the cut, section 4.1).

A cutting edge is *marked* when its bounding-box edge exceeds the largest bounding-box
edge of the simulation cells whose boxes meet its own box enlarged by that same extent
(the cells it meets or nearly meets). Marked edges are split at their midpoints; in 3D
the triangles are split by longest-edge templates (the longest edge of a triangle with
any marked edge is marked too, so 1, 2 or 3 marked edges give 2, 3 or 4 children, each
a bisection of a bisection: angles stay bounded), in 2D segments are halved. Every
split edge gets ONE new vertex shared by both triangles on it: the mesh stays conforming
(a hanging midpoint, rounded, would not lie on the neighbour's edge and would open a gap
in the cutting surface). Rounds repeat until no edge is marked. An edge that was not
marked never is (its geometry and the simulation mesh do not change), so each round
tests only the edges it created, against one index over the simulation cells (and one
over their bins per size class) built once per run (:mod:`.refine_index`): a test is
decided from summed-area counts of the boxes that certainly / possibly meet the query,
a constant number of look-ups, and only the rare undecided ones look at boxes. The
marks are exactly those of the pairwise test. The simulation mesh is read once, in
blocks (:mod:`.refine_scan`: box-edge statistics and the cells near the cut), and the
indexes hold only cells that can matter: a run costs that pass plus O(cells created +
cells near the cut) (benchmarks/README.md, "Refinement").

Midpoints are 0.5·a + 0.5·b in binary64, then rounded to the working dtype: the refined
surface lies within one rounding of the input surface, and the guarantees of the paper
hold for the refined mesh (its coordinates are the ones registered). Input vertices keep
their ids (new vertices are appended), ``cut_origin[r]`` is the input cell a refined
cell came from and ``bary[r]`` the refined cell's vertices in barycentric coordinates
of that input cell (dyadic rationals, exact up to the midpoint rounding):
:meth:`Refinement.input_weights` maps registered cutting primitives and weights back.
The refinement depends only on the geometry (ties are broken by coordinates), not on
vertex numbering, cell order or orientation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fperr.warnings import ResolutionError

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.boxes import box_extent, boxes_of
from predicates.registration.levels.complex import unique_rows
from predicates.registration.plan.refine_index import LevelIndex
from predicates.registration.plan.refine_scan import none_longer, points_near, scan_cells

__all__ = ["MAX_CELLS", "Refinement", "refine"]

#: refuse to create more refined cutting cells than this (memory), see :func:`refine`
MAX_CELLS = 20_000_000
_SLOTS = {2: [(0, 1)], 3: [(0, 1), (1, 2), (2, 0)]}


@dataclass
class Refinement:
    """The refined cutting mesh and its map back to the input.

    ``points`` (N', d) in the working dtype, the input points first (same ids);
    ``cells`` (M', k); ``cut_origin`` (M',): input cell of each refined cell;
    ``bary`` (M', k, k): row i = refined vertex i in barycentric coordinates of the input
    cell ``cut_origin``'s vertices (in the input cell's vertex order; a read-only view
    of identity rows when nothing was refined); ``rounds``: split
    rounds run; ``input_cells``: M; ``input_points``: N.
    """

    points: np.ndarray
    cells: np.ndarray
    cut_origin: np.ndarray
    bary: np.ndarray
    rounds: int
    input_cells: int
    input_points: int

    @property
    def refined(self) -> bool:
        return len(self.cells) != self.input_cells

    def input_weights(self, cut_ids, cut_weights):
        """(input cell index (m,), weights (m, k)) for registered cutting primitives
        ``cut_ids`` (m, j+1) (refined vertex ids, e.g. ``res[kind].cut``) with weights
        ``cut_weights``: the same point as barycentric weights on the vertices of the
        input cell ``input_cell`` (``input_cells[input_cell]``), exact up to rounding of
        the midpoints. A primitive on a refined cell shared by several input cells is
        mapped to one of them."""
        ids = np.asarray(cut_ids, dtype=np.int64)
        w = np.asarray(cut_weights, dtype=np.float64)
        k = self.cells.shape[1]
        owner = {}
        for r, cell in enumerate(self.cells.tolist()):  # faces -> one refined cell
            for a in range(k):
                owner.setdefault((cell[a],), r)
                for b in range(a + 1, k):
                    owner.setdefault(tuple(sorted((cell[a], cell[b]))), r)
            owner.setdefault(tuple(sorted(cell)), r)
        cell_out = np.empty(len(ids), dtype=np.int64)
        w_out = np.zeros((len(ids), k))
        for m, row in enumerate(ids.tolist()):
            r = owner[tuple(sorted(row))]
            local = [self.cells[r].tolist().index(v) for v in row]
            cell_out[m] = self.cut_origin[r]
            rows = self.bary[r][local]
            acc = w[m, 0] * rows[0]  # summed in a fixed order (not BLAS: docs/design.md)
            for j in range(1, len(local)):
                acc = acc + w[m, j] * rows[j]
            w_out[m] = acc
        return cell_out, w_out


def refine(points: np.ndarray, cells: np.ndarray, sim_lo: np.ndarray, sim_hi: np.ndarray,
           max_cells: int = MAX_CELLS, sim_stats=None, accelerate: bool = False,
           boxes: tuple | None = None) -> Refinement:
    """Refine the cutting mesh (``points`` in the working dtype, ``cells`` (M, k)) where
    its edges are longer than the simulation cells they meet (boxes ``sim_lo``,
    ``sim_hi`` in binary64; ``sim_stats``: their box-edge statistics if known,
    :func:`~.refine_scan.stats_from`). ``accelerate``: the edges' unique rows by the
    compiled counting sort (the same rows and map) and the cells' boxes compiled;
    ``boxes``: the cutting cells' (lo, hi) if the caller has them. See the module
    docstring."""
    k = cells.shape[1]
    P = points  # never written: a refined mesh's points are a new array
    C = cells.astype(np.int64, copy=True)
    origin = np.arange(len(C), dtype=np.int64)
    # identity rows, a read-only view (no bytes) until a split gathers them: an
    # unrefined mesh's map back costs nothing (W4: 23.6 MB held through the run)
    B = np.broadcast_to(np.eye(k), (len(C), k, k))
    if boxes is None and len(C):
        boxes = boxes_of(P, C, Blocks(accelerate=accelerate))
    sim = _SimScale(sim_lo, sim_hi, *_reach(P, C, boxes, accelerate), sim_stats) \
        if len(C) and not none_longer(boxes, sim_stats) else None  # None: no round
    known = np.zeros(0, dtype=np.int64)  # keys of edges already tested (unmarked)
    rounds = 0
    while sim is not None and (rounds or _can_mark(sim)):
        E, slot_edge = _edges(C, k, accelerate)
        keys = E[:, 0] * (1 << 31) + E[:, 1]
        marked = np.zeros(len(E), dtype=bool)
        new = ~np.isin(keys, known)
        marked[new] = _too_long(P, E[new], sim)
        if not marked.any():
            break
        rank = _edge_rank(P, E) if k == 3 else np.zeros(len(E), dtype=np.int64)
        if k == 3:
            marked = _longest_edge_closure(rank, slot_edge, marked)
        known = keys[~marked]
        mid_id = np.full(len(E), -1, dtype=np.int64)
        mid_id[marked] = len(P) + np.arange(int(marked.sum()))
        a, b = P[E[marked, 0]].astype(np.float64), P[E[marked, 1]].astype(np.float64)
        P = np.concatenate([P, (0.5 * a + 0.5 * b).astype(P.dtype)])
        C, origin, B = (_split_segments if k == 2 else _split_triangles)(
            C, origin, B, mid_id[slot_edge], rank[slot_edge])
        rounds += 1
        if len(C) > max_cells or len(P) >= 1 << 31:
            raise ResolutionError(
                f"refining the cutting mesh to the simulation cells it meets would create "
                f"more than {max_cells} cells: the cutting mesh is far coarser than the "
                "simulation mesh over a large area; refine it yourself near the simulation "
                "mesh, or pass refine_cut=False (the result will then warn)")
    return Refinement(P, C, origin, B, rounds, len(cells), len(points))


def _can_mark(sim) -> bool:
    """Can round one mark an edge? Not when no input cutting cell's box edge exceeds
    the smallest simulation cell box edge: an edge's box lies in its cell's box, so
    its box edge is at most the cell's (monotone rounding), and :func:`_too_long`
    marks only edges longer than that smallest edge — no edge list, no queries."""
    return sim.n > 0 and bool(float(sim.cut_ext.max()) > sim.scan.ext_min)


def _edges(C, k, accelerate: bool = False):
    """Unique edges (sorted vertex pairs) and, per cell, the edge id of each slot
    (``accelerate``: :func:`~predicates.registration.levels.complex.unique_rows`')."""
    slots = _SLOTS[k]
    pairs = np.empty((len(C), len(slots), 2), dtype=C.dtype)
    for j, (a, b) in enumerate(slots):  # each pair sorted: min, max (no row sort)
        np.minimum(C[:, a], C[:, b], out=pairs[:, j, 0])
        np.maximum(C[:, a], C[:, b], out=pairs[:, j, 1])
    pairs = pairs.reshape(-1, 2)
    n = int(C.max()) + 1 if C.size else 1
    E, inv = unique_rows(pairs, n, accelerate)
    return E, inv.reshape(len(C), len(slots))


class _SimScale:
    """The simulation cells' boxes and box edges, and coarser proxies of them: for a
    size class g, the cells binned by centre on a grid of size g, each bin one box (the
    union of its cells' boxes) with the largest box edge of its cells. Querying edges of
    box edge ≥ g against the bins costs O(1) pairs per edge instead of one pair per cell
    they span; the scale found is then the largest over a slightly larger region (a
    heuristic of where to refine only: soundness comes from the L computed afterwards).

    Each set of boxes (the cells, or the bins of one class) gets ONE
    :class:`~.refine_index.LevelIndex` per run, queried each round with the new edges
    only: a round costs O(its new edges), not a pass over every simulation cell.

    The whole mesh is read once (:func:`~.refine_scan.scan_cells`: box-edge statistics
    and the cells near the reach boxes ``reach`` = (lo, hi) of the input cutting cells,
    box edges ``cut_ext``); the cells' index and the bins hold only cells that can
    matter, so the marks are those of all cells (:meth:`_binned`)."""

    def __init__(self, lo, hi, reach, cut_ext, stats=None):
        self.lo, self.hi = lo, hi
        self.reach, self.cut_ext = reach, cut_ext
        # no query is longer than the longest input cutting cell's box edge
        self.scan = scan_cells(lo, hi, reach, float(cut_ext.max()) if len(cut_ext) else 0.0,
                               stats)
        self.n, self.fine = self.scan.n, self.scan.fine
        self._cells = None  # (lo, hi, ext) of the cells near the reach boxes
        self._bin_set = None  # (lo, hi, ext, mid) of the cells the bins are built from
        self._extremes = None  # min |centre| > 0, max |centre|: on demand (_exact)
        self._bins = {}
        self._index = {}

    def boxes(self, g: float):
        if g <= self.fine:
            if self._cells is None:
                near = self.scan.near
                lo, hi = self.lo[near], self.hi[near]
                self._cells = lo, hi, box_extent(lo, hi)
            return self._cells
        if g not in self._bins:
            # classes come coarse first: bin the cells once, for the finest class that
            # uses bins (the smallest 4^c above fine: fine < 2^e), and derive the others
            g0 = math.ldexp(1.0, 2 * -(-math.frexp(self.fine)[1] // 2))
            if self.fine > 0 and g0 < g and math.isfinite(g0) and g0 not in self._bins:
                self.boxes(g0)
            finer = max((f for f in self._bins if f < g), default=None)
            if finer is not None and self._exact(finer, g):
                # bins of g are unions of bins of finer: floor(floor(x)/4^j) = floor(x/4^j)
                # and every quotient is exact, so the grouping is the same as from the
                # cells, at the cost of the (fewer) finer bins
                key0, lo0, hi0, ext0 = self._bins[finer]
                key = np.floor(key0 / (g / finer))
            else:
                lo0, hi0, ext0, mid = self._binned()
                key = np.floor(mid / g)
            # min / max are exact: grouping by a sort and reduceat gives the same boxes
            # as any other order of reduction
            u, order, starts = _group(key)
            lo = np.minimum.reduceat(lo0[order], starts, axis=0)
            hi = np.maximum.reduceat(hi0[order], starts, axis=0)
            ext = np.maximum.reduceat(ext0[order], starts)
            self._bins[g] = (u, lo, hi, ext)
        return self._bins[g][1:]

    def _binned(self):
        """(lo, hi, ext, centre) of the cells every class's bins are built from: each
        bin that can meet a query holds ALL its cells, so its box and largest edge are
        those over the whole mesh (bins no query meets change no mark). A bin's cells'
        centres c have equal floor(c/g), so |c − c'| < g (c/g is exact: g is a power of
        two and g ≥ 2^-50·|c|, checked); one of them, c', has its box reaching the query
        box Q on each side, so |c' − Q| ≤ E (E: the largest box edge of all cells) and
        every centre lies within g + E of Q, hence of the reach box holding Q, with
        g ≤ the input cutting cell's box edge (its edges' classes). Otherwise: all cells."""
        if self._bin_set is None:
            E, mag, fine = self.scan.ext_max, self.scan.mag, self.fine
            g0 = math.ldexp(1.0, 2 * -(-math.frexp(fine)[1] // 2)) if fine > 0 else 0.0
            pad = (self.cut_ext + E) * (1 + 2.0 ** -30)  # rounded up: the factor
            with np.errstate(over="ignore", invalid="ignore"):
                blo = np.nextafter(self.reach[0] - pad[:, None], -np.inf)
                bhi = np.nextafter(self.reach[1] + pad[:, None], np.inf)
            if g0 >= mag * 2.0 ** -50 and np.isfinite(blo).all() and np.isfinite(bhi).all():
                ids = points_near(self.lo, self.hi, (blo, bhi))
                lo, hi = self.lo[ids], self.hi[ids]
            else:  # every cell (np.asarray: the plan's boxes may be computed on demand)
                lo, hi = np.asarray(self.lo), np.asarray(self.hi)
            self._bin_set = lo, hi, box_extent(lo, hi), 0.5 * (lo + hi)
        return self._bin_set

    def _exact(self, f: float, g: float) -> bool:
        """Every centre / f and centre / g is exact (normal or zero, finite): scaling by
        a power of two then loses nothing, so the keys of g follow from those of f."""
        tiny = np.finfo(np.float64).tiny
        if self._extremes is None:
            a = np.abs(self._binned()[3])
            self._extremes = (float(a[a > 0].min()) if (a > 0).any() else np.inf,
                              float(a.max()) if a.size else 0.0)
        mmin, mmax = self._extremes
        return bool(mmin / g > tiny and np.isfinite(mmax / f))

    def marks(self, g: float, qlo, qhi, qext):
        """Per query box (edges of class g, box edge ``qext``): is qext > thr > 0, thr
        the largest box edge of the boxes of class g (cells or bins, :meth:`boxes`)
        meeting it (closed boxes)? One :class:`~.refine_index.LevelIndex` per set of
        boxes, built on first use: a constant number of look-ups per query."""
        name = "cells" if g <= self.fine else g
        if name not in self._index:
            lo, hi, ext = self.boxes(g)
            self._index[name] = LevelIndex(lo, hi, ext) if len(lo) else None
        if self._index[name] is None:
            return np.zeros(len(qlo), dtype=bool)  # no box meets any query: thr = 0
        return self._index[name].marks(qlo, qhi, qext)


def _reach(P, C, boxes=None, accelerate: bool = False):
    """Per input cutting cell, a box holding the query box (:func:`_too_long`) of every
    edge refinement can make inside it: midpoints stay in their edge's box (rounding is
    monotone), so an edge's box lies in its cell's box and its box edge is at most the
    cell's; lo − ext and hi + ext are then bounded by the cell's (monotone rounding),
    widened by one ulp and 2^-1000 for halvings of subnormal coordinates. Returns
    ((lo, hi), the cells' box edges); ``boxes``: the cells' (lo, hi) if known;
    ``accelerate``: one compiled pass (:func:`predicates.compiled.cellsums.widened`,
    the same values)."""
    lo, hi = boxes_of(P, C) if boxes is None else boxes
    ext = box_extent(lo, hi)
    tiny = math.ldexp(1.0, -1000)
    if accelerate and lo.dtype == hi.dtype == ext.dtype == np.float64:
        from predicates.compiled.cellsums import widened

        out = np.empty_like(lo), np.empty_like(hi)
        widened(lo, hi, ext, tiny, *out)  # as laid out: no C-ordered copies
        return out, ext
    e = ext[:, None]
    return (np.nextafter(lo - e, -np.inf) - tiny, np.nextafter(hi + e, np.inf) + tiny), ext


def _group(key):
    """The rows of the float integer-valued ``key`` (n ≥ 1) by group: (unique rows,
    sorted; ``order`` listing the rows group by group; ``starts`` of each group in it),
    for ``reduceat``. One int64 sort when the index ranges fit, else a lexsort."""
    k0 = key.min(axis=0)
    span = key.max(axis=0) - k0 + 1
    if (span < 2.0 ** 52).all() and np.prod(span) < 2.0 ** 62:  # exact differences
        lin = np.zeros(len(key), dtype=np.int64)
        for ax in range(key.shape[1]):
            lin = lin * int(span[ax]) + (key[:, ax] - k0[ax]).astype(np.int64)
        order = np.argsort(lin, kind="stable")
        s = lin[order]
        brk = np.flatnonzero(s[1:] != s[:-1]) + 1
    else:
        order = np.lexsort(key.T[::-1])
        s = key[order]
        brk = np.flatnonzero(np.any(s[1:] != s[:-1], axis=1)) + 1
    starts = np.concatenate([[0], brk])
    return key[order[starts]], order, starts


def size_classes(ext: np.ndarray) -> np.ndarray:
    """The size class c of each box edge: 4^c ≤ max(ext, 1e-300) < 4^(c+1), i.e.
    floor(log2(ext)/2), from the binary exponent (frexp: ext = μ·2^e, μ ∈ [1/2, 1), so
    floor(log2 ext) = e − 1) — exact on every machine, where ``np.log2``'s last bit
    (libm or SIMD) could move an edge just below a power of four into the next class."""
    return (np.frexp(np.maximum(ext, 1e-300))[1].astype(np.int64) - 1) // 2


def _too_long(P, E, sim):
    """Marks: box edge of each edge > largest box edge of the simulation cells meeting
    the edge's box enlarged by its own box edge (heuristic scale; soundness comes from
    the L computed afterwards, not from here)."""
    if len(E) == 0 or sim.n == 0:
        return np.zeros(len(E), dtype=bool)
    lo, hi = boxes_of(P, E)
    ext = box_extent(lo, hi)
    marked = np.zeros(len(E), dtype=bool)
    # a mark needs ext > thr > 0, and every threshold (a cell's box edge, or a bin's:
    # the largest of its cells') is at least the smallest cell box edge: edges no longer
    # than that are never marked, so only the others are queried (same marks; a cutting
    # mesh already as fine as the simulation mesh costs one pass)
    todo = np.flatnonzero(ext > sim.scan.ext_min)
    if todo.size == 0:
        return marked
    lo, hi, ext = lo[todo] - ext[todo, None], hi[todo] + ext[todo, None], ext[todo]
    # one query per size class 4^c, against boxes of that class (the cells, or bins of
    # size 4^c: a few huge edges would otherwise pair with every cell they span)
    size_class = size_classes(ext)
    for c in np.unique(size_class):
        sel = np.flatnonzero(size_class == c)
        marked[todo[sel]] = sim.marks(math.ldexp(1.0, 2 * int(c)), lo[sel], hi[sel], ext[sel])
    return marked


def _edge_rank(P, E):
    """Rank of every edge by squared length, ties by its endpoints' coordinates (the
    lexicographically smaller endpoint first): geometry only, never vertex ids."""
    X = P[E].astype(np.float64)
    d2 = ((X[:, 1] - X[:, 0]) ** 2).sum(axis=1)
    first = _lex_less(X[:, 1], X[:, 0])
    lo = np.where(first[:, None], X[:, 1], X[:, 0])
    hi = np.where(first[:, None], X[:, 0], X[:, 1])
    order = np.lexsort([*hi.T[::-1], *lo.T[::-1], d2])
    rank = np.empty(len(E), dtype=np.int64)
    rank[order] = np.arange(len(E))
    return rank


def _lex_less(x, y):
    """Row-wise: x < y lexicographically."""
    less = np.zeros(len(x), dtype=bool)
    eq = np.ones(len(x), dtype=bool)
    for c in range(x.shape[1]):
        less |= eq & (x[:, c] < y[:, c])
        eq &= x[:, c] == y[:, c]
    return less


def _longest_edge_closure(rank, slot_edge, marked):
    """Mark the longest edge (highest rank) of every triangle with a marked edge, until
    stable: the templates then always split a triangle across its longest edge."""
    longest = slot_edge[np.arange(len(slot_edge)), rank[slot_edge].argmax(axis=1)]
    while True:
        need = longest[marked[slot_edge].any(axis=1)]
        if marked[need].all():
            return marked
        marked = marked.copy()
        marked[need] = True


def _split_segments(C, origin, B, mid, rank):
    m = mid[:, 0] >= 0
    keep = ~m
    M = mid[m, 0]
    Bm = B[m]
    Bmid = 0.5 * (Bm[:, 0] + Bm[:, 1])
    C2 = np.concatenate([C[keep], np.stack([C[m, 0], M], 1), np.stack([M, C[m, 1]], 1)])
    B2 = np.concatenate([B[keep], np.stack([Bm[:, 0], Bmid], 1), np.stack([Bmid, Bm[:, 1]], 1)])
    O2 = np.concatenate([origin[keep], origin[m], origin[m]])
    return C2, O2, B2


#: children of a triangle (a, b, c) whose longest edge ab (slot 0) is marked, by which of
#: bc (slot 1), ca (slot 2) are marked; local points 0-2 = a, b, c, 3-5 = mid ab, bc, ca.
#: Every child keeps the parent's orientation.
_TEMPLATES = {
    (False, False): [(0, 3, 2), (3, 1, 2)],
    (True, False): [(0, 3, 2), (3, 1, 4), (3, 4, 2)],
    (False, True): [(0, 3, 5), (5, 3, 2), (3, 1, 2)],
    (True, True): [(0, 3, 5), (5, 3, 2), (3, 1, 4), (3, 4, 2)],
}


def _split_triangles(C, origin, B, mid, rank):
    """Split every triangle with a marked edge by :data:`_TEMPLATES`, after rotating
    its vertices so that its longest edge (marked by the closure) is slot 0."""
    split = (mid >= 0).any(axis=1)
    out_C, out_O, out_B = [C[~split]], [origin[~split]], [B[~split]]
    idx = np.flatnonzero(split)
    Cs, Ms, Bs = C[idx], mid[idx], B[idx]
    r = rank[idx].argmax(axis=1)
    rows = np.arange(len(idx))[:, None]
    roll = (np.arange(3)[None, :] + r[:, None]) % 3
    V, M, Bv = Cs[rows, roll], Ms[rows, roll], Bs[rows, roll]
    loc = np.concatenate([V, M], axis=1)
    Bloc = np.concatenate([Bv, 0.5 * (Bv + Bv[:, [1, 2, 0]])], axis=1)
    for (m1, m2), tmpl in _TEMPLATES.items():
        sel = ((M[:, 1] >= 0) == m1) & ((M[:, 2] >= 0) == m2)
        for t in tmpl:
            out_C.append(loc[sel][:, list(t)])
            out_B.append(Bloc[sel][:, list(t)])
            out_O.append(origin[idx[sel]])
    return np.concatenate(out_C), np.concatenate(out_O), np.concatenate(out_B)
