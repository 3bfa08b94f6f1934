"""The levels of the registration (section 1 of the paper; steps 5–6 of
:mod:`predicates.registration.pipeline`): the cells near the other mesh, then per level,
per kind, the candidate pairs of the broad phase, their suppression when a sub-pair was
registered at a lower level (line 2 of every algorithm, "degenerate intersection"), and
the predicate in numpy batch mode on chunks of candidates.

Registered pairs are kept per kind as sorted int64 keys, so that the suppression look-up
is a vectorised ``searchsorted``.
"""
from __future__ import annotations

import contextlib
import ctypes
import sys
import time

import numpy as np

from predicates.catalogue import kinds as catalogue_kinds
from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.broadphase import boxes_of, tighten_flags
from predicates.registration.levels.complex import (
    Side, any_flagged, distinct_lex_order, packed_keys, sorted_rows)
from predicates.registration.levels.facepairs import FacePairs, cell_pairs, joined
from predicates.registration.result.intersection import KindPairs

__all__ = ["MemoryGuard", "Registration", "RegistrationMemoryError", "trim_freed"]


class RegistrationMemoryError(MemoryError):
    """The serial registration after the plan (rank space, broad phase, levels) ran out
    of memory: the message names the stage, the cells near the cut and what to do
    (partition the run: docs/partitioned.md, section 2)."""


class MemoryGuard:
    """A MemoryError of the serial registration (inside ``with``) as
    :class:`RegistrationMemoryError` naming the stage reached in ``timings``, the cells
    near the cut and what to do. Keeps the plan's counts, not the plan (whose arrays
    the registration releases meanwhile)."""

    def __init__(self, plan, timings: dict, mib: float):
        self.kinds, self.timings, self.mib = plan.kinds, timings, mib
        self.near = len(plan.sim_cells), len(plan.cut_cells)

    def __enter__(self) -> MemoryGuard:
        return self

    def __exit__(self, kind, e, tb) -> None:
        if not isinstance(e, MemoryError) or isinstance(e, RegistrationMemoryError):
            return  # anything else propagates as it is
        done = self.timings
        stage = next((k.name for k in self.kinds if k.name not in done),
                     "output") if "broadphase_cells" in done else (
                     "broad phase" if "ranks" in done else "rank space")
        raise RegistrationMemoryError(
            f"not enough memory for the registration ({stage}) of meshes of "
            f"{self.mib:.0f} MiB, {self.near[0]} simulation and {self.near[1]} cutting "
            f"cells near the cut: partition the run (partitions=/scheduler=; fperr "
            f"intersect --workers N --partitions K: each partition holds less, "
            f"docs/partitioned.md) or run on a machine with more memory "
            f"({type(e).__name__}: {str(e) or 'no detail'})") from e


