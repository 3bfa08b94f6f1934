"""Summed-area tables over a box grid (for :mod:`predicates.registration.spatial.broadphase`):
which grid cells a set of boxes covers, and whether a box's cell range holds a covered
cell — without expanding any box into its cells. O(2^d) work per box plus the grid.

Cell ranges are inclusive index ranges [i0, i1] per axis on a grid of G cells per axis;
keys are linear on the (G + 1)-grid, axis 0 fastest.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.spatial.blocks import SERIAL, Blocks

__all__ = ["any_in", "coverage", "covered_in", "occupancy"]


def _stride(G):
    """Strides of the linear keys on the (G + 1)-grid, axis 0 fastest."""
    return np.cumprod(np.concatenate([[1], (G + 1)[:-1]])).astype(np.int64)


def _corners(i0, i1, G):
    """(linear key on the (G + 1)-grid, sign) of the 2^d corners {i0, i1 + 1} of each
    box's cell range; sign (−1)^(number of i0 picks) (inclusion–exclusion). Keys are sums
    of per-axis terms (two candidates per axis, computed once)."""
    d = len(G)
    stride = _stride(G)
    lo = [i0[:, ax].astype(np.int64) * stride[ax] for ax in range(d)]
    up = [(i1[:, ax].astype(np.int64) + 1) * stride[ax] for ax in range(d)]
    for pick in range(1 << d):
        key = (up if pick & 1 else lo)[0].copy()
        for ax in range(1, d):
            key += (up if pick >> ax & 1 else lo)[ax]
        yield key, (-1) ** (d - bin(pick).count("1"))


def coverage(i0, i1, G, blocks: Blocks = SERIAL, dtype=np.int64):
    """How many boxes cover each cell, as a C-order ``dtype`` array of shape
    reversed(G + 1) (axis 0 of the boxes is the last, fastest axis), last row of every
    axis unused. Block by block (``np.add.at`` of ±1 at each box's corners into one
    difference array per span; the spans' arrays are summed: integers, exact; every
    prefix sum is a count of boxes, so int32 is exact below 2^31 boxes)."""
    size = int(np.prod(G + 1))
    flip = len(G) % 2

    def span(a: int, b: int) -> np.ndarray:
        diff = np.zeros(size, dtype=dtype)
        for lo, hi in blocks.each(a, b):
            if blocks.accelerate:  # the same counts, compiled (GIL-free)
                from predicates.compiled.cells import add_corners

                add_corners(i0[lo:hi], i1[lo:hi], _stride(G), diff, flip)
                continue
            for key, sign in _corners(i0[lo:hi], i1[lo:hi], G):
                np.add.at(diff, key, -sign if flip else sign)
        return diff

    parts = blocks.map(span, len(i0))
    diff = parts[0]
    for p in parts[1:]:
        diff += p
    cover = diff.reshape(tuple((G + 1)[::-1]))
    if blocks.accelerate:  # the same integers, one compiled call (~10× numpy's cumsum)
        from predicates.compiled.prefix import prefix_sums

        return prefix_sums(cover)
    for ax in range(cover.ndim):
        np.cumsum(cover, axis=ax, out=cover)
    return cover


def occupancy(i0, i1, G, blocks: Blocks = SERIAL):
    """Cells covered by at least one box (:func:`coverage` > 0). Compiled, its counts
    in int32 when they fit: half the grid's memory traffic (not on the numpy path:
    ``np.add.at`` into int32 takes a casting slow path, ~10× slower)."""
    small = blocks.accelerate and len(i0) < 2 ** 31 - 1
    return coverage(i0, i1, G, blocks, np.int32 if small else np.int64) > 0


def any_in(occ, i0, i1, G, blocks: Blocks = SERIAL):
    """Per box: does its cell range [i0, i1] contain an occupied cell (summed-area
    table of ``occ`` over the (G + 1)-grid, 2^d look-ups per box, block by block)."""
    S = np.zeros(tuple((G + 1)[::-1]), dtype=np.int32 if occ.size < 2 ** 31 else np.int64)
    inner = tuple(slice(1, None) for _ in range(occ.ndim))
    S[inner] = occ[tuple(slice(None, -1) for _ in range(occ.ndim))]
    for ax in range(S.ndim):
        np.cumsum(S, axis=ax, out=S)
    S = S.ravel()
    out = np.empty(len(i0), dtype=bool)

    def look(lo: int, hi: int) -> None:
        if blocks.accelerate:  # the same flags, compiled (GIL-free)
            from predicates.compiled.cells import look_corners

            look_corners(S, i0[lo:hi], i1[lo:hi], _stride(G), out[lo:hi])
            return
        count = np.zeros(hi - lo, dtype=S.dtype)
        for key, sign in _corners(i0[lo:hi], i1[lo:hi], G):
            if sign > 0:
                count += S.take(key)
            else:
                count -= S.take(key)
        np.greater(count, 0, out=out[lo:hi])

    blocks.rows(look, len(i0))
    return out


def covered_in(S: np.ndarray, i0, i1, G) -> np.ndarray:
    """Per box: does its cell range hold an occupied cell (2^d look-ups in the
    summed-area table ``S``, raveled on the (G + 1)-grid)."""
    count = np.zeros(len(i0), dtype=S.dtype)
    for key, sign in _corners(i0, i1, G):
        if sign > 0:
            count += S.take(key)
        else:
            count -= S.take(key)
    return count > 0
