"""The points of a mesh stored in pieces, kept on the workers (docs/partitioned.md
section 6, "Points on the workers"): the client holds nothing per point.

The pieces' points (:mod:`.pieces`) are exchanged between the workers into R ranges of
global ids (R = the piece count): each piece sends every range its rows there (their
positions in the piece, global ids, coordinates and whether the piece's cells use
them), and each range's task assembles point g as :func:`.pieces.assemble_points` would
— the first piece holding g gives it, a later piece with other bits is refused naming
both — so the shared points are compared where they meet, on the workers; the client
receives per range a few numbers and reduces them to the serial refusal (the first
piece and row in the pieces' order, the count of ids held by none).

:class:`RemotePoints` is what the plan and the result see instead of an (N, d) array:
the points' checks (finite, representable in the working dtype: the serial
``inputs._points`` messages) and the exact scaling's refusals (overflow before
underflow, ``inputs.scale_points``' messages) are per-range tasks reduced on the
client, and only the run's vertices' scaled coordinates come back (24 bytes per run
vertex). A point is "used" exactly when some piece's cells use it: a cell is in one
piece, and that piece holds its vertices. Anything else that asks for coordinates —
rows by id, the whole array (``np.asarray``), the result's ``sim_points`` as a dask
array — is fetched from the ranges on demand.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from predicates.registration.plan.inputs import _check_scaled, times_pow2, times_pow2_quiet

__all__ = ["RemotePoints", "points_on_workers"]


class PointRange(NamedTuple):
    """Global points [lo, lo + len(coords)) as the pieces give them (float64), and
    whether some piece's cells use each (held by a worker)."""

    lo: int
    coords: np.ndarray
    used: np.ndarray


def _split_piece(piece, bounds: np.ndarray) -> tuple:
    """A piece's rows per range of ``bounds``: (positions in the piece, global ids,
    coordinates, used by the piece's cells), in the piece's row order."""
    used = np.zeros(len(piece.ids), dtype=bool)
    for col in range(piece.local.shape[1]):
        used[piece.local[:, col]] = True
    which = np.searchsorted(bounds, piece.ids, side="right") - 1
    order = np.argsort(which, kind="stable")  # stable: the piece's order in each range
    edges = np.searchsorted(which[order], np.arange(len(bounds)))
    return tuple((pos, piece.ids[pos], piece.points[pos], used[pos])
                 for pos in (order[edges[r]:edges[r + 1]] for r in range(len(bounds) - 1)))


def _assemble(lo: int, hi: int, d: int, *parts) -> tuple:
    """Range [lo, hi) from every piece's part (in the pieces' order): (PointRange, its
    summary (the first differing shared point: (piece, row, id, its coordinates, the
    first holder's, the first holder) or None; ids held by none: count, first))."""
    points = np.zeros((hi - lo, d), dtype=np.float64)
    owner = np.full(hi - lo, -1, dtype=np.int32)
    used = np.zeros(hi - lo, dtype=bool)
    differ_at = None
    for i, (pos, ids, coords, u) in enumerate(parts):
        at = ids - lo
        seen = owner[at] >= 0
        # bits, not values: -0.0 and 0.0, or two NaNs, are not "the same point" here
        differ = seen & np.any(points[at].view(np.uint64) != coords.view(np.uint64), axis=1)
        if differ.any():  # the pieces after this one do not matter (the serial order)
            j = int(np.flatnonzero(differ)[0])
            differ_at = (i, int(pos[j]), int(ids[j]), coords[j].tolist(),
                         points[at[j]].tolist(), int(owner[at[j]]))
            break
        points[at[~seen]] = coords[~seen]
        owner[at[~seen]] = i
        used[at[u]] = True
    none = np.flatnonzero(owner < 0)
    first = int(none[0]) + lo if len(none) else None
    return PointRange(lo, points, used), (differ_at, len(none), first)


def _summary(assembled: tuple):
    return assembled[1]


def _range(assembled: tuple) -> PointRange:
    return assembled[0]


def _values(rng: PointRange, dtype) -> np.ndarray:
    """The range in the working ``dtype`` as the serial validation gives it (rows no
    cell uses set to 0), or as given (``dtype`` None)."""
    if dtype is None:
        return rng.coords
    with np.errstate(all="ignore"):  # checked by _check_range
        out = rng.coords.astype(dtype)
    out[~rng.used] = 0
    return out


