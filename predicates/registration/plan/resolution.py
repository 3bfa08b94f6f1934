"""Tolerances from the geometry that can meet, the resolution report, the memory guard
(section 4.1 of the paper, Algorithms 1 and 6; docs/resolution.md).

Section 4.1 needs L to bound the coordinate differences of the pairs that are
*processed*: pairs whose boxes are within σ+ (every kind's reach is ≤ σ+). The paper
takes the largest box edge of every primitive; :func:`consistent_scale` takes it over
the cells that can meet, self-consistently:

    L_0 over all cells; L_k over the cells that survive the cell-level broad phase
    (``near_flags``, a superset of the cells with a partner within the pad) with pad
    σ+(L_{k-1}), run on the survivors of round k−1 only.

Round k's survivors contain every cell with a partner within σ+(L_{k-1}) (induction:
such a cell and its partner were within the larger pad of round k−1). Using L_k is sound
when σ+(L_k) ≤ σ+(L_{k-1}): a processed pair of faces has boxes within reach(L_k), so
the cells holding them are within σ+(L_{k-1}), both survive round k, and a face's box
lies in its cell's box, so L_k bounds both faces. This is checked numerically on the
pads actually used (not argued from monotonicity); rounds stop when the pad no longer
shrinks or after :data:`MAX_ROUNDS`.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from predicates.catalogue import kinds as catalogue_kinds
from predicates.tolerances import tolerances as compute_tolerances
from predicates.registration.plan.edges import shortest_edge  # noqa: F401 (re-exported)
from predicates.registration.plan.first_round import near_fixed
from predicates.registration.plan.paircount import KEY_RADIX as _KEY_RADIX
from predicates.registration.plan.paircount import cell_keys as _cell_keys
from predicates.registration.plan.paircount import compiled_count, grid_start
from predicates.registration.plan.paircount import count_dot as _count_dot
from predicates.registration.spatial.blocks import SERIAL, Blocks
from predicates.registration.spatial.boxes import box_extent, boxes_of
from predicates.registration.spatial.boxgrid import colmax, colmin, rowwise
from predicates.registration.spatial.broadphase import near_flags
from predicates.registration.spatial.gridsums import coverage

__all__ = ["COARSE_RATIO", "MAX_ROUNDS", "Resolution", "Scale", "cell_boxes",
           "consistent_scale", "estimate_cell_pairs", "memory_limit", "near_cells"]

#: warn when σ+ exceeds this fraction of the shortest simulation edge near the cut: a
#: crossing within σ+ of an edge's end may be registered at the vertex, so up to
#: 2·COARSE_RATIO of every edge is "vertex zone" (see docs/resolution.md)
COARSE_RATIO = 0.1
#: rounds of broad phase -> L -> σ+ at most
MAX_ROUNDS = 16
#: rough memory per estimated cell pair within reach (candidate pairs of every kind,
#: the broad phase's temporaries); an order-of-magnitude guard, see docs/resolution.md
BYTES_PER_CELL_PAIR = 256


def cell_boxes(points: np.ndarray, cells: np.ndarray):
    """(lo, hi) binary64 bounding boxes of the cells (exact: conversion only)."""
    return boxes_of(points, cells)  # no (n, k, d) gather (memory: benchmarks/README.md)


def _max_edge(ext, mask) -> float:
    """Largest box edge of the selected cells (``ext`` from :func:`~.broadphase.box_extent`), rounded
    up one ulp (upper bound)."""
    if not mask.any():
        return 0.0
    d = float(ext.max() if mask.all() else ext[mask].max())  # no copy when all selected
    return float(np.nextafter(d, np.inf)) if d > 0 else 0.0


@dataclass
class Scale:
    """L_a, L_b (input units, upper bounds for every processed pair), the exponent e
    of the exact scaling (L_a + L_b)·2^-e ∈ [1/2, 1), the tolerances and per-kind reach
    for the scaled coordinates, ``pad``: max reach in input units; ``masks``: the cells
    of each mesh L_a, L_b were taken over (they contain every cell within ``pad`` of
    the other mesh); ``history``: L_a + L_b per round, the paper's global one first;
    ``first``: round one's masks, which the report reuses when no round was kept."""

    L_a: float
    L_b: float
    e: int
    tol: object
    reach: dict
    pad: float
    masks: tuple = ()
    history: list = field(default_factory=list)
    first: tuple = ()  # round one's flags (at the first pad, over every cell)


