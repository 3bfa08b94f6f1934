"""Hierarchical registration of a simulation mesh against a cutting mesh (section 1,
sections 4.1 and 5.1 of the paper).

``intersect(sim_points, sim_cells, cut_points, cut_cells)`` (or two ``meshio.Mesh``, or
two ``(points, cells)`` tuples) registers intersection pairs level by level, from the
most degenerate up, in the paper's order. Kind names read "simulation primitive _
cutting primitive":

* 2D (triangles vs segments): vertex_vertex; vertex_edge, edge_vertex; edge_edge,
  triangle_vertex.
* 3D (tetrahedra vs triangles): vertex_vertex; vertex_edge, edge_vertex; edge_edge,
  vertex_triangle, triangle_vertex; edge_triangle, triangle_edge, tetrahedron_vertex.

A pair is skipped ("degenerate intersection", line 2 of every algorithm) when any pair
of its sub-simplices — faces of either primitive, the primitive itself included, the
pair itself excluded — was registered at a lower level; registered pairs are kept per
kind as sorted int64 keys, so that look-up is a vectorised ``searchsorted``.

How it runs
-----------
1. Validation (:mod:`predicates.mesh_input`): every bad input is rejected up front.
2. Exact power-of-two scaling: coordinates are multiplied by 2^-e so that
   L_a + L_b ∈ [1/2, 1). Every tolerance and every quantity of the predicates (up to
   L⁶ in 3D edge-edge) is then of order one: no overflow, and nothing that matters can
   underflow. Scaling by a power of two is exact, so the registered pairs are exactly
   those of the unscaled input whenever the unscaled run itself neither overflows nor
   underflows — and the scaled run gives them also when it would. Coordinates are never
   *shifted* (translation is inexact): the predicates only use coordinate differences,
   which rule E makes exact to within one rounding whatever the offset, and the rule K
   bound |coord| ≤ L/2 is only used through |x₁ − x₂| ≤ L, true for any pair processed.
   A large common offset (e.g. coordinates near 10⁶ with cells of 10⁻³) is therefore
   handled; an input whose coordinates cannot be scaled exactly (a coordinate would
   become subnormal and lose bits, or overflow) is refused with a clear error.
3. Primitives: unique vertices, edges, faces (and cells) of each mesh — of the cells
   the first broad-phase stage keeps (step 5). Inside every primitive the vertices are
   ordered lexicographically by coordinates, so that the predicates see the same
   numbers in the same order whatever the vertex numbering, the cell order or the
   orientation: the result is invariant under all three.
4. Tolerances (Algorithms 1 and 6) from L_a, L_b, the largest bounding-box edge of any
   cell of each mesh, rounded up (they must be upper bounds).
5. Broad phase (:mod:`predicates.broadphase`): the cells of each mesh sharing a grid
   cell with a cell of the other mesh enlarged by σ+ (a superset of those within σ+),
   then per kind the primitives' boxes within that kind's reach (≤ σ+; see
   ``predicates.catalogue``), tested exactly.
6. Per level, per kind: suppression by registered sub-pairs, then the predicate in
   numpy batch mode on chunks of candidates.

``tolerance_scale=0`` runs the same pipeline with every tolerance zero (the naive
floating-point baseline); the broad phase keeps its robust reach, so the baseline only
differs in the predicates.
"""
from __future__ import annotations

import itertools
import math
import sys
import time
from math import comb

import numpy as np

from .catalogue import kinds as catalogue_kinds
from . import meshes as _meshes  # noqa: F401  (predicates.meshes after import predicates)
from .broadphase import box_pairs, near_flags
from .mesh_input import from_meshio, validate_pair
from .result import IntersectionResult, KindPairs
from .tolerances import tolerances as compute_tolerances

__all__ = ["intersect"]

#: Pairs per predicate batch (bounds the gathered coordinates and temporaries).
CHUNK = 1 << 17