def _check_range(rng: PointRange, dtype) -> tuple:
    """The serial points check (``inputs._points``) of a range's used rows: (the first
    non-finite one's global id and row, or None; their largest |coordinate|; overflow
    in ``dtype``; rounded by it)."""
    sel = rng.coords[rng.used]
    if not len(sel):
        return None, 0.0, False, False
    finite = np.isfinite(sel)
    if not finite.all():
        j = int(np.argwhere(~finite)[0, 0])
        g = int(np.flatnonzero(rng.used)[j])
        return (rng.lo + g, rng.coords[g]), None, False, False
    top = float(np.abs(sel).max())
    if np.dtype(dtype) == sel.dtype:
        return None, top, False, False
    with np.errstate(all="ignore"):
        out = sel.astype(dtype)
    if not np.isfinite(out).all():
        return None, top, True, False
    rounded = bool(np.any(out.astype(np.result_type(sel.dtype, out.dtype)) != sel))
    return None, top, False, rounded


def _scale_range(rng: PointRange, dtype, e: int, role: str, keep: np.ndarray) -> tuple:
    """``inputs.scale_points`` of a range in ``dtype``: (the overflow refusal's message
    or None, the inexact one's or None, the rows ``keep`` (global ids) scaled)."""
    block = _values(rng, dtype)
    out = times_pow2_quiet(block, -e)
    msgs = []
    for kw in (dict(exact=False), dict(overflow=False)):
        try:
            _check_scaled(block, out, e, role, **kw)
            msgs.append(None)
        except ValueError as err:
            msgs.append(str(err))
    return msgs[0], msgs[1], out[keep - rng.lo]


def _rows(rng: PointRange, dtype, ids: np.ndarray) -> np.ndarray:
    return _values(rng, dtype)[ids - rng.lo]


class RemotePoints:
    """The (N, d) points of pieces, held on the workers in ranges of global ids
    (module docstring): ``shape``, ``dtype`` (float64 as given, or the working dtype
    after :meth:`checked`), ``len()``; coordinates only on demand."""

    ndim = 2

    def __init__(self, ranges: list, bounds: np.ndarray, d: int, scheduler, dtype=None):
        self.ranges, self.bounds, self.scheduler = ranges, bounds, scheduler
        self.shape = (int(bounds[-1]), d)
        self.working = dtype  # None: the coordinates as given
        self.dtype = np.dtype(np.float64 if dtype is None else dtype)
        self._kept = None  # (ids, scaled rows, e) of the run's vertices, once scaled

    def __len__(self) -> int:
        return self.shape[0]

    def _compute(self, f, *args, per_range=None) -> list:
        """``f(range, *args[, per_range[r]])`` for every range, on the workers."""
        import dask

        extra = [()] * len(self.ranges) if per_range is None else [(a,) for a in per_range]
        tasks = [dask.delayed(f, pure=False)(r, *args, *x)
                 for r, x in zip(self.ranges, extra)]
        return list(dask.compute(*tasks, scheduler=self.scheduler))

    def checked(self, role: str, dtype) -> tuple[RemotePoints, bool]:
        """The serial points check in ``dtype`` (``inputs._points``: NaN or infinity
        at the first used point by global id, then an overflow of ``dtype`` with the
        largest used |coordinate|), on the workers: (these points in ``dtype``,
        rounded?)."""
        got = self._compute(_check_range, np.dtype(dtype))
        bad = [g[0] for g in got if g[0] is not None]
        if bad:
            g, row = min(bad, key=lambda b: b[0])
            raise ValueError(f"{role} points contain NaN or infinity (point {g}: {row})")
        if any(g[2] for g in got):
            raise ValueError(f"{role} points overflow {np.dtype(dtype).name}: coordinates "
                             f"up to {max(g[1] for g in got):.3g}")
        return (RemotePoints(self.ranges, self.bounds, self.shape[1], self.scheduler,
                             np.dtype(dtype)), any(g[3] for g in got))

    def scaled(self, e: int, role: str, keep: np.ndarray) -> np.ndarray:
        """``inputs.scale_points(points, e, role, keep)`` on the workers: every point
        checked (an overflow anywhere refused before an inexact one, the same
        messages), the rows ``keep`` (ascending global ids) returned scaled."""
        keep = np.asarray(keep, dtype=np.int64)
        cut = np.searchsorted(keep, self.bounds)
        got = self._compute(_scale_range, self.working, e, role,
                            per_range=[keep[cut[r]:cut[r + 1]]
                                       for r in range(len(self.ranges))])
        for t in (0, 1):
            msg = next((g[t] for g in got if g[t] is not None), None)
            if msg is not None:
                raise ValueError(msg)
        out = np.concatenate([g[2] for g in got]) if got else np.zeros((0, self.shape[1]))
        self._kept = (keep, out, e)
        return out

    def take(self, ids) -> np.ndarray:
        """The rows ``ids`` (global ids, any order): from the scaled run's vertices when
        they hold them (scaled back: exact), else fetched from the ranges."""
        shape = np.shape(ids)
        ids = np.asarray(ids, dtype=np.int64).ravel()  # (cells (m, k): rows (m, k, d))
        return self._take(ids).reshape(*shape, self.shape[1])

    def _take(self, ids: np.ndarray) -> np.ndarray:
        if self._kept is not None and len(ids):
            keep, out, e = self._kept
            pos = np.minimum(np.searchsorted(keep, ids), max(len(keep) - 1, 0))
            if len(keep) and np.array_equal(keep[pos], ids):
                return times_pow2(out[pos], e)
        order = np.argsort(ids, kind="stable")
        sorted_ids = ids[order]
        cut = np.searchsorted(sorted_ids, self.bounds)
        got = self._compute(_rows, self.working, per_range=[
            sorted_ids[cut[r]:cut[r + 1]] for r in range(len(self.ranges))])
        rows = np.empty((len(ids), self.shape[1]), dtype=self.dtype)
        rows[order] = np.concatenate(got) if got else rows[:0]
        return rows

    def __getitem__(self, key):
        if isinstance(key, (list, np.ndarray)) and np.asarray(key).dtype.kind in "iu":
            return self.take(key)
        return np.asarray(self)[key]  # anything else: the whole array, on demand

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        """Every point, gathered on the client (on demand only: N·d numbers)."""
        out = np.concatenate(self._compute(_values, self.working))
        return out if dtype is None else out.astype(dtype)

    def to_dask(self):
        """The points as a dask array, one chunk per range, computed where they are
        (the result's ``sim_points``: nothing of size N on the client until asked)."""
        import dask
        import dask.array as da

        chunks = [da.from_delayed(dask.delayed(_values, pure=True)(r, self.working),
                                  shape=(int(b - a), self.shape[1]), dtype=self.dtype)
                  for r, a, b in zip(self.ranges, self.bounds[:-1], self.bounds[1:])]
        return da.concatenate(chunks) if chunks else da.zeros((0, self.shape[1]))