def _ldexp_up(x: float, e: int) -> float:
    y = math.ldexp(x, -e)
    return y if math.ldexp(y, e) == x else float(np.nextafter(y, np.inf))


def scale_for(dim: int, L_a: float, L_b: float, dtype, table=None) -> Scale:
    """Tolerances (Algorithms 1/6) for L_a, L_b in input units, computed in the exactly
    scaled coordinates; reach per kind as in :mod:`predicates.catalogue` (a ``table``
    whose T+/T exceeds the paper's widens the reach by the same factor)."""
    e = math.frexp(L_a + L_b)[1]
    tol = compute_tolerances(dim, _ldexp_up(L_a, e), _ldexp_up(L_b, e), dtype=dtype,
                             table=table)
    eps = float(np.finfo(dtype).eps)
    reach = {k.name: float(tol.values[k.reach[0]]) * k.reach[1] * _widen(tol, k.reach[0])
             * (1 + 16 * eps) for k in catalogue_kinds(dim)}
    pad = math.ldexp(max(reach.values()), e)
    return Scale(L_a, L_b, e, tol, reach, pad)


def _widen(tol, name: str) -> float:
    """max(1, (T+/T of the table)/(T+/T of the paper)), rounded up."""
    from predicates.tolerance_table import TABLES

    a, b = tol.spec(name), TABLES[tol.dim][name]
    return max(1.0, float(a.hi / a.mid * b.mid / b.hi) * (1 + 1e-12))


def near_cells(sim_box, cut_box, pad, masks, flags=near_flags):
    """Masks of the cells (among ``masks``) sharing a broad-phase grid cell with a cell
    of the other mesh enlarged by ``pad``: a superset of the cells within ``pad``.
    ``sim_box``: (lo, hi) arrays or a :class:`~.cellboxes.CellBoxes` (the boxes
    computed block by block, :mod:`.lean`: the same flags); ``flags``: near_flags or an
    identical one (the threaded plan's)."""
    return _near(sim_box, cut_box, pad, masks, flags)[:2]


def _near(sim_box, cut_box, pad, masks, flags):
    """:func:`near_cells` and the largest box edge of the flagged simulation cells
    (not rounded; 0.0 if none)."""
    ms, mc = masks
    out_s, out_c = np.zeros_like(ms), np.zeros_like(mc)
    lean = hasattr(sim_box, "flag_pass")  # a CellBoxes (or its remote form)
    if ms.all() and mc.all() and len(ms) and len(mc):  # round 1: no copies of the boxes
        return near_fixed(sim_box, *cut_box, pad)  # at the grid the cutting mesh fixes
    if ms.any() and mc.any():
        # near_flags does not depend on the cells' order (its grid size is an exactly
        # rounded mean), so neither does L
        rows = sim_box.rows(ms) if lean else _rows(sim_box, ms)
        ns, nc = flags(*rows, *_rows(cut_box, mc), pad)
        out_s[np.flatnonzero(ms)[ns]] = True
        out_c[np.flatnonzero(mc)[nc]] = True
        return out_s, out_c, _edge_max(rows, ns)
    return out_s, out_c, 0.0


def _edge_max(box, mask) -> float:
    """Largest box edge of the boxes ``box`` selected by ``mask`` (0.0 if none)."""
    if not mask.any():
        return 0.0
    lo, hi = _rows(box, mask)
    return float(box_extent(lo, hi).max())


def _up(d: float) -> float:
    """A largest box edge rounded up one ulp (an upper bound; 0 stays 0)."""
    return float(np.nextafter(d, np.inf)) if d > 0 else 0.0


def _rows(box, mask):
    """The boxes (lo, hi) selected by ``mask`` (no copy when it selects all)."""
    return box if mask.all() else (box[0][mask], box[1][mask])