# -- primitives ---------------------------------------------------------------------------
def _unique_rows(rows: np.ndarray, n: int):
    """Unique rows (sorted lexicographically) and the inverse map, for ids < n."""
    w = rows.shape[1]
    if w == 1:
        u, inv = np.unique(rows[:, 0], return_inverse=True)
        return u[:, None], inv.ravel()
    if n ** w < 2 ** 62:
        key = rows[:, 0].astype(np.int64)
        for c in range(1, w):
            key = key * n + rows[:, c]
        _, first, inv = np.unique(key, return_index=True, return_inverse=True)
        return rows[first], inv.ravel()
    u, inv = np.unique(rows, axis=0, return_inverse=True)
    return u, inv.ravel()


class _Complex:
    """The simplices of a mesh, all dimensions, in rank space (see :func:`intersect`).

    ``S[k]`` (n_k, k+1): the k-simplices, rows of increasing rank; ``face(k, j)``
    (n_k, C(k+1, j+1)): indices into ``S[j]`` of the j-faces of each k-simplex.
    """

    def __init__(self, cells: np.ndarray, n: int):
        self.top = cells.shape[1] - 1
        top = self.top
        self.S = {}
        self.F = {}
        self.S[top], _ = _unique_rows(cells, n)
        for k in range(top, 0, -1):
            rows = self.S[k]
            combos = list(itertools.combinations(range(k + 1), k))
            sub = rows[:, combos].reshape(-1, k)
            self.S[k - 1], inv = _unique_rows(sub, n)
            self.F[k, k - 1] = inv.reshape(len(rows), k + 1)
        for k in range(2, top + 1):
            for j in range(k - 2, -1, -1):
                g = self.F[k - 1, j][self.F[k, k - 1]].reshape(len(self.S[k]), -1)
                g.sort(axis=1)
                self.F[k, j] = np.ascontiguousarray(g[:, :: k - j])
                assert self.F[k, j].shape[1] == comb(k + 1, j + 1)

    def face(self, k: int, j: int) -> np.ndarray:
        if j == k:
            return np.arange(len(self.S[k]))[:, None]
        return self.F[k, j]


# -- input handling --------------------------------------------------------------------------
def _parse_args(args):
    if len(args) == 4:
        return args
    if len(args) == 2:
        out = []
        for role, m in zip(("simulation", "cutting"), args):
            if hasattr(m, "points") and hasattr(m, "cells"):
                out.append(m)
            elif isinstance(m, (tuple, list)) and len(m) == 2:
                out.append(tuple(m))
            else:
                raise TypeError(f"the {role} mesh must be a meshio.Mesh or a (points, cells) "
                                f"tuple, got {type(m).__name__}")
        sim, cut = out
        if isinstance(sim, tuple) and isinstance(cut, tuple):
            return (*sim, *cut)
        if isinstance(sim, tuple) or isinstance(cut, tuple):
            raise TypeError("pass both meshes as meshio.Mesh or both as (points, cells)")
        return from_meshio(sim, cut)
    raise TypeError("intersect(sim_points, sim_cells, cut_points, cut_cells) or "
                    f"intersect(sim_mesh, cut_mesh); got {len(args)} positional arguments")


def _max_box_edge(points: np.ndarray, cells: np.ndarray) -> float:
    """Largest bounding-box edge of any cell, in binary64, rounded up one ulp (an upper
    bound of the exact value: hi − lo is correctly rounded)."""
    if len(cells) == 0:
        return 0.0
    X = points.astype(np.float64, copy=False)[cells]
    d = (X.max(axis=1) - X.min(axis=1)).max()
    return float(np.nextafter(d, np.inf)) if d > 0 else 0.0