def trim_freed() -> None:
    """Return the memory freed before the levels to the system (a serial run's peak,
    docs/partitioned.md section 2): with glibc, trim its heap (blocks freed below its
    mmap threshold otherwise stay resident: W4 ~95 MiB, benchmarks/README.md "Serial
    peak"). No collection: a run makes no reference cycle (the plan's arrays are freed
    as their last reference goes; tests/test_registration/test_no_cycles.py), and a
    full collection cost ~60 ms at W4."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):  # not glibc: nothing to trim
            ctypes.CDLL(None).malloc_trim(0)


class Registration:
    """Both meshes in rank space and the pairs registered so far, level by level."""

    def __init__(self, dim, P_sim, sim_cells, P_cut, cut_cells, tol, reach, chunk,
                 accelerate: bool = False):
        self.dim, self.tol, self.reach, self.chunk = dim, tol, reach, chunk
        self.accelerate = accelerate  # the compiled chain (predicates.compiled)
        self.dtype = P_sim.dtype
        self.sim = Side(P_sim, sim_cells, accelerate)
        self.cut = Side(P_cut, cut_cells, accelerate)
        self.registered = {}  # (i, j) -> sorted int64 keys s * n_cut[j] + c
        self.later = None  # the kinds still to come (i, j), set by run(); None: all
        self.sim_involved = {}  # i -> bool per sim i-simplex: in some registered pair
        self.cut_involved = {}
        self.box_rows = {}  # j -> the cutting j-simplices' boxes as rows (fused chain)
        self.empty = True

    # -- broad phase ------------------------------------------------------------------
    def _near(self):
        """Keep only the cells of each mesh that share a grid cell with a cell of the
        other mesh enlarged by σ+ (``tighten_flags``: a superset of the cells within σ+
        of the other mesh; the plan's masks already dropped the far ones; not on the
        compiled path, whose join does without), find the
        pairs of those cells within σ+ (every candidate pair of every kind is made of
        their faces), and build the simplicial complexes of the cells in some pair only
        (:mod:`~predicates.registration.levels.facepairs`)."""
        sim, cut = self.sim, self.cut
        if len(sim.cells) == 0 or len(cut.cells) == 0:
            return
        pad = max(self.reach.values())
        if self.accelerate:
            # no pre-filter: the compiled join visits a far cell's few grid cells and
            # tests every proposal exactly; cell_pairs keeps the cells in some pair —
            # the same cells and pairs, cheaper than tighten_flags' pass (W1 cell
            # broad phase 56 -> 35 ms, W4 667 -> 423 ms; benchmarks/README.md)
            tops_s, tops_c = sim.unique_cells(), cut.unique_cells()
        else:
            blocks = Blocks(accelerate=False)
            near_s, near_c = tighten_flags(*boxes_of(sim.P, sim.cells, blocks),
                                           *boxes_of(cut.P, cut.cells, blocks), pad,
                                           blocks=blocks)
            if not (near_s.any() and near_c.any()):
                return
            # the pairs of distinct cells within σ+; complexes of the cells in some pair
            tops_s, tops_c = sim.unique_cells(near_s), cut.unique_cells(near_c)
        T, C, keep_s, keep_c = cell_pairs(sim.P, tops_s, cut.P, tops_c, pad, 2 * self.chunk,
                                          self.accelerate)
        if len(T) == 0:
            return
        # compress: the same rows as boolean indexing, which numpy does row by row
        # here (W1's two tables ~2 -> 0.25 ms; benchmarks/README.md, "s23-w1")
        sim.build_unique(tops_s.compress(keep_s, axis=0))
        cut.build_unique(tops_c.compress(keep_c, axis=0))
        sim.cells = cut.cells = None  # the complexes hold what the levels read
        self.faces = FacePairs(sim, cut, T, C, self.reach, catalogue_kinds(self.dim),
                               2 * self.chunk, self.accelerate)
        self.empty = False

    def _candidates(self, kind, i, j):
        yield from self.faces.candidates(kind, i, j)

    # -- suppression --------------------------------------------------------------------
    def _suspects(self, i, j):
        """(lower, flag_s, flag_c) for kind (i, j): the registered lower kinds (pairs of
        sub-simplex levels) and, per i-simplex / j-simplex, whether one of its faces
        is in a registered pair of such a level — once per kind, for every simplex
        (cheaper than per candidate). None when no lower pair is registered."""
        lower = [(a, b) for (a, b), keys in self.registered.items()
                 if a <= i and b <= j and (a, b) != (i, j) and len(keys)]
        if not lower:
            return None
        fast = self.accelerate
        flag_s = np.zeros(self.sim.count(i), dtype=bool)
        for a in {a for a, _ in lower}:
            flag_s |= _any_face(self.sim.cx, i, a, self.sim_involved[a], fast)
        flag_c = np.zeros(self.cut.count(j), dtype=bool)
        for b in {b for _, b in lower}:
            flag_c |= _any_face(self.cut.cx, j, b, self.cut_involved[b], fast)
        return lower, flag_s, flag_c

    def _blocked(self, i, j, s, c, suspects, flagged: bool = False):
        """Per candidate (s, c): is a pair of its sub-simplices (the pair itself
        excluded) registered? ``suspects`` from :meth:`_suspects`; ``flagged``: every
        pair has both flags set (the fused kernels' pairs left to the look-up), so
        no pre-filter."""
        blocked = np.zeros(len(s), dtype=bool)
        if suspects is None:
            return blocked
        lower, flag_s, flag_c = suspects
        if flagged and self.accelerate:  # the look-ups straight into blocked
            self._registered_any(i, j, s, c, lower, blocked)
            return blocked
        maybe = np.flatnonzero(flag_s.take(s) & flag_c.take(c))
        if maybe.size == 0:
            return blocked
        s, c = s.take(maybe), c.take(maybe)
        hit = np.zeros(len(maybe), dtype=bool)
        if self.accelerate:  # the same look-ups, compiled: no (pairs, faces²) keys
            self._registered_any(i, j, s, c, lower, hit)
            blocked[maybe] = hit
            return blocked
        for a, b in lower:
            # int64 keys: s may be int32 (stage 1's ids), whose product would wrap
            A = _faces(self.sim.cx, i, a, s).astype(np.int64, copy=False)
            B = _faces(self.cut.cx, j, b, c)
            keys = (A[:, :, None] * self.cut.count(b) + B[:, None, :]).reshape(len(s), -1)
            R = self.registered[a, b]
            pos = np.searchsorted(R, keys).clip(max=len(R) - 1)
            hit |= (R.take(pos) == keys).any(axis=1)
        blocked[maybe] = hit
        return blocked

    def _registered_any(self, i, j, s, c, lower, hit):
        """hit[q] |= a pair of sub-simplices of (s[q], c[q]) of a ``lower`` kind is
        registered (predicates.compiled.chain.registered_any, per lower kind)."""
        from predicates.compiled.chain import registered_any

        for a, b in lower:
            registered_any(s, c, None if a == i else self.sim.cx.face(i, a),
                           None if b == j else self.cut.cx.face(j, b),
                           self.cut.count(b), self.registered[a, b], hit,
                           self.sim_involved[a], self.cut_involved[b])

    # -- levels ---------------------------------------------------------------------------
    def run(self, progress: bool, timings: dict, give_back: bool = False) -> dict:
        """Register every kind in the catalogue's order; returns {kind: KindPairs} and
        records the time of the broad phase and of every kind in ``timings``. Once:
        the arrays are released after. ``give_back``: first return the memory freed
        before (:func:`trim_freed`; a serial run, its plan released)."""
        from tqdm import tqdm

        if give_back:
            trim_freed()

        kinds = catalogue_kinds(self.dim)
        pairs = {}
        bar = tqdm(total=len(kinds) + 1, desc="registering", unit="step", delay=1.0,
                   file=sys.stderr, disable=not progress, leave=False)
        try:
            bar.set_postfix_str("broad phase", refresh=False)  # refresh would defeat delay
            t = time.perf_counter()
            self._near()
            timings["broadphase_cells"] = time.perf_counter() - t
            bar.update(1)
            for n, k in enumerate(kinds):
                self.later = [(q.i, q.j) for q in kinds[n + 1:]]
                t = time.perf_counter()
                bar.set_postfix_str(k.name, refresh=False)
                pairs[k.name] = self._level(k)
                timings[k.name] = time.perf_counter() - t
                bar.update(1)
        finally:
            bar.close()
            # the complexes, boxes and registered keys: not held past the run
            self.faces = self.sim = self.cut = None
            self.registered, self.sim_involved, self.cut_involved = {}, {}, {}
            self.box_rows = {}
        return pairs

    def _level(self, k) -> KindPairs:
        """One kind (a :class:`predicates.catalogue.Kind`): candidates, suppression,
        predicate; registers the hits and returns them in input ids."""
        kind, i, j, dt = k.name, k.i, k.j, self.dtype
        s_all, c_all, sw_all, cw_all = [], [], [], []
        ncand = nsup = 0
        if not self.empty and self.accelerate:
            ncand, nsup = self._fused(k, s_all, c_all, sw_all, cw_all)
        elif not self.empty:
            suspects = self._suspects(i, j)
            for s, c in self._candidates(kind, i, j):
                ncand += len(s)
                blocked = self._blocked(i, j, s, c, suspects)
                nsup += int(blocked.sum())
                s, c = s[~blocked], c[~blocked]
                for lo in range(0, len(s), self.chunk):
                    ss, cc = s[lo: lo + self.chunk], c[lo: lo + self.chunk]
                    ss, cc, sw, cw = self._evaluate(k, ss, cc)
                    s_all.append(ss)
                    c_all.append(cc)
                    sw_all.append(sw)
                    cw_all.append(cw)
        s = joined(s_all, np.zeros(0, dtype=np.int64))
        c = joined(c_all, np.zeros(0, dtype=np.int64))
        sw = joined(sw_all, np.zeros((0, i + 1), dtype=dt))
        cw = joined(cw_all, np.zeros((0, j + 1), dtype=dt))
        self._register(i, j, s, c)
        return self._output(kind, i, j, s, c, sw, cw, ncand, nsup)

    def _fused(self, k, *out) -> tuple[int, int]:
        """Kind ``k`` by the compiled fused chain (predicates.compiled.chain.fused):
        appends the registered pairs to the lists ``out`` (s, c, sim and cut weights);
        the pairs the suppression pre-filter flags are looked up exactly here, the
        others evaluated. Returns (candidates, suppressed), as the numpy path counts."""
        from predicates.compiled.chain import fused

        suspects = self._suspects(k.i, k.j)
        flags = None if suspects is None else suspects[1:]
        if k.j not in self.box_rows:  # once per cutting level, while a kind reads it
            self.box_rows[k.j] = self.faces.box_rows(k.j)
        boxes = self.sim.P, self.sim.cx.S[k.i], self.box_rows[k.j]
        if self.later is not None and not any(j == k.j for _, j in self.later):
            del self.box_rows[k.j]
        ncand = nsup = 0
        for f, C, owned, pad in self.faces.blocks(k.name, k.i, k.j, lists=True):
            n, hits, (ms, mc) = fused(k, self.sim, self.cut, f, C, owned, pad, boxes, flags,
                                      self.tol)
            ncand += n
            if len(ms):
                blocked = self._blocked(k.i, k.j, ms, mc, suspects, flagged=True)
                nsup += int(blocked.sum())
                more = self._evaluate(k, ms[~blocked], mc[~blocked])
                for lst, a in zip(out, more):
                    lst.append(a)
            for lst, a in zip(out, hits):
                lst.append(a)
        return ncand, nsup

    def _evaluate(self, k, s, c):
        """The predicate of kind ``k`` on the candidates (s, c): the registered ones and
        their weights (numpy batch mode, or the same bits compiled)."""
        if self.accelerate:
            from predicates.compiled.chain import evaluate

            return evaluate(k, self.sim, self.cut, s, c, self.tol)
        hit, sw, cw = k.evaluate(self.sim.coords(k.i, s), self.cut.coords(k.j, c), self.tol)
        return s[hit], c[hit], sw[hit], cw[hit]

    def _register(self, i, j, s, c):
        """Keep kind (i, j)'s pairs for the suppression of the kinds still to come
        (``later``): those of a kind none of them has as a lower kind (a ≤ i', b ≤ j')
        are never looked up, so not sorted (W4: triangle_edge's 729 k keys)."""
        if self.empty or (self.later is not None
                          and not any(i <= a and j <= b for a, b in self.later)):
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
        if self.accelerate and len(s):  # the same order and ids, compiled
            from predicates.compiled.hitorder import hits_in_order, rows_in_order

            sim, cut = self.sim, self.cut
            order, sid, cid = hits_in_order((sim.cx.S[i], sim.order, s, sim.n_input),
                                            (cut.cx.S[j], cut.order, c, cut.n_input))
            return KindPairs(kind, sid, cid, rows_in_order(sw, order), rows_in_order(cw, order),
                             candidates=ncand, suppressed=nsup)
        else:
            sid = self.sim.ids(i, s).reshape(len(s), i + 1)
            cid = self.cut.ids(j, c).reshape(len(c), j + 1)
            # lexicographic on (sorted sim ids, sorted cut ids): packed into few int64
            # keys (order-preserving; the order of a lexsort of the 2 + i + j columns,
            # whose rows are distinct: each pair is registered once)
            keys = (packed_keys(sorted_rows(sid), self.sim.n_input)
                    + packed_keys(sorted_rows(cid), self.cut.n_input))
            order = distinct_lex_order(keys) if len(sid) else np.zeros(0, dtype=np.int64)
            # take: rows gathered ~3× faster than fancy indexing, the same values
            sid, cid = sid.take(order, axis=0), cid.take(order, axis=0)
        return KindPairs(kind, sid, cid, sw.take(order, axis=0), cw.take(order, axis=0),
                         candidates=ncand, suppressed=nsup)


def _faces(cx, k, j, idx):
    """The j-faces (n, C(k+1, j+1)) of the k-simplices ``idx`` (``take``: faster than
    fancy indexing; the simplex itself when j == k)."""
    if j == k:
        return idx[:, None]
    return cx.face(k, j).take(idx, axis=0)


def _any_face(cx, k, j, involved, accelerate: bool = False):
    """Per k-simplex: is one of its j-faces flagged in ``involved`` (per j-simplex)?
    ``accelerate``: in one compiled pass over the rows (the same flags)."""
    if j == k:
        return involved
    if accelerate:
        from predicates.compiled.rows import any_flagged as compiled_any_flagged

        return compiled_any_flagged(involved, cx.face(k, j))
    return any_flagged(involved, cx.face(k, j))