def consistent_scale(dim: int, sim_box, cut_box, dtype, max_rounds: int = MAX_ROUNDS,
                     table=None, flags=near_flags) -> Scale:
    """L from the cells that can meet (module docstring): broad phase -> L -> σ+ until
    the pad no longer shrinks. ``sim_box``: (lo, hi) per cell, or a
    :class:`~.cellboxes.CellBoxes` (boxes computed block by block; the same values);
    ``cut_box``: (lo, hi); ``flags``: as in :func:`near_cells`."""
    lean = hasattr(sim_box, "flag_pass")
    masks = (np.ones(len(sim_box) if lean else len(sim_box[0]), bool),
             np.ones(len(cut_box[0]), bool))
    ext_c = box_extent(*cut_box)  # once, not per round
    if lean:
        L_a = _up(sim_box.summary().ext_max) if len(sim_box) else 0.0
    else:
        L_a = _max_edge(box_extent(*sim_box), masks[0])
    L_b = _max_edge(ext_c, masks[1])
    cur = scale_for(dim, L_a, L_b, dtype, table)
    cur.masks, history, first = masks, [L_a + L_b], ()
    for _ in range(max_rounds):
        *nxt_masks, ext_s = _near(sim_box, cut_box, cur.pad, cur.masks, flags)
        first = first or tuple(nxt_masks)
        La, Lb = _up(ext_s), _max_edge(ext_c, nxt_masks[1])
        if La + Lb == 0:  # nothing can meet: keep the last sound scale
            break
        nxt = (replace(cur, reach=dict(cur.reach)) if (La, Lb) == (cur.L_a, cur.L_b) else
               scale_for(dim, La, Lb, dtype, table))  # (the same L: the same scale)
        if not nxt.pad <= cur.pad:  # L_k bounds pairs within cur.pad only
            break
        nxt.masks = tuple(nxt_masks)
        history.append(La + Lb)
        shrunk = nxt.pad < cur.pad
        cur = nxt
        if not shrunk:
            break
    cur.history, cur.first = history, first if len(history) == 1 else ()  # (memory)
    return cur


def estimate_cell_pairs(lo_a, hi_a, lo_b, hi_b, pad: float, blocks: Blocks = SERIAL) -> int:
    """Rough count of cell pairs within ``pad`` (per-grid-cell occupancy products on a
    grid of about the pad or the boxes' median size): the memory guard's input. Our own
    cheap count, independent of the broad phase's grid; exact integer arithmetic (no
    BLAS: the count decides refusals, docs/design.md). ``blocks``: the occupancy
    counts' passes (compiled or threaded: the same integers)."""
    if len(lo_a) == 0 or len(lo_b) == 0:
        return 0
    fast = compiled_count(lo_a, hi_a, lo_b, hi_b, pad) if blocks.accelerate else None
    if fast is not None:  # the dense count, its indices never stored (paircount.py)
        return fast
    grid = _compiled_grid if blocks.accelerate else _estimate_grid
    ia0, ia1, ib0, ib1, budget = grid(lo_a, hi_a, lo_b, hi_b, pad)
    fast = _dense_pair_count(ia0, ia1, ib0, ib1, budget, blocks)
    if fast is not None:
        return fast
    ka, kb = _cell_keys(ia0, ia1), _cell_keys(ib0, ib1)
    ua, ca = np.unique(ka, return_counts=True)
    ub, cb = np.unique(kb, return_counts=True)
    _, ja, jb = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
    return _count_dot(ca[ja], cb[jb])


def _estimate_grid(lo_a, hi_a, lo_b, hi_b, pad: float):
    """Grid indices (float arrays of integers: first and last cell per axis) of both
    meshes' boxes enlarged by ``pad``/2, on the estimate's grid, and the budget of
    covered cells the grid was coarsened to."""
    h = 0.5 * pad
    A0, A1, B0, B1 = lo_a - h, hi_a + h, lo_b - h, hi_b + h
    # reductions along the short rows column by column (numpy's are ~10x slower on
    # (n, 3) arrays; the same values: max, min exact, products in the same order)
    ext = np.concatenate([box_extent(A0, A1), box_extent(B0, B1)])
    origin = np.minimum(colmin(A0), colmin(B0))
    span = float((np.maximum(colmax(A1), colmax(B1)) - origin).max())
    # at most 2^20 cells per axis (as the broad phase's grid): point-like boxes with
    # pad 0 would otherwise get indices beyond int64
    g = max(float(np.median(ext)), float(pad), span * 2.0 ** -20, 1e-300)
    budget = 8 * (len(A0) + len(B0)) + (1 << 20)
    while True:
        ia0, ia1 = np.floor((A0 - origin) / g), np.floor((A1 - origin) / g)
        ib0, ib1 = np.floor((B0 - origin) / g), np.floor((B1 - origin) / g)
        na, nb = rowwise(np.multiply, ia1 - ia0 + 1), rowwise(np.multiply, ib1 - ib0 + 1)
        if na.sum() + nb.sum() <= budget:
            return ia0, ia1, ib0, ib1, budget
        g *= 2