def _scale(points: np.ndarray, e: int, role: str) -> np.ndarray:
    with np.errstate(all="ignore"):
        out = np.ldexp(points, -e)
        back = np.ldexp(out, e)
    limit = np.finfo(points.dtype).max / 16
    if not (np.isfinite(out).all() and np.all(np.abs(out) <= limit)):
        raise ValueError(f"the {role} coordinates are too large relative to the cells' size "
                         f"(scaling the cells to unit size by 2^{-e} overflows "
                         f"{points.dtype.name}): translate the meshes closer to the origin")
    if not np.array_equal(back, points):
        raise ValueError(f"the {role} coordinates cannot be scaled exactly by 2^{-e} (to "
                         f"unit-size cells): some are so small relative to the cells that "
                         f"they underflow {points.dtype.name}; round them to zero first")
    return out


# -- the registration ----------------------------------------------------------------------
def intersect(*args, dtype=np.float64, tolerance_scale: float = 1.0, progress: bool = False,
              chunk: int = CHUNK) -> IntersectionResult:
    """Register the intersections of a simulation mesh with a cutting mesh.

    ``intersect(sim_points, sim_cells, cut_points, cut_cells)``, ``intersect(sim_mesh,
    cut_mesh)`` (``meshio.Mesh``) or ``intersect((sim_points, sim_cells), (cut_points,
    cut_cells))``. 2D: triangles (M, 3) vs segments (K, 2), points (N, 2); 3D:
    tetrahedra (M, 4) vs triangles (K, 3), points (N, 3). An empty cutting mesh gives an
    empty result.

    ``dtype``: float64 or float32, the working precision (coordinates are converted;
    ``res.rounded_inputs`` says whether that rounded them). ``tolerance_scale``: 1 for the
    robust method, 0 for the naive zero-tolerance baseline (values in [0, 1]).
    ``progress``: a tqdm bar on stderr (shown after one second). Returns an
    :class:`~predicates.result.IntersectionResult`. See the module docstring.
    """
    t0 = time.perf_counter()
    timings = {}
    dtype = np.dtype(dtype)
    ts = float(tolerance_scale)
    if not 0 <= ts <= 1:
        raise ValueError(f"tolerance_scale must be in [0, 1], got {tolerance_scale!r}")
    sp, sc, cp, cc = _parse_args(args)
    dim, sim, cut = validate_pair(sp, sc, cp, cc, dtype)

    # exact power-of-two scaling so that L_a + L_b is in [1/2, 1)
    L_a0 = _max_box_edge(sim.points, sim.cells)
    L_b0 = _max_box_edge(cut.points, cut.cells)
    if L_a0 + L_b0 == 0:
        raise ValueError("every cell of both meshes collapses to a single point (zero "
                         "bounding boxes): the tolerances would be zero")
    e = math.frexp(L_a0 + L_b0)[1]
    P_sim = _scale(sim.points, e, "simulation")
    P_cut = _scale(cut.points, e, "cutting")
    # upper bounds, scaled exactly (compute_tolerances rounds them up into dtype)
    L_a, L_b = math.ldexp(L_a0, -e), math.ldexp(L_b0, -e)
    tol = compute_tolerances(dim, L_a, L_b, dtype=dtype)
    tol_run = tol if ts == 1 else tol.scaled(dtype.type(ts))
    eps = float(np.finfo(dtype).eps)
    kinds = catalogue_kinds(dim)
    reach = {k.name: float(tol.values[k.reach[0]]) * k.reach[1] * (1 + 16 * eps)
             for k in kinds}
    timings["setup"] = time.perf_counter() - t0

    # rank space: vertices ordered lexicographically by coordinates
    t = time.perf_counter()
    reg = _Registration(dim, P_sim, sim.cells, P_cut, cut.cells, tol_run, reach, chunk)
    timings["ranks"] = time.perf_counter() - t
    pairs = reg.run(progress, timings)

    timings["total"] = time.perf_counter() - t0
    return IntersectionResult(
        dim=dim, dtype=dtype, kinds=tuple(k.name for k in kinds), pairs=pairs, tolerances=tol_run, scale_exponent=e,
        tolerance_scale=ts, L_a=L_a0, L_b=L_b0,
        sim_points=sim.points, sim_cells=sim.cells, cut_points=cut.points,
        cut_cells=cut.cells, rounded_inputs=sim.rounded or cut.rounded, timings=timings)


