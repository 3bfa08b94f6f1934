"""The shortest edge of a set of cells, exactly, and its per-chunk summaries (the
resolution report's h_sim and h_cut: docs/resolution.md; combined from the workers'
chunks in a partitioned run: docs/partitioned.md 5a)."""
from __future__ import annotations

import numpy as np

from predicates.registration.plan.inputs import times_pow2
from predicates.registration.spatial.blocks import SERIAL, Blocks

__all__ = ["edge_from", "edge_shift", "edge_summary", "shortest_edge"]


def shortest_edge(points: np.ndarray, cells: np.ndarray, mask,
                  blocks: Blocks = SERIAL, boxes=None) -> float | None:
    """Shortest edge (binary64 length) of the selected cells, None if none; block by
    block (the minimum of the blocks' minima: exact). Computed on the coordinates scaled
    exactly by a power of two to magnitude ≤ 1, so that no square overflows or
    underflows (a mesh at 1e±300 has the same edges, scaled). ``boxes``: (lo, hi) of
    the selected cells (binary64), which give the largest |coordinate| without reading
    the points: compiled, the least squares are then read from the points as given
    (:func:`_least_from_boxes`; the same value)."""
    if not mask.any():
        return None
    sel = cells if mask.all() else cells[mask]
    least = None if boxes is None else _least_from_boxes(points, sel, boxes, blocks)
    if least is not None:
        return edge_from(*least)
    top, shift, least = edge_summary(points, sel, blocks)
    return edge_from(least, shift)


def _least_from_boxes(points, cells, boxes, blocks: Blocks):
    """(least, shift) of :func:`edge_summary` for 3D tetrahedra or triangles, compiled,
    from the cells' boxes and the points as given
    (:func:`predicates.compiled.edgerows.least_square_rows`): the largest |coordinate|
    of the vertices is max(−min lo, max hi) (a box's bounds are its vertices'
    coordinates), the scaling a product by 2^-shift as each point is read (times_pow2's
    values when 2^-shift is normal). None where that does not hold (the caller's path)."""
    lo, hi = boxes
    # (points not a C-ordered array — F-ordered, or pieces on the workers
    # (RemotePoints) — the copy's path, which gathers the used rows only)
    if not (blocks.accelerate and isinstance(points, np.ndarray) and points.shape[1] == 3
            and cells.shape[1] in (3, 4) and len(lo) == len(cells)
            and points.flags.c_contiguous):
        return None
    fi = np.finfo(np.float64)
    top = max(0.0, -float(lo.min()), float(hi.max()))  # (−0.0, 0.0: shift 0 either way)
    shift = edge_shift(top)
    if not fi.minexp < -shift < fi.maxexp:  # times_pow2 would take ldexp
        return None
    from predicates.compiled.edgerows import least_square_rows

    factor = float(np.ldexp(1.0, -shift))  # exact (not pow: libm's, last bit unpromised)
    return min(blocks.map(lambda a, b: float(least_square_rows(points, cells[a:b], factor)),
                          len(cells))), shift


def edge_from(least: float, shift: int) -> float:
    """The shortest edge from the least squared edge at scale 2^-shift
    (:func:`edge_summary`): sqrt is monotone and correctly rounded, the scaling exact."""
    return float(np.ldexp(np.sqrt(least), shift))


def edge_shift(top: float) -> int:
    """The exponent that scales coordinates of magnitude ≤ ``top`` to ≤ 1."""
    return int(np.frexp(top)[1]) if top > 0 and np.isfinite(top) else 0


def edge_summary(points: np.ndarray, cells: np.ndarray, blocks: Blocks = SERIAL,
                 shift: int | None = None):
    """(top, shift, least): the largest |coordinate| of the vertices ``cells`` use, the
    exponent :func:`edge_shift` of it (or ``shift`` if given) and the least squared
    edge of ``cells`` (≥ 1 row) in the coordinates scaled by 2^-shift. The minimum over
    chunks of cells with one shift is the whole's (min is exact), so per-chunk
    summaries on the workers combine to :func:`shortest_edge`'s value when their
    shifts agree (docs/partitioned.md 5a)."""
    ids, C = _renumbered(points, cells, blocks.accelerate)
    P = points[ids]
    top = float(np.abs(P).max()) if C.size else 0.0
    shift = edge_shift(top) if shift is None else shift
    # compiled: (n, d) rows, a vertex's coordinates in one cache line (the kernel's
    # gathers miss the cache: three column reads per vertex cost 1.5-2x); numpy's
    # per-axis takes: (d, n) columns. The same values either way (elementwise scaling)
    P = P if blocks.accelerate else P.T
    coords = times_pow2(np.ascontiguousarray(P, dtype=np.float64), -shift)
    return top, shift, _least_square(coords, C, blocks)


def _renumbered(points: np.ndarray, cells: np.ndarray, accelerate: bool):
    """(ids, C): the vertices the cells use (ascending) and the cells (k, m) renumbered
    into them — only these points are read, close together in memory."""
    if accelerate:  # the same integers in one compiled pass (cellsums.used_renumbered)
        from predicates.compiled.cellsums import used_renumbered

        return used_renumbered(np.ascontiguousarray(cells, dtype=np.int64), len(points))
    C = np.ascontiguousarray(np.asarray(cells).T)
    used = np.zeros(len(points), dtype=bool)  # the vertices of the selected cells
    for row in C:  # (a mask, not np.unique: its hash or sort costs seconds at 10^7)
        used[row] = True
    ids = np.flatnonzero(used)
    local = np.zeros(len(points), dtype=np.int64)
    local[ids] = np.arange(len(ids))
    return ids, local[C]


def _least_square(coords: np.ndarray, C: np.ndarray, blocks: Blocks) -> float:
    """The least squared edge of the cells ``C`` ((k, n) local ids into ``coords``:
    (n, d) rows when ``blocks.accelerate``, else (d, n) columns)."""
    k, dim = C.shape[0], coords.shape[0]  # (dim: the numpy path's)

    def span(a: int, b: int) -> float:
        if blocks.accelerate:  # the same sums, compiled (GIL-free; 3D tetrahedra
            from predicates.compiled.edgesquares import least_square_kernel  # unrolled)

            return float(least_square_kernel(coords.shape[1], k)(coords, C, a, b))
        best = np.inf
        for lo, hi in blocks.each(a, b):
            # per axis 1D takes (no (n, k, d) gather); the squares summed axis by axis
            # from the left, as an (n, d) array's .sum(1) adds them (same values); the
            # square root of the least sum (sqrt is monotone and correctly rounded: the
            # least root)
            X = [[coords[ax].take(C[v, lo:hi]) for ax in range(dim)] for v in range(k)]
            sq, t = np.empty(hi - lo), np.empty(hi - lo)
            for u in range(k):
                for v in range(u + 1, k):
                    for ax in range(dim):
                        np.subtract(X[u][ax], X[v][ax], out=t)
                        if ax == 0:
                            np.multiply(t, t, out=sq)
                        else:
                            sq += np.multiply(t, t, out=t)
                    best = min(best, float(sq.min()))
        return best

    return min(blocks.map(span, C.shape[1]))
