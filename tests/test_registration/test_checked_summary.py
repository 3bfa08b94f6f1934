"""The plan's simulation tetrahedra: validation's cell check and the boxes' summary in
one compiled pass (``CellBoxes.checked_summary``, docs/partitioned.md section 2) give
what the two separate passes give — the same refusal (error type and message) for bad
cells and points, the same points and cells, and a summary equal bit for bit to the
separate summary pass, itself checked here against the exact hull and extents — on
hypothesis meshes with bad ids, NaN and infinite points, float32 and int32 inputs,
serially and on a thread pool with tiny blocks."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from predicates.registration.plan.cellboxes import CellBoxes  # noqa: E402
from predicates.registration.plan.inputs import validate_mesh, validate_pair  # noqa: E402
from predicates.registration.spatial.blocks import Blocks  # noqa: E402

_VALUES = [-0.0, 0.0, 0.25, -0.5, 1.0, 1.0 + 2.0 ** -52, 3.0, 2.0 ** -30, -(2.0 ** 20)]
_SLOW = settings(max_examples=max(10, settings.default.max_examples // 4), deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _outcome(f):
    """f()'s result, or its error's type and message."""
    try:
        return "ok", f()
    except (ValueError, TypeError) as e:
        return type(e).__name__, str(e)


def _summary_bytes(s) -> tuple:
    """Every value of a BoxSummary, exactly."""
    hist = None if s.hist is None else s.hist.tobytes()
    return (s.n, s.lo_min.tobytes(), s.hi_max.tobytes(), np.float64(s.ext_max).tobytes(),
            np.float64(s.ext_min).tobytes(), hist)


def _tetrahedra(data):
    """Points (adversarial values, float64 or float32, sometimes one non-finite) and
    tetrahedra over them (int32 or int64), sometimes with a negative, out-of-range or
    repeated id in any row."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n, m = data.draw(st.integers(4, 60)), data.draw(st.integers(1, 300))
    P = rng.choice(_VALUES, size=(n, 3))
    mixed = rng.random(n) < 0.5
    P[mixed] = rng.random((int(mixed.sum()), 3)) * 2.0 ** rng.integers(-3, 3)
    if data.draw(st.booleans()) and data.draw(st.booleans()):
        P[rng.integers(0, n), rng.integers(0, 3)] = data.draw(
            st.sampled_from([np.nan, np.inf, -np.inf]))
    P = P.astype(data.draw(st.sampled_from([np.float64, np.float32])))
    cells = np.array([rng.permutation(n)[:4] for _ in range(m)])
    for _ in range(data.draw(st.integers(0, 2))):
        cells[rng.integers(0, m), rng.integers(0, 4)] = data.draw(st.sampled_from(
            [-1, n, n + 7, int(cells[0, 0])]))
    return P, cells.astype(data.draw(st.sampled_from([np.int32, np.int64])))


@_SLOW
@given(data=st.data(), dtype=st.sampled_from([np.float64, np.float32]))
def test_checked_summary_is_the_separate_passes(data, dtype):
    """validate_mesh(summarize=True) on compiled blocks refuses exactly what the numpy
    check refuses, with its message; otherwise it returns the same points and cells,
    and its summary (made when the points are finite and in the working dtype, else
    None) equals the separate compiled and numpy summary passes; the hull and the
    largest extent are the exact ones."""
    P, cells = _tetrahedra(data)
    with ThreadPoolExecutor(2) as pool:
        for t, b in ((1, None), (2, 7), (1, 5)):
            fast, slow = Blocks(pool, t, block=b, accelerate=True), Blocks(pool, t, block=b)
            want = _outcome(lambda: validate_mesh(P, cells, "simulation", 3, np.dtype(dtype),
                                                  False, slow))
            got = _outcome(lambda: validate_mesh(P, cells, "simulation", 3, np.dtype(dtype),
                                                 False, fast, summarize=True))
            assert want[0] == got[0] and (want[0] == "ok" or want[1] == got[1])
            if want[0] != "ok":
                continue
            w, g = want[1], got[1]
            assert np.array_equal(w.points, g.points) and g.cells is cells
            eligible = P.dtype == np.dtype(dtype) and bool(np.isfinite(P).all())
            assert (g.summary is not None) == eligible
            if g.summary is None:
                continue
            assert w.summary is None
            separate = [CellBoxes(w.points, cells, bl).summary() for bl in (fast, slow)]
            assert _summary_bytes(g.summary) == _summary_bytes(separate[0])
            s = separate[1]  # numpy's: the hull's signed zeros may follow its merges
            assert np.array_equal(g.summary.lo_min, s.lo_min)
            assert np.array_equal(g.summary.hi_max, s.hi_max)
            assert (g.summary.ext_max, g.summary.ext_min) == (s.ext_max, s.ext_min)
            X = [[Fraction(float(v)) for v in P[row, ax]] for row in cells
                 for ax in range(3)]
            assert g.summary.ext_max == float(max(max(x) - min(x) for x in X))
            assert g.summary.lo_min[0] == min(min(X[3 * r]) for r in range(len(cells)))