class _Side:
    """One mesh in rank space: coordinates by rank, the cells (rows of increasing
    rank), the simplicial complex of the cells that matter (built by :meth:`build`), and
    the map back to the input's vertex ids."""

    def __init__(self, P: np.ndarray, cells: np.ndarray):
        n = len(P)
        order = np.lexsort(P.T[::-1])  # x primary; ties (equal points) keep id order
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n)
        self.order = order
        self.P = np.ascontiguousarray(P[order])
        self.cells = np.sort(rank[cells], axis=1)
        self.cx = None

    def build(self, mask):
        """The complex of the cells selected by ``mask`` (all their faces)."""
        self.cx = _Complex(self.cells[mask], len(self.P))

    def count(self, k):
        return len(self.cx.S[k])

    def coords(self, k, idx):
        return self.P[self.cx.S[k][idx]]

    def ids(self, k, idx):
        return self.order[self.cx.S[k][idx]]


class _Registration:
    def __init__(self, dim, P_sim, sim_cells, P_cut, cut_cells, tol, reach, chunk):
        self.dim, self.tol, self.reach, self.chunk = dim, tol, reach, chunk
        self.dtype = P_sim.dtype
        self.sim = _Side(P_sim, sim_cells)
        self.cut = _Side(P_cut, cut_cells)
        self.registered = {}  # (i, j) -> sorted int64 keys s * n_cut[j] + c
        self.sim_involved = {}  # i -> bool per sim i-simplex: in some registered pair
        self.cut_involved = {}
        self.empty = True

    # -- broad phase ------------------------------------------------------------------
    def _near(self):
        """Keep only the cells of each mesh that share a grid cell with a cell of the
        other mesh enlarged by σ+ (a superset of the cells within σ+ of the other mesh:
        every candidate pair of every kind is made of their faces), and build the
        simplicial complexes of those cells only."""
        sim, cut = self.sim, self.cut
        if len(sim.cells) == 0 or len(cut.cells) == 0:
            return
        Xs, Xc = sim.P[sim.cells], cut.P[cut.cells]
        pad = max(self.reach.values())
        near_s, near_c = near_flags(Xs.min(1), Xs.max(1), Xc.min(1), Xc.max(1), pad)
        if not (near_s.any() and near_c.any()):
            return
        sim.build(near_s)
        cut.build(near_c)
        self.empty = False

    def _candidates(self, kind, i, j):
        Xs = self.sim.coords(i, slice(None))
        Xc = self.cut.coords(j, slice(None))
        yield from box_pairs(Xs.min(1), Xs.max(1), Xc.min(1), Xc.max(1), self.reach[kind],
                             chunk=4 * self.chunk)

    # -- suppression --------------------------------------------------------------------
    def _blocked(self, i, j, s, c):
        lower = [(a, b) for (a, b), keys in self.registered.items()
                 if a <= i and b <= j and (a, b) != (i, j) and len(keys)]
        blocked = np.zeros(len(s), dtype=bool)
        if not lower:
            return blocked
        sflag = np.zeros(len(s), dtype=bool)
        for a in {a for a, _ in lower}:
            sflag |= self.sim_involved[a][self.sim.cx.face(i, a)[s]].any(axis=1)
        cflag = np.zeros(len(c), dtype=bool)
        for b in {b for _, b in lower}:
            cflag |= self.cut_involved[b][self.cut.cx.face(j, b)[c]].any(axis=1)
        maybe = np.flatnonzero(sflag & cflag)
        if maybe.size == 0:
            return blocked
        s, c = s[maybe], c[maybe]
        hit = np.zeros(len(maybe), dtype=bool)
        for a, b in lower:
            A = self.sim.cx.face(i, a)[s]
            B = self.cut.cx.face(j, b)[c]
            keys = (A[:, :, None] * self.cut.count(b) + B[:, None, :]).reshape(len(s), -1)
            R = self.registered[a, b]
            pos = np.searchsorted(R, keys).clip(max=len(R) - 1)
            hit |= (R[pos] == keys).any(axis=1)
        blocked[maybe] = hit
        return blocked

    # -- levels ---------------------------------------------------------------------------
    def run(self, progress, timings):
        from tqdm import tqdm

        dim, dt = self.dim, self.dtype
        kinds = catalogue_kinds(dim)
        pairs = {}
        bar = tqdm(total=len(kinds) + 1, desc="registering", unit="step", delay=1.0,
                   file=sys.stderr, disable=not progress, leave=False)
        try:
            bar.set_postfix_str("broad phase", refresh=False)  # refresh would defeat delay
            t = time.perf_counter()
            self._near()
            timings["broadphase_cells"] = time.perf_counter() - t
            empty = self.empty
            bar.update(1)
            for k in kinds:
                kind, i, j = k.name, k.i, k.j
                t = time.perf_counter()
                bar.set_postfix_str(kind, refresh=False)
                s_all, c_all, sw_all, cw_all = [], [], [], []
                ncand = nsup = 0
                if not empty:
                    for s, c in self._candidates(kind, i, j):
                        ncand += len(s)
                        blocked = self._blocked(i, j, s, c)
                        nsup += int(blocked.sum())
                        s, c = s[~blocked], c[~blocked]
                        for lo in range(0, len(s), self.chunk):
                            ss, cc = s[lo: lo + self.chunk], c[lo: lo + self.chunk]
                            hit, sw, cw = k.evaluate(self.sim.coords(i, ss),
                                                     self.cut.coords(j, cc), self.tol)
                            s_all.append(ss[hit])
                            c_all.append(cc[hit])
                            sw_all.append(sw[hit])
                            cw_all.append(cw[hit])
                s = np.concatenate(s_all) if s_all else np.zeros(0, dtype=np.int64)
                c = np.concatenate(c_all) if c_all else np.zeros(0, dtype=np.int64)
                sw = np.concatenate(sw_all) if sw_all else np.zeros((0, i + 1), dtype=dt)
                cw = np.concatenate(cw_all) if cw_all else np.zeros((0, j + 1), dtype=dt)
                self._register(i, j, s, c)
                pairs[kind] = self._output(kind, i, j, s, c, sw, cw, ncand, nsup)
                timings[kind] = time.perf_counter() - t
                bar.update(1)
        finally:
            bar.close()
        return pairs

    def _register(self, i, j, s, c):
        if self.empty:
            self.registered[i, j] = np.zeros(0, dtype=np.int64)
            return
        keys = s.astype(np.int64) * self.cut.count(j) + c
        self.registered[i, j] = np.sort(keys)
        if i not in self.sim_involved:
            self.sim_involved[i] = np.zeros(self.sim.count(i), dtype=bool)
        if j not in self.cut_involved:
            self.cut_involved[j] = np.zeros(self.cut.count(j), dtype=bool)
        self.sim_involved[i][s] = True
        self.cut_involved[j][c] = True

    def _output(self, kind, i, j, s, c, sw, cw, ncand, nsup):
        if self.empty:
            return KindPairs(kind, np.zeros((0, i + 1), np.int64), np.zeros((0, j + 1), np.int64),
                             np.zeros((0, i + 1), self.dtype), np.zeros((0, j + 1), self.dtype))
        sid = self.sim.ids(i, s).reshape(len(s), i + 1)
        cid = self.cut.ids(j, c).reshape(len(c), j + 1)
        both = np.concatenate([np.sort(sid, axis=1), np.sort(cid, axis=1)], axis=1)
        order = np.lexsort(both.T[::-1]) if len(both) else np.zeros(0, dtype=np.int64)
        return KindPairs(kind, sid[order], cid[order], sw[order], cw[order],
                         candidates=ncand, suppressed=nsup)
