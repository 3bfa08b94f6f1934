"""A registration makes no reference cycle: the plan's boxes, masks and tables are freed
as their last reference goes, so a serial run's peak does not wait for a full collection
(``levels.loop.trim_freed`` no longer runs one: it cost ~60 ms at W4)."""
from __future__ import annotations

import gc
from collections import Counter

import pytest

import predicates
from predicates.registration.examples import cube_grid, icosphere


def _cyclic_garbage(run) -> Counter:
    """Objects that only a collection would free after ``run()`` (by type name)."""
    gc.collect()
    was = gc.isenabled()
    gc.disable()  # nothing collected behind the test's back while it runs
    try:
        gc.set_debug(gc.DEBUG_SAVEALL)
        run()
        gc.collect()
        found = Counter(type(o).__name__ for o in gc.garbage)
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        if was:
            gc.enable()
    return found


@pytest.mark.parametrize("accelerate", [False, True])
def test_a_serial_run_leaves_no_reference_cycle(accelerate):
    if accelerate:
        pytest.importorskip("numba")
    sim, cut = cube_grid(8), icosphere(2)
    def run():
        return predicates.intersect(sim, cut, accelerate=accelerate)
    run()  # compiled kernels loaded, caches filled: what a first call creates once
    found = _cyclic_garbage(run)
    assert not found, f"a run left reference cycles: {found.most_common(8)}"
