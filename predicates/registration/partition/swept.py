"""A chunk's validation, summary and first-round flags in one task and one sweep on a
worker (docs/partitioned.md section 2; :mod:`predicates.registration.plan.first_round`).

The first round's grid is fixed by the cutting mesh before the simulation cells are
read, so a worker that checks a chunk of tetrahedra can flag them in the same compiled
loop (:meth:`~predicates.registration.plan.cellboxes.CellBoxes.checked_summary` with a
grid): the flag pass's round of tasks is not needed when the grid turns out to be the
round's. The task returns what :func:`check_chunk` (validation and summary) and
:func:`chunk_flags` return (the same values: the same kernels' flags, tested
serially), or falls back to ``check_chunk`` alone (and the flag round later) where the
sweep does not apply. On the numpy path (no compiled sweep) the same task runs the flag
pass after the check, over the same boxes (its quiet shortcut:
:mod:`~predicates.registration.plan.quiet`).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.plan.cellboxes import CellBoxes
from predicates.registration.plan.edges import edge_summary
from predicates.registration.plan.inputs import _checked_and_used, first_bad
from predicates.registration.spatial.blocks import BLOCK, Blocks

__all__ = ["check_chunk", "check_swept", "chunk_flags", "covered", "cut_flags_from",
           "flagged_cover", "narrow_ids"]


def flagged_cover(i0: np.ndarray, i1: np.ndarray, G, blocks: Blocks):
    """What the client needs of a chunk's flagged cells' grid ranges [i0, i1] (the
    first round's cutting flags: :func:`~predicates.registration.plan.lean.cut_flags`,
    a cutting cell is flagged when its range holds a covered grid cell): the grid
    cells they cover as packed bits (:func:`~predicates.registration.spatial.gridsums.
    occupancy`, (G + 1)^d bits: 125 kB on W4 against 5.6 MB of ranges), or the ranges
    themselves when those are the smaller. Occupancy is an OR over any split of the
    boxes, so the chunks' combine exactly (:func:`covered`)."""
    from predicates.registration.spatial.gridsums import occupancy

    G = np.asarray(G, dtype=np.int64)
    if len(i0) and int(np.prod(G + 1)) // 8 < i0.nbytes + i1.nbytes:
        return np.packbits(occupancy(i0, i1, G, blocks).ravel())
    return i0, i1


def cut_flags_from(occ: np.ndarray, ib0, ib1, G, blocks: Blocks) -> np.ndarray:
    """The cutting cells' flags (ranges [ib0, ib1]) from the grid cells the flagged
    cells cover (``occ``, :func:`covered`): :func:`~predicates.registration.plan.lean.
    cut_flags`' values — compiled in 3D as it is (the occupied cells' summed-area table
    in one pass, the same integers: ``occ`` as 0/1 counts), else
    :func:`~predicates.registration.spatial.gridsums.any_in`."""
    from predicates.registration.plan.lean import looked_up
    from predicates.registration.spatial.gridsums import any_in

    if not (blocks.accelerate and len(G) == 3):
        return any_in(occ, ib0, ib1, G, blocks)
    from predicates.compiled.cellsums import occupied_table

    # 0/1 counts as they are: no int32 copy (seventh pass)
    cover = occ.view(np.uint8) if occ.dtype == bool else occ
    S = np.empty(cover.shape, dtype=np.int32 if cover.size < 2 ** 31 else np.int64)
    occupied_table(cover, S)
    return looked_up(S.ravel(), ib0, ib1, G, blocks)


def covered(covers: list, G, blocks: Blocks):
    """(i0, i1, None) when every chunk sent its ranges (:func:`flagged_cover`: they
    are concatenated), else (None, None, the grid cells any chunk's flagged cells cover
    — :func:`~predicates.registration.spatial.gridsums.occupancy` of all of them)."""
    from predicates.registration.spatial.gridsums import occupancy

    ranges = [c for c in covers if isinstance(c, tuple)]
    if len(ranges) == len(covers):
        return (*(np.concatenate([c[s] for c in covers]) for s in (0, 1)), None)
    G = np.asarray(G, dtype=np.int64)
    shape = tuple((G + 1)[::-1])
    bits = np.bitwise_or.reduce([c for c in covers if not isinstance(c, tuple)])
    occ = np.unpackbits(bits, count=int(np.prod(G + 1))).view(bool).reshape(shape)
    if ranges:  # the chunks that sent ranges: their occupancy added (an OR)
        i0, i1 = (np.concatenate([c[s] for c in ranges]) for s in (0, 1))
        occ |= occupancy(i0, i1, G, blocks)
    return None, None, occ