def points_on_workers(paths: list, read: list, n: int, d: int, client, scheduler):
    """The pieces ``read`` (their futures on ``client``, or delayed reads on a local
    ``scheduler``) exchanged into ranges of global ids on the workers and checked there
    (module docstring): a :class:`RemotePoints`, or the serial refusal (a shared point
    whose bits differ, naming both pieces; ids held by no piece)."""
    import dask

    from predicates.registration.io.read import MeshFileError

    count = max(1, min(len(read), n))
    bounds = np.array([n * r // count for r in range(count + 1)], dtype=np.int64)
    split = [dask.delayed(_split_piece, nout=count, pure=True)(r, bounds) for r in read]
    both = [dask.delayed(_assemble, pure=True)(int(bounds[r]), int(bounds[r + 1]), d,
                                               *[s[r] for s in split])
            for r in range(count)]
    if client is not None:  # assembled once, kept there: the ranges' futures
        both = client.persist(both)
    ranges = [dask.delayed(_range, pure=True)(b) for b in both]
    if client is not None:
        ranges = client.persist(ranges)
    sums = dask.compute(*[dask.delayed(_summary)(b) for b in both],
                        scheduler=client or scheduler)
    differ = [s[0] for s in sums if s[0] is not None]
    if differ:
        i, _, g, here, there, first = min(differ, key=lambda x: (x[0], x[1]))
        raise MeshFileError(paths[i], f"global point {g} has coordinates {here} here and "
                                      f"{there} in {paths[first]}: a point shared by "
                                      f"pieces must be identical in each")
    held_by_none = sum(s[1] for s in sums)
    if n and held_by_none:
        g = min(s[2] for s in sums if s[2] is not None)
        raise ValueError(f"the pieces' global point ids must be 0 … N-1 (N = {n}), each "
                         f"held by some piece; {held_by_none} are held by none (the "
                         f"first: {g}): give every piece, or renumber the ids")
    return RemotePoints(ranges, bounds, d, client or scheduler)