def _compiled_grid(lo_a, hi_a, lo_b, hi_b, pad: float):
    """:func:`_estimate_grid`'s values by two compiled passes per side and cell size
    (:mod:`predicates.compiled.cellsums`: the padded boxes are never stored): the same
    indices, and the same coarsening decisions (integer counts, exact sums)."""
    from predicates.compiled.cellsums import pad_index

    d = lo_a.shape[1]
    h, sides, lo_min, hi_max, _, g, budget = grid_start(lo_a, hi_a, lo_b, hi_b, pad,
                                                        np.ascontiguousarray)
    out = [np.empty((len(lo), d)) for lo, _ in sides for _ in (0, 1)]
    while True:
        total = sum(pad_index(*side, h, lo_min, g, *out[2 * s:2 * s + 2])
                    for s, side in enumerate(sides))
        if total <= budget:
            return (*out, budget)
        g *= 2


def _dense_pair_count(ia0, ia1, ib0, ib1, budget: int, blocks: Blocks = SERIAL):
    """Σ over grid cells of (a boxes covering it) × (b boxes covering it) from two
    count grids (:func:`~predicates.registration.spatial.gridsums.coverage`),
    without expanding the boxes into cells — the same integer as the keyed count when
    :func:`_cell_keys` is injective on the grid (every index < its radix, no int64
    overflow); None otherwise (or when the grid has more than ``budget`` cells), and
    the caller counts by keys."""
    # cast while joining (astype's conversion, numpy's unsafe casting): one (n, d) copy
    # each, not two (the second's page faults cost as much as the cast: ~5 ms on W4)
    i0 = np.concatenate([ia0, ib0], dtype=np.int64, casting="unsafe")
    i1 = np.concatenate([ia1, ib1], dtype=np.int64, casting="unsafe")
    G = colmax(i1) + 1
    top = float(G[0])
    for g in G[1:]:
        top *= _KEY_RADIX
    if np.any(G[1:] > _KEY_RADIX) or top >= 2.0 ** 62 or float(np.prod(G + 1.0)) > budget:
        return None
    na = len(ia0)
    return _count_dot(coverage(i0[:na], i1[:na], G, blocks).ravel(),
                      coverage(i0[na:], i1[na:], G, blocks).ravel())


