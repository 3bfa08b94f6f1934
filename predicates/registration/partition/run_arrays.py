"""A partitioned plan's run arrays (docs/partitioned.md, section 5a, "The client's
share"): the scaled coordinates of the run cells' vertices (``Plan.P_sim``), their
global ids (``Plan.sim_vertex_ids``) and the run cells renumbered to them
(``Plan.sim_cells``).

With the simulation cells on the workers (:mod:`.remote`) the split runs there too
(:mod:`.split_remote`: each chunk scales its own run vertices, element-wise, the same
rows), so nothing in such a run reads these arrays — unless it takes the client's
split (a run written to per-partition files, a cutting or run mesh that is empty).
Their computation (the vertices' mask, the gather, the renumbering of every run cell:
~50 ms of the client's CPU on W4) is then deferred: :class:`DeferredRun` stands for
them in the plan and :func:`materialised` computes them — the same arrays, bit for bit
— when the client's split needs them. Every point is still checked before any work
(the serial refusals, in the serial order: :func:`checked_scaling`).
"""
from __future__ import annotations

import numpy as np

from predicates.registration.plan.inputs import (
    renumbered, run_vertices, scale_points, times_pow2)
from predicates.registration.partition.points import RemotePoints

__all__ = ["DeferredRun", "checked_scaling", "materialised", "run_arrays", "scaled_points"]

#: rows per block of :func:`checked_scaling`'s compiled pass (one reused buffer)
STEP = 1 << 16


class DeferredRun:
    """The run arrays of a plan whose cells are on the workers, not computed yet:
    ``len()`` is the run cells' count (what the client's bookkeeping reads); the plan
    holds it as ``sim_cells`` and ``sim_vertex_ids`` (``P_sim`` None) until
    :func:`materialised`."""

    def __init__(self, points: np.ndarray, run: np.ndarray, e: int, fast: bool):
        if run.dtype.itemsize > 4 and len(points) < 2 ** 31:  # the same ids, half the
            run = run.astype(np.int32)  # bytes held through the tasks (7.7 MB on W4)
        self.points, self.run, self.e, self.fast = points, run, e, fast

    def __len__(self) -> int:
        return len(self.run)

    def arrays(self) -> tuple:
        """(the run's vertices (ascending global ids), their coordinates scaled by
        2^-e, the run cells in their positions): :func:`run_arrays`' values."""
        keep = run_vertices(self.run, len(self.points))
        return keep, times_pow2(self.points[keep], -self.e), renumbered(self.run, keep,
                                                                        self.fast)


def materialised(plan):
    """``plan`` with its run arrays computed if they were deferred (else ``plan``)."""
    deferred = plan.sim_vertex_ids
    if not isinstance(deferred, DeferredRun):
        return plan
    keep, P_sim, cells = deferred.arrays()
    return plan._replace(P_sim=P_sim, sim_cells=cells, sim_vertex_ids=keep)


def checked_scaling(points: np.ndarray, e: int, accelerate: bool = False) -> None:
    """Refuse as :func:`~predicates.registration.plan.inputs.scale_points` refuses
    ``points``·2^-e (an overflow anywhere first, else the first inexact block), keeping
    nothing: compiled block by block into one buffer
    (:func:`predicates.compiled.cellsums.scale_exact`: the same two tests), the numpy
    checks on a refusal (their messages); the numpy checks alone otherwise."""
    fi = np.finfo(points.dtype)
    if accelerate and fi.minexp < -abs(e) and abs(e) < fi.maxexp and len(points):
        from predicates.compiled.cellsums import scale_exact

        ty = points.dtype.type
        buf = np.empty((min(STEP, len(points)),) + points.shape[1:], dtype=points.dtype)
        factor, back, limit = ty(2.0 ** -e), ty(2.0 ** e), float(fi.max / 16)
        refused = False
        for a in range(0, len(points), STEP):
            block = np.ascontiguousarray(points[a:a + STEP])
            over, inexact = scale_exact(block, buf[:len(block)], factor, back, limit)
            if over or inexact:
                refused = True
                break
        if not refused:
            return
    scale_points(points, e, "simulation", np.zeros(0, dtype=np.int64))  # raises if bad


def scaled_points(points, run: np.ndarray, e: int, partitioned: bool,
                  accelerate: bool = False):
    """(the run's vertices (ascending global ids) or None, the simulation points scaled
    by 2^-e): ``inputs.scale_points`` — every point checked, a partitioned run's plan
    keeping only the vertices of its cells ``run`` — or, for points on the workers
    (:class:`~.points.RemotePoints`), checked and scaled there, only those rows back;
    ``accelerate``: scale_points' compiled pass (the same values and refusals)."""
    if isinstance(points, RemotePoints):
        keep = np.unique(run).astype(np.int64)  # the run's vertices: no mask of N
        return keep, points.scaled(e, "simulation", keep)
    keep = run_vertices(run, len(points)) if partitioned else None
    return keep, scale_points(points, e, "simulation", keep, accelerate=accelerate)


def run_arrays(sim, run: np.ndarray, e: int, partitioned: bool, accelerate: bool = False,
               defer: bool = False) -> tuple:
    """(``Plan.sim_vertex_ids``, ``Plan.P_sim``, ``Plan.sim_cells``) for the run cells
    ``run`` (global ids) of the validated simulation mesh ``sim``: serially (every
    point scaled, ``run`` as it is) or a partitioned run's (:func:`scaled_points`, the
    run cells renumbered); ``defer``: its cells are on the workers and its points here
    — every point checked now, the arrays a :class:`DeferredRun` (module docstring)."""
    points = sim.points
    if defer and partitioned and not isinstance(points, RemotePoints):
        checked_scaling(points, e, accelerate)
        deferred = DeferredRun(points, run, e, accelerate)
        return deferred, None, deferred
    keep, P_sim = scaled_points(points, run, e, partitioned, accelerate)
    return keep, P_sim, run if keep is None else renumbered(run, keep, accelerate)