@_SLOW
@given(data=st.data())
def test_validate_pair_hands_the_summary_to_the_plan(data):
    """validate_pair makes the simulation mesh's summary on compiled blocks (float64
    finite points) and never on numpy blocks or for the cutting mesh; the plan's
    CellBoxes given it returns it without a pass, equal to a fresh pass."""
    P, cells = _tetrahedra(data)
    P = np.where(np.isfinite(P), P, 0.0).astype(np.float64)
    cells = np.abs(cells) % len(P)
    ok = np.array([len(set(r)) == 4 for r in cells.tolist()])
    if not ok.any():
        return
    cells = cells[ok]
    tri = np.array([[0, 1, 2], [1, 2, 3]])
    fast = Blocks(accelerate=True)
    _, sim, cut = validate_pair(P, cells, P, tri, np.float64, fast)
    assert sim.summary is not None and cut.summary is None
    assert validate_pair(P, cells, P, tri, np.float64, Blocks())[1].summary is None
    box = CellBoxes(sim.points, sim.cells, fast, sim.summary)
    assert box.summary() is sim.summary
    assert _summary_bytes(sim.summary) == _summary_bytes(
        CellBoxes(sim.points, sim.cells, fast).summary())


@_SLOW
@given(data=st.data())
def test_checked_numpy_blocks_are_boxes_of(data):
    """The plan's numpy blocks for validated cells (``checked``: takes without numpy's
    bounds check) are the unchecked blocks and boxes_of's boxes, bit for bit (signed
    zeros included), and so is the summary made from them."""
    from predicates.registration.spatial.boxes import boxes_of

    P, cells = _tetrahedra(data)
    P = np.where(np.isfinite(P), P, -0.0)
    cells = np.abs(cells) % len(P)
    lo, hi = boxes_of(P, cells)
    plain, checked = CellBoxes(P, cells), CellBoxes(P, cells, checked=True)
    for a, b in ((0, len(cells)), (0, len(cells) // 2), (len(cells) // 3, len(cells))):
        want, got = plain.block(a, b), checked.block(a, b)
        for s in (0, 1):
            assert got[s].tobytes() == want[s].tobytes()
            assert got[s].tobytes() == np.ascontiguousarray((lo, hi)[s][a:b]).tobytes()
    assert _summary_bytes(checked.summary()) == _summary_bytes(plain.summary())


def test_summary_field_keeps_the_subclass_positions():
    """MeshInput's summary is keyword-only: the remote mesh's positional ``held``
    (partition/remote.py) still lands in ``held``, which the split on the workers
    reads."""
    from predicates.registration.partition.remote import CellsOnWorkers

    held = ("cells", None, "points")
    mesh = CellsOnWorkers(np.zeros((4, 3)), np.array([[0, 1, 2, 3]]), "simulation",
                          False, held)
    assert mesh.held is held and mesh.summary is None