def memory_limit() -> int:
    """Default memory budget: half of the memory available now (Linux), else 4 GiB."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024 // 2
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 4 << 30


@dataclass
class Resolution:
    """What the run resolves, in input units (docs/resolution.md): σ+ (the largest T+, the reach
    of the broad phase) and the distance tolerances' T+ against the shortest simulation
    and cutting edges near the interface (cells within σ+ of the other mesh).

    ``coarse``: σ+ > :data:`COARSE_RATIO` × ``h_sim`` (then a
    :class:`fperr.ResolutionWarning` was issued). ``L_global``: the paper's L_a + L_b
    over every cell; ``L_a``, ``L_b``: over the cells that can meet (what was used).
    ``refined``: (input cutting cells, refined cells, rounds) or None (refinement off).
    ``cell_pairs``: estimated cell pairs within σ+ (the memory guard's count)."""

    dim: int
    dtype: str
    t_plus: dict
    h_sim: float | None
    h_cut: float | None
    L_a: float
    L_b: float
    L_global: float
    rounds: int
    refined: tuple | None
    cell_pairs: int
    tolerance_scale: float = 1.0

    @property
    def sigma_plus(self) -> float:
        return self.t_plus["sigma"] * self.tolerance_scale

    @property
    def ratio(self) -> float | None:
        """σ+ / shortest simulation edge near the cut (None if nothing is near)."""
        return None if not self.h_sim else self.sigma_plus / self.h_sim

    @property
    def coarse(self) -> bool:
        r = self.ratio
        return r is not None and r > COARSE_RATIO

    def lines(self) -> list[str]:
        """The report's lines for ``str(res)``."""
        tp = ", ".join(f"{n}+ = {v * self.tolerance_scale:.3g}" for n, v in self.t_plus.items())
        out = [f"resolution: {tp} (input units)"]
        if self.h_sim is None:
            out.append("  no simulation cell within σ+ of the cut: nothing can be registered")
        else:
            out.append(f"  shortest edge near the cut: simulation {self.h_sim:.3g}, cutting "
                       f"{self.h_cut:.3g}; σ+ = {self.ratio:.3g} × the simulation edge "
                       f"({'COARSE' if self.coarse else 'resolved'}: threshold "
                       f"{COARSE_RATIO:g})")
        out.append(f"  L_a + L_b over the cells that can meet = {self.L_a + self.L_b:.6g} "
                   f"(over every cell: {self.L_global:.6g}; {self.rounds} rounds)")
        if self.refined is None:
            out.append("  cutting mesh used as given (refinement off)")
        elif self.refined[0] != self.refined[1]:
            out.append(f"  cutting mesh refined: {self.refined[0]} -> {self.refined[1]} cells "
                       f"in {self.refined[2]} rounds (ids refer to the refined mesh)")
        return out

    def message(self) -> str:
        """One line: why the run is coarse and what to do."""
        adv = []
        if self.dtype == "float32":
            adv.append("use float64 (σ grows as ε^" + ("1/4" if self.dim == 3 else "1/2") + ")")
        if self.refined is None and self.L_b > self.L_a:
            adv.append("let the cutting mesh be refined (refine_cut=True, no --no-refine-cut)")
        if self.h_sim and self.L_a > 4 * self.h_sim:
            adv.append(f"split or drop the large or sliver simulation elements near the cut "
                       f"(box edge up to {self.L_a:.3g}, shortest edge {self.h_sim:.3g}: "
                       "L is the largest, the paper's L is global) or mesh it more uniformly")
        if not adv:
            adv.append("use a wider format or accept the coarseness (σ+ is set by the "
                       "elements near the cut and the format's ε)")
        return (f"coarse resolution: σ+ = {self.sigma_plus:.3g} is {self.ratio or 0:.3g} × "
                f"the shortest simulation edge near the cut ({self.h_sim or 0:.3g}; threshold "
                f"{COARSE_RATIO:g}), so crossings near vertices are registered at the "
                f"vertices and the result does not resolve this geometry; to fix: "
                + "; ".join(adv))

    def to_dict(self) -> dict:
        return {"t_plus": dict(self.t_plus), "sigma_plus": self.sigma_plus,
                "h_sim": self.h_sim, "h_cut": self.h_cut, "ratio": self.ratio,
                "coarse": self.coarse, "threshold": COARSE_RATIO, "L_a": self.L_a,
                "L_b": self.L_b, "L_global": self.L_global, "rounds": self.rounds,
                "refined": list(self.refined) if self.refined else None,
                "cell_pairs": self.cell_pairs}


def t_plus(dim: int, scale: Scale) -> dict:
    """T+ of the distance tolerances (power 1 of L) in input units."""
    L = math.ldexp(float(scale.tol.L), scale.e)
    eps = float(scale.tol.eps)
    specs = {n: scale.tol.spec(n) for n in scale.tol.values}
    return {n: float(s.hi) * eps ** float(s.q) * L for n, s in specs.items() if s.p == 1
            and n != "sigma_hat"}


def memory_error(res: Resolution, limit: int, dim: int, share: float = 1.0):
    """The memory guard's error (a :class:`fperr.ResolutionError`), or None. ``share``:
    the fraction of the cell pairs held at once (a partitioned run: its concurrent
    partitions' share, docs/partitioned.md)."""
    from fperr.warnings import ResolutionError

    need = res.cell_pairs * BYTES_PER_CELL_PAIR * share
    if need <= limit:
        return None
    what = "simulation" if dim == 3 else "2D simulation"
    return ResolutionError(
        f"refused before the work: about {res.cell_pairs:.3g} pairs of cells lie within "
        f"σ+ = {res.sigma_plus:.3g} of each other (≈{need / 2**30:.1f} GiB, limit "
        f"{limit / 2**30:.1f} GiB) because the tolerances are large relative to the "
        f"{what} elements near the cut (shortest edge {res.h_sim or 0:.3g}, "
        f"L_a + L_b = {res.L_a + res.L_b:.3g}); " + res.message().split("to fix: ", 1)[1])
