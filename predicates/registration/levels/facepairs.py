"""Candidate pairs of primitives of every kind from the pairs of *cells* within reach
(the per-kind broad phase of section 1 of the paper; step 5 of
:mod:`predicates.registration.pipeline`).

The cell pairs (a simulation cell, a cutting cell) whose boxes are within σ+ are found
once (:func:`~predicates.registration.spatial.broadphase.box_pairs`). A pair of faces (an
i-face f of the simulation mesh, a j-face g of the cutting mesh) whose boxes are within
a kind's reach r ≤ σ+ has *every* pair of cells containing f and g within σ+: a cell's
box contains its faces' boxes exactly (min and max round nothing), so
lo_C − hi_T ≤ lo_g − hi_f exactly, and rounding to nearest is monotone:
F[lo_C − hi_T] ≤ F[lo_g − hi_f] ≤ r ≤ σ+ (likewise on the other side of every axis).
Every face is *owned* by one cell containing it, so the pair (f, g) is proposed from
exactly one cell pair, (owner(f), owner(g)): no de-duplication is needed.

Two stages, each a conservative box test (the cutting cell's box contains g's):

1. per simulation level i, (f, C) for every cell pair (T, C) and every i-face f owned
   by T, kept when f's box is within the largest reach of the kinds with that i of
   C's box; shared by those kinds;
2. per kind (i, j), (f, g) for every kept (f, C) and every j-face g owned by C, kept by
   exactly the test of :func:`~predicates.registration.spatial.broadphase.box_pairs` at the
   kind's reach.

So each kind gets exactly the pairs ``box_pairs`` would give on its primitives' boxes
(tested against it in tests/test_registration/test_broadphase.py), at a fraction of
the proposals: no grid per kind, no sort.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import Blocks
from predicates.registration.spatial.broadphase import box_pairs, boxes_of, pair_test

__all__ = ["FacePairs", "cell_pairs", "joined", "owned_table"]


def cell_pairs(P_sim, sim_cells, P_cut, cut_cells, pad: float, chunk: int,
               accelerate: bool = False):
    """The pairs of cells (rows of ``sim_cells`` × rows of ``cut_cells``, coordinates
    ``P_sim``, ``P_cut``) whose boxes are within ``pad``: (T, C, keep_s, keep_c), with
    ``keep_*`` the masks of the cells in some pair and T, C indices into the kept rows."""
    lo_s, hi_s = _boxes(P_sim, sim_cells, accelerate)
    lo_c, hi_c = _boxes(P_cut, cut_cells, accelerate)
    parts = list(box_pairs(lo_s, hi_s, lo_c, hi_c, pad, chunk=chunk, accelerate=accelerate))
    if len(parts) == 1:  # the compiled dense-grid join's one part: not copied again
        T, C = parts[0]
    else:
        T = np.concatenate([p[0] for p in parts]) if parts else np.zeros(0, np.int64)
        C = np.concatenate([p[1] for p in parts]) if parts else np.zeros(0, np.int64)
    # int32 ids when they fit (the compiled kernels take either; numpy's gathers
    # too): half the memory the levels hold (W4: 4.5 M pairs, 34 MiB saved)
    ids = [np.int32 if len(x) < 2 ** 31 else np.int64 for x in (sim_cells, cut_cells)]
    if accelerate and T.dtype == ids[0] and C.dtype == ids[1]:
        from predicates.compiled.boxtest import renumbered

        # the join's arrays renumbered compiled (keep, cumsum and take: W4 68 -> 12
        # ms) into arrays of their length, as take did: the join's longer arrays
        # held instead raised W4's serial peak by ~8 MiB (glibc's mmap threshold)
        (keep_s, T), (keep_c, C) = renumbered(T, len(sim_cells)), renumbered(C, len(cut_cells))
        return T, C, keep_s, keep_c
    keep_s, keep_c = np.zeros(len(sim_cells), bool), np.zeros(len(cut_cells), bool)
    keep_s[T] = True
    keep_c[C] = True
    # take: the same values as fancy indexing, faster
    return ((np.cumsum(keep_s, dtype=ids[0]) - 1).take(T),
            (np.cumsum(keep_c, dtype=ids[1]) - 1).take(C), keep_s, keep_c)


def joined(parts: list, empty: np.ndarray) -> np.ndarray:
    """``np.concatenate(parts)`` (``empty`` if none; the same values and dtype), each
    part released once copied and the list emptied: the blocks and the whole are not
    held at once (the output's pages are touched as they are written)."""
    if not parts:
        return empty
    out = np.empty((sum(len(p) for p in parts),) + parts[0].shape[1:],
                   np.result_type(*parts))
    at = 0
    parts.reverse()
    while parts:
        part = parts.pop()
        out[at: at + len(part)] = part
        at += len(part)
    return out


def owned_table(F: np.ndarray, n_faces: int) -> np.ndarray:
    """``F`` (n_cells, m): the face ids of each cell. Returns the same table with −1
    where the cell does not own the face: every face is owned by exactly one of the
    cells containing it (which one does not matter). int32 when the face ids fit."""
    n, m = F.shape
    owner = np.full(n_faces, -1, dtype=np.int64)
    # a repeated index receives one of the values written to it: one cell holding it
    owner[F.ravel()] = np.repeat(np.arange(n, dtype=np.int64), m)
    # int32 face ids when they fit: stage 1's pairs are made of them (half its memory)
    ids = np.int32 if n_faces < 2 ** 31 else np.int64
    return np.where(owner[F] == np.arange(n)[:, None], F, -1).astype(ids, copy=False)


def _owned(tab, cells):
    """(face, position in ``cells``) for every face the ``cells`` own (owned table
    ``tab``), in the order of ``cells``."""
    A = tab.take(cells, axis=0)
    flat = np.flatnonzero(A >= 0)  # flat: ~4x faster than a 2D nonzero + 2D indexing
    return A.ravel().take(flat), flat // A.shape[1]


def _slices(fs: list, cs: list, step: int, consume: bool = False):
    """Consecutive blocks (f, C) of ``step`` pairs of the stage-1 parts ``fs``, ``cs``:
    the slices of their concatenation (a block across parts joined, a block within one
    a view), without the concatenation held (a serial run's peak: W4's level 2 is 5.6 M
    pairs; docs/partitioned.md section 2). ``consume``: each part dropped from the
    lists once read (the level's last kind)."""
    held_f, held_c, n = [], [], 0
    for k in range(len(fs)):
        f, c = fs[k], cs[k]
        if consume:
            fs[k] = cs[k] = None
        lo = 0
        while lo < len(f):
            take = min(step - n, len(f) - lo)
            held_f.append(f[lo: lo + take])
            held_c.append(c[lo: lo + take])
            n, lo = n + take, lo + take
            if n == step:
                yield _cat(held_f), _cat(held_c)
                held_f, held_c, n = [], [], 0
    if n:
        yield _cat(held_f), _cat(held_c)


def _cat(parts: list) -> np.ndarray:
    """The one part as it is (a view), or the parts concatenated."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _boxes(points, rows, accelerate: bool):
    """:func:`~predicates.registration.spatial.broadphase.boxes_of` (lo, hi (n, d)), the
    same boxes; compiled in one call (:func:`predicates.compiled.boxtest.boxes`)."""
    if accelerate:
        from predicates.compiled.boxtest import boxes

        return boxes(points, rows)
    return boxes_of(points, rows, Blocks(accelerate=False))


def _columns(points, rows, accelerate: bool):
    """Boxes of the simplices ``points[rows]`` as (d, n) columns (lo, hi)."""
    lo, hi = _boxes(points, rows, accelerate)
    return lo.T, hi.T  # (d, n) arrays underneath: their transposes, no copy


class FacePairs:
    """Candidate pairs of one registration, kind by kind (module docstring).

    ``sim``, ``cut``: :class:`~predicates.registration.levels.complex.Side` with their
    complexes built; ``T``, ``C``: every pair of their top simplices (indices) whose
    boxes are within the largest reach (:func:`cell_pairs`), each once; ``reach``:
    {kind name: reach}; ``kinds``: the catalogue's kinds (each with ``name``, ``i``,
    ``j``) in the order they will be asked for."""

    def __init__(self, sim, cut, T, C, reach: dict, kinds, chunk: int,
                 accelerate: bool = False):
        self.sim, self.cut, self.reach, self.chunk = sim, cut, reach, chunk
        self.accelerate = accelerate  # compiled box tests (predicates.compiled)
        self.top_s, self.top_c = sim.cx.top, cut.cx.top
        self._boxes = {}  # (side, level) -> (lo, hi) columns
        self._tables = {}  # (side, level) -> owned table
        self._stage1 = {}  # sim level i -> (f, C) as lists of parts (_slices)
        self._pending = {}  # sim level i -> kinds still to ask for it
        for k in kinds:
            self._pending[k.i] = self._pending.get(k.i, 0) + 1
        self._level_reach = {}
        for k in kinds:
            self._level_reach[k.i] = max(self._level_reach.get(k.i, 0.0), reach[k.name])
        self._left = [(k.i, k.j) for k in kinds]  # the kinds still to ask for, in order
        self._first_done = set()  # the simulation levels whose stage 1 was computed
        self.T, self.C = T, C

    def _release(self) -> None:
        """Drop the boxes and owned tables no kind still to come reads (a serial run's
        peak: W4's face boxes and lists are ~150 MB, docs/partitioned.md section 2):
        the simulation tables serve stage 1 only, the cutting cells' boxes also serve
        stage 1 of the levels still without it; the same pairs either way."""
        sim = {i for i, _ in self._left}
        first = {i for i in sim if i != self.top_s and i not in self._first_done}
        cut = {j for _, j in self._left} | ({self.top_c} if first else set())
        for key in [k for k in self._boxes if k[1] not in (sim if k[0] == "sim" else cut)]:
            del self._boxes[key]
        for key in [k for k in self._tables if k[1] not in (first if k[0] == "sim" else cut)]:
            del self._tables[key]

    def _box(self, side, k):
        if (side, k) not in self._boxes:
            s = self.sim if side == "sim" else self.cut
            self._boxes[side, k] = _columns(s.P, s.cx.S[k], self.accelerate)
        return self._boxes[side, k]

    def _table(self, side, k):
        if (side, k) not in self._tables:
            s = self.sim if side == "sim" else self.cut
            self._tables[side, k] = owned_table(s.cx.face(s.cx.top, k), s.count(k))
        return self._tables[side, k]

    def _lists(self, side, k, columns: bool = False):
        """The compiled kernels' form of :meth:`_table`: (start, faces, widest)
        (:func:`predicates.compiled.boxtest.owned_lists_of`, the same owners); with
        ``columns`` also each face's column in the face map (stage 1's)."""
        if (side, k, "lists", columns) not in self._tables:
            from predicates.compiled.boxtest import owned_lists_of

            s = self.sim if side == "sim" else self.cut
            self._tables[side, k, "lists", columns] = owned_lists_of(
                s.cx.face(s.cx.top, k), s.count(k), columns)
        return self._tables[side, k, "lists", columns]

    def _test(self, pad, i, j_box, f, g):
        """(f, g) pairs kept by the box test at ``pad``: simulation i-faces ``f`` against
        cutting boxes ``j_box`` = (side level) ``g``."""
        lo_a, hi_a = self._box("sim", i)
        lo_b, hi_b = self._box("cut", j_box)
        test = pair_test
        if self.accelerate:
            from predicates.compiled.boxtest import pair_test as test
        keep = test(pad, lo_a, hi_a, lo_b, hi_b, f, g)
        return f[keep], g[keep]

    def _owned_test(self, tab, side, A, B, pad, i, j_box):
        """:func:`_owned` (of ``A``'s or ``B``'s rows, ``side``) and :meth:`_test`,
        fused and compiled (:mod:`predicates.compiled.boxtest`): the same pairs."""
        from predicates.compiled.boxtest import owned_pairs

        return owned_pairs(tab, side, A, B, pad, self._box("sim", i), self._box("cut", j_box))

    def _first(self, i):
        """Stage 1 for simulation level i: (f, C) as lists of parts, f an i-face owned
        by T, (T, C) a cell pair, f's box within the level's largest reach of C's box."""
        if i == self.top_s:  # the cell itself: the cell pairs, tested in stage 2
            return [self.T], [self.C]
        if self.accelerate:  # every level still to come in one compiled pass
            levels = sorted(k for k, left in self._pending.items()
                            if left and k != self.top_s and k not in self._stage1)
            self._stage1.update(self._first_levels(levels))
            self._first_done.update(levels)
            return self._stage1[i]
        tab = self._table("sim", i)
        step = max(1, self.chunk // tab.shape[1])
        fs, cs = [], []
        for lo in range(0, len(self.T), step):
            T, C = self.T[lo: lo + step], self.C[lo: lo + step]
            f, rows = _owned(tab, T)
            f, C = self._test(self._level_reach[i], i, self.top_c, f, C.take(rows))
            fs.append(f)
            cs.append(C)
        self._first_done.add(i)
        return fs, cs  # not joined: the kinds read them as blocks (_slices)

    def _first_levels(self, levels: list) -> dict:
        """Stage 1 of the simulation ``levels`` in one compiled pass over the cell pairs
        (:func:`predicates.compiled.stage1.owned_levels`: the same pairs as the blocks
        of :meth:`_first`, no concatenation; face by face per cell, so the fused kernels
        fold each face's box once per run of its pairs): {level: (f, C)}."""
        from predicates.compiled.stage1 import owned_levels

        # the faces' owned lists and columns, not their boxes: the kernel folds each
        # box from its cell's vertices (the same values, min and max exact; W4: 1.08 M
        # boxes, 52 MB never built)
        spec = []
        for i in levels:
            start, faces, _, cols = self._lists("sim", i, True)
            spec.append((i, start, faces, cols, self._level_reach[i]))
        got = owned_levels(self.T, self.C, self._box("cut", self.top_c), self.sim.P,
                           self.sim.cx.S[self.top_s], spec)
        return {level: ([f], [C]) for level, (f, C) in zip(levels, got)}

    def blocks(self, kind: str, i: int, j: int, lists: bool = False):
        """Yield (f, C, tab, pad): blocks of the stage-1 pairs of level i (f an i-face,
        C a cutting cell), the owned table of the cutting j-faces (None: the cells
        themselves; ``lists``: as :meth:`_lists`, for the compiled fused chain,
        predicates.compiled.chain.fused) and the kind's reach; :meth:`candidates`
        expands and tests them."""
        if i not in self._stage1:
            self._stage1[i] = self._first(i)
        fs, cs = self._stage1[i]
        self._pending[i] -= 1
        last = self._pending[i] == 0  # the last kind of this simulation level
        if last:
            del self._stage1[i]
        pad = self.reach[kind]
        if j == self.top_c:  # the cutting cell itself
            tab, step = None, self.chunk
        else:
            tab = self._lists("cut", j) if lists else self._table("cut", j)
            step = max(1, self.chunk // (max(1, tab[2]) if lists else tab.shape[1]))
        for f, C in _slices(fs, cs, step, consume=last):
            yield f, C, tab, pad
        self._left.remove((i, j))  # this kind is done: what no later kind reads goes
        self._release()

    def box_rows(self, j: int) -> np.ndarray:
        """The cutting j-simplices' boxes as (n, 2d) rows for the fused chain: copied
        from the columns when stage 1 made them, else folded from the points in one
        pass (:func:`predicates.compiled.chain.point_box_rows`): the same values."""
        from predicates.compiled.chain import box_rows, point_box_rows

        cols = self._boxes.get(("cut", j))
        if cols is not None:
            return box_rows(*cols)
        return point_box_rows(self.cut.P, self.cut.cx.S[j])

    def candidates(self, kind: str, i: int, j: int):
        """Yield (s, c) index arrays (into the complexes' i- and j-simplices): together
        every pair whose boxes are within the kind's reach, each exactly once."""
        for f, C, tab, pad in self.blocks(kind, i, j):
            if self.accelerate and tab is not None:
                s, c = self._owned_test(tab, "b", f, C, pad, i, j)
            else:
                if tab is not None:
                    C, rows = _owned(tab, C)
                    f = f.take(rows)
                s, c = self._test(pad, i, j, f, C)
            if len(s):
                yield s, c