def narrow_ids(cells: np.ndarray, n_points: int) -> np.ndarray:
    """Valid vertex ids (each below ``n_points``) as int32 when every id fits: half the
    bytes a flagged cell costs the client to receive and concatenate (the same ids)."""
    if cells.dtype.itemsize > 4 and n_points <= 2 ** 31:
        return cells.astype(np.int32)
    return cells


def check_chunk(chunk, points, n_points: int, mark_used: bool = True,
                accelerate: bool = False, local=None):
    """A chunk's validation and summary: (first bad rows per check, the vertices it
    uses as packed bits (none unless ``mark_used``: points on the workers check their
    own, :mod:`.points`), its BoxSummary — None when a check failed). ``local``: the
    chunk's rows in the numbering of ``points`` (a piece's own), else ``chunk``.
    ``accelerate``: the serial plan's compiled passes (:func:`~predicates.registration.
    plan.inputs._checked_and_used`'s checks and marks in one loop, the summary's
    compiled blocks: the same rows, marks and summary)."""
    from predicates import compiled

    blocks = Blocks(accelerate=accelerate and compiled.available())
    chunk = np.asarray(chunk)
    bad, used = _validated(chunk, n_points, mark_used, blocks)
    if any(b is not None for b in bad):
        return bad, np.packbits(used[:0]), None
    return bad, np.packbits(used), CellBoxes(points, chunk if local is None else local,
                                             blocks).summary()


def _validated(chunk: np.ndarray, n_points: int, mark_used: bool, blocks: Blocks):
    """(first bad rows per check, the vertices used — empty unless ``mark_used``)."""
    used = np.zeros(n_points if mark_used or blocks.accelerate else 0, dtype=bool)
    if blocks.accelerate and chunk.dtype.kind == "i" and chunk.size:
        bad = _checked_and_used(chunk, n_points, blocks, used)
    else:
        bad = first_bad(chunk, chunk.shape[1], n_points)
        if mark_used and all(b is None for b in bad):  # (blocks of rows, raveled: a
            # third of the time of a strided column at a time, as inputs.py marks them)
            for a in range(0, len(chunk), BLOCK):
                used[chunk[a:a + BLOCK].ravel()] = True
    return bad, used if mark_used else used[:0]


def check_swept(chunk, points, n_points: int, mark_used: bool, accelerate: bool, grid,
                local=None):
    """(:func:`check_chunk`'s result, :func:`chunk_flags`' result or None) for one
    chunk; ``grid`` = (origin, h, G, table) of the speculative first-round grid. The
    sweep applies to compiled tetrahedra over finite points; on the numpy path the
    flags are a pass after the check in the same task (:func:`_checked_then_flagged`);
    elsewhere, or at a row validation refuses (whose message the plain check then
    makes), the flags are None. ``local``: a
    piece's cells in the numbering of its own ``points`` (:mod:`.pieces`): ``chunk``
    (global ids) is validated as :func:`check_chunk` validates it, the sweep runs over
    ``local``, and the flagged cells come back in global ids with their boxes (the
    client has no points to compute them from)."""
    from predicates import compiled

    blocks = Blocks(accelerate=accelerate and compiled.available())
    chunk = np.asarray(chunk)
    own = chunk if local is None else np.asarray(local)
    if not blocks.accelerate and own.dtype.kind in "iu" and len(own):
        return _checked_then_flagged(chunk, own, points, n_points, mark_used, grid,
                                     local is not None, blocks)
    from predicates.compiled.tetsums import all_finite
    from predicates.registration.plan.first_round import FixedGrid

    if (blocks.accelerate and own.dtype.kind == "i" and own.shape[1] == 4
            and chunk.dtype.kind == "i" and points.shape[1] == 3 and len(own)
            and points.flags.c_contiguous and all_finite(points)):
        if local is None:  # the sweep checks the rows and marks the used vertices
            used = swept_used = np.zeros(n_points, dtype=bool)
        else:  # the global ids checked here; the piece's own are valid by construction
            bad, used = _validated(chunk, n_points, mark_used, blocks)
            if any(b is not None for b in bad):
                return (bad, np.packbits(used[:0]), None), None
            swept_used = np.zeros(len(points), dtype=bool)
        origin, h, G, table = grid
        fixed = FixedGrid(None, None, len(own), h, 0.0, origin, G, None, None, table)
        summary = CellBoxes(points, own, blocks).checked_summary(swept_used, fixed)
        if summary is not None:
            return _swept_result(summary, points, chunk, local, n_points, used,
                                 mark_used, blocks, G)
    return check_chunk(chunk, points, n_points, mark_used, accelerate, local), None


