"""The pieces' points kept on the workers (predicates.registration.partition.points;
docs/partitioned.md 6): exchanged into ranges of global ids, checked and scaled per
range, they give the serial values and refusals bit for bit — against
``inputs.scale_points`` and ``inputs._points`` on the assembled array."""
from __future__ import annotations

import numpy as np
import pytest

from predicates.registration.partition.pieces import Piece
from predicates.registration.plan.inputs import _points, scale_points

dask = pytest.importorskip("dask")


def _random_pieces(rng, P: np.ndarray, count: int):
    """``count`` pieces holding random overlapping sets of the points (each point in at
    least one; its coordinates identical in each), in random local orders, each piece's
    cells (single-vertex rows: the points it uses) a random subset of its points; returns
    the delayed pieces and the global used mask (a point is used when some piece uses
    it)."""
    n = len(P)
    home = rng.integers(0, count, n)
    used = np.zeros(n, dtype=bool)
    pieces = []
    for i in range(count):
        ids = np.union1d(np.flatnonzero(home == i), rng.choice(n, n // 10, replace=False))
        ids = rng.permutation(ids).astype(np.int64)
        local = np.flatnonzero(rng.random(len(ids)) < 0.8)[:, None]
        used[ids[local[:, 0]]] = True
        pieces.append(dask.delayed(Piece, pure=True)(ids, P[ids], ids[local], 3, None, [],
                                                    local))
    return pieces, used


@pytest.mark.parametrize("seed", range(6))
def test_points_on_the_workers_check_and_scale_as_the_serial_plan(seed):
    from predicates.registration.partition.points import points_on_workers

    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 400))
    P = rng.uniform(-4, 4, (n, 3))
    at = rng.choice(n, 3, replace=False)
    if seed % 2:  # a subnormal coordinate: not exact when scaled down
        P[at[0], 1] = 5e-324
    if seed % 3 == 2:  # beyond max/16 once halved: overflows, refused first
        P[at[1], 0] = -1.5e308
    pieces, used = _random_pieces(rng, P, int(rng.integers(1, 6)))
    remote = points_on_workers([f"p{i}" for i in range(len(pieces))], pieces, n, 3, None,
                               "synchronous")
    assert np.asarray(remote).tobytes() == P.tobytes()  # as given, every row
    for dtype in (np.float64, np.float32):
        try:
            ref, rounded = _points(P, used, "simulation", np.dtype(dtype))
        except ValueError as err:  # (1.5e308 in float32, when used)
            with pytest.raises(ValueError) as got:
                remote.checked("simulation", np.dtype(dtype))
            assert str(got.value) == str(err) and "overflow float32" in str(err)
            continue
        work, got_rounded = remote.checked("simulation", np.dtype(dtype))
        assert got_rounded == rounded and np.asarray(work).tobytes() == ref.tobytes()
        keep = np.flatnonzero(used & (rng.random(n) < 0.5))
        for e in (1, -3, 0):
            try:
                want = scale_points(ref, e, "simulation", keep)
            except ValueError as err:
                with pytest.raises(ValueError) as got:
                    work.scaled(e, "simulation", keep)
                assert str(got.value) == str(err)
                continue
            out = work.scaled(e, "simulation", keep)
            assert out.dtype == want.dtype and out.tobytes() == want.tobytes()
            # rows by id: the run's vertices scaled back (exact), others fetched
            ids = rng.permutation(np.concatenate([keep[:5], [0, n - 1]]))
            assert work[ids].tobytes() == ref[ids].tobytes()


def test_points_refused_as_the_serial_check():
    """A NaN and an infinity in used rows: the first by global id, the serial message
    (``inputs._points``); an overflow of float32: its largest |coordinate|; a NaN in
    an unused row is not read."""
    from predicates.registration.partition.points import points_on_workers

    rng = np.random.default_rng(9)
    P = rng.uniform(-1, 1, (200, 3))
    pieces, used = _random_pieces(rng, P, 3)
    bad = np.flatnonzero(used)
    unused = np.flatnonzero(~used)
    for rows, value, dtype in (((bad[40], bad[7]), np.nan, np.float64),
                               ((bad[3], bad[90]), np.inf, np.float32),
                               ((bad[11], bad[2]), 3e39, np.float32),
                               ((unused[0], unused[-1]), np.nan, np.float64)):
        Q = P.copy()
        Q[rows[0], 2], Q[rows[1], 0] = value, -value
        got = [dask.delayed(Piece, pure=True)(p.ids, Q[p.ids], *p[2:])
               for p in dask.compute(*pieces)]
        remote = points_on_workers(["a", "b", "c"], got, len(Q), 3, None, "threads")
        try:
            _points(Q, used, "simulation", np.dtype(dtype))
        except ValueError as err:
            with pytest.raises(ValueError) as e:
                remote.checked("simulation", np.dtype(dtype))
            assert str(e.value) == str(err)
        else:
            assert rows[0] in unused  # (the case is what it says)
            remote.checked("simulation", np.dtype(dtype))
