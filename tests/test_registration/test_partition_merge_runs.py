"""The merge's runs found by a compiled loop (partition/assign.merge_runs with
``fast``, compiled/mergeruns.py): the Python loop's runs, limit and refusal
(benchmarks/README.md "The 2-worker W4 client, seventh pass")."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates import compiled

pytestmark = pytest.mark.skipif(not compiled.available(), reason="numba not installed")


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.integers(0, 200),
       st.sampled_from([1, 3, 10, 4096]), st.booleans(), st.floats(0, 1))
def test_compiled_merge_runs_are_the_runs(seed, k, n, limit, shared, blocky):
    """assign.merge_runs compiled (``fast``: the keys joined, one loop) gives the
    Python loop's runs, its None past ``limit`` runs and its refusal of a key two
    partitions hold; int32 and int64 keys (beyond int32's range), empty partitions,
    keys in long blocks of one partition (few runs) or interleaved."""
    from predicates.registration.partition.assign import merge_runs

    rng = np.random.default_rng(seed)
    values = np.sort(rng.choice(2**40 if rng.random() < 0.3 else 10**6, size=n,
                                replace=False))
    owner = (np.repeat(rng.integers(0, k, size=max(1, n // 20 + 1)), 20)[:n]
             if rng.random() < blocky else rng.integers(0, k, size=n))
    keys = [values[owner == r] for r in range(k)]
    keys = [x.astype(np.int32) if x.size and x.max() < 2**31 and rng.random() < 0.5 else x
            for x in keys]
    if shared and k > 1 and n:  # a key held by a second partition too
        v = int(rng.choice(values))
        r = (int(owner[np.searchsorted(values, v)]) + 1) % k
        keys[r] = np.sort(np.append(keys[r], v).astype(keys[r].dtype))

    def runs(fast):
        try:
            return merge_runs(keys, limit, "pairs", fast)
        except RuntimeError as e:
            return str(e)

    want = runs(False)
    assert runs(True) == want
    if shared and k > 1 and n and limit == 4096:  # (a smaller limit may come first)
        assert isinstance(want, str) and "ownership bug" in want