def _checked_then_flagged(chunk, own, points, n_points: int, mark_used: bool, grid,
                          piece: bool, blocks: Blocks) -> tuple:
    """:func:`check_swept` on the numpy path: :func:`check_chunk`'s validation, then,
    when it passes and every point is finite (as the compiled sweep asks), the summary
    and the flags at ``grid`` in one pass over the boxes
    (:func:`~predicates.registration.plan.quiet.swept_summary`), given as
    :func:`chunk_flags` gives them — one task instead of two rounds. ``piece``: ``own`` are a piece's local ids, ``chunk`` its
    global ones."""
    bad, used = _validated(chunk, n_points, mark_used, blocks)
    if any(b is not None for b in bad):
        return (bad, np.packbits(used[:0]), None), None
    from predicates.registration.plan.first_round import FixedGrid

    boxes = CellBoxes(points, own, blocks, checked=True)
    with np.errstate(invalid="ignore"):
        finite = bool(np.isfinite(points).all())
    if finite:  # the flags in the summary's pass (quiet.swept_summary)
        origin, h, G, table = grid
        boxes.sweep_grid = FixedGrid(None, None, len(own), h, 0.0, origin, G, None, None,
                                     table)
    checked = (bad, np.packbits(used), boxes.summary())
    if not finite:
        return checked, None
    return checked, chunk_flags(boxes, *grid, chunk if piece else None, n_points)


def chunk_flags(boxes: CellBoxes, origin, h, G, table, chunk=None,
                n_points: int | None = None) -> tuple:
    """A chunk's first-round flags (:func:`~predicates.registration.plan.lean.flag_pass`
    over ``boxes``) as (count, (flagged rows (int32 below 2^31 rows), the grid cells
    their ranges cover (:func:`flagged_cover`: packed bits, or the ranges i0, i1),
    largest edge, their vertex ids (the pass's kept rows when it kept them: no
    gather), the flagged cells' :func:`~predicates.registration.plan.edges.
    edge_summary` or None, their boxes or None)): the report's shortest edge of the
    run's cells rides on this task, as those cells are round one's flags unless a later
    round shrinks them. Their boxes are not sent: the client computes them from its
    points as fast as it receives 48 bytes a cell (docs/partitioned.md 5a, measured) —
    unless ``chunk`` (a piece's cells in global ids, ``boxes`` in its own numbering;
    ``n_points``: the global count): the vertex ids are then global and the boxes
    sent (the client has no points to compute them from)."""
    count, got = boxes.flag_pass(origin, h, G, table)
    if got is None:
        return count, None
    near, i0, i1, ext = got
    ids = np.flatnonzero(near)
    cells = boxes.cells_of(near)  # the pass's kept rows when it kept them: no gather
    edge = edge_summary(boxes.points, cells, boxes.blocks) if len(ids) else None
    flagged_boxes = None
    if chunk is not None:
        cells, flagged_boxes = np.take(chunk, ids, axis=0), boxes.rows(near)
    if len(near) < 2 ** 31:
        ids = ids.astype(np.int32)  # (the client adds the chunk's int64 offset)
    return count, (ids, flagged_cover(i0, i1, G, boxes.blocks), ext,
                   narrow_ids(cells, len(boxes.points) if n_points is None else n_points),
                   edge, flagged_boxes)


def _swept_result(summary, points, chunk, local, n_points: int, used, mark_used: bool,
                  blocks: Blocks, G) -> tuple:
    """:func:`check_swept`'s result from the sweep's ``summary`` (its flags kept in
    ``summary.first``, taken out here); the flagged cells' ranges as
    :func:`flagged_cover` (G: the grid's cells per axis)."""
    (count, (near, i0, i1, ext)), (lo, hi, cells) = summary.first[1]
    summary.first = None
    ids = np.flatnonzero(near)
    edge = edge_summary(points, cells, blocks) if len(ids) else None
    boxes = None
    if local is not None:  # the flagged cells in global ids, their boxes (the sweep's)
        cells, boxes = np.take(chunk, ids, axis=0), (lo, hi)
    if len(near) < 2 ** 31:
        ids = ids.astype(np.int32)  # (the client adds the chunk's int64 offset)
    used = used if mark_used else used[:0]
    return (([None] * 3, np.packbits(used), summary),
            (count, (ids, flagged_cover(i0, i1, G, blocks), ext,
                     narrow_ids(cells, n_points), edge, boxes)))
