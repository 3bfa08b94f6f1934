"""The per-worker peak memory a partitioned run reports is the worker's own
(predicates.registration.partition.memory; docs/partitioned.md, section 5): VmHWM of the
process that ran the task, read in the task, not ``ru_maxrss`` (which a worker spawned
by a large client inherits across fork + exec)."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from predicates.registration.partition import memory

linux = pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs /proc")


@linux
def test_peak_is_this_process_vmhwm_read_now():
    peak, source = memory.peak_rss_mib()
    assert source == "VmHWM" and peak >= memory.rss_mib() > 0
    big = np.ones(64 << 20, dtype=np.uint8)  # 64 MiB touched: the mark rises, read anew
    after, _ = memory.peak_rss_mib()
    assert after >= memory.rss_mib() >= big.nbytes / 2**20
    del big


def test_without_proc_falls_back_to_ru_maxrss(monkeypatch, tmp_path):
    monkeypatch.setattr(memory, "_STATUS", str(tmp_path / "missing"))
    peak, source = memory.peak_rss_mib()
    assert source == "ru_maxrss" and peak > 0 and memory.rss_mib() is None


@linux
def test_worker_peak_is_its_own_not_the_clients():
    """A client holding ~600 MiB spawns a LocalCluster: the workers' ru_maxrss starts at
    the client's RSS (kept across fork + exec), their VmHWM at their own. The reported
    peak per task is the worker's VmHWM as the worker itself reads it."""
    distributed = pytest.importorskip("distributed")
    ballast = np.ones(600 << 20, dtype=np.uint8)  # touched: resident in the client
    ex = example("sphere", 4, subdivisions=1)
    (sp, sc), (cp, cc) = ex["sim"], ex["cut"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        res = predicates.intersect(sp, sc, cp, cc, partitions=3, scheduler=client)
        hwm = client.run(lambda: memory.peak_rss_mib()[0])
        inherited = client.run(lambda: __import__("resource").getrusage(
            __import__("resource").RUSAGE_SELF).ru_maxrss / 1024)
    parts = res.timings["partitions"]
    assert parts and all(p["peak_rss_source"] == "VmHWM" for p in parts)
    assert {p["pid"] for p in parts} != {os.getpid()}
    for p in parts:
        assert p["peak_rss_mib"] < ballast.nbytes / 2**20  # not the client's
        assert 0 < p["rss_begin_mib"] <= p["peak_rss_mib"] <= max(hwm.values()) + 1
    if sys.platform.startswith("linux"):  # the bug this guards against is real here
        assert max(inherited.values()) >= ballast.nbytes / 2**20
    ref = predicates.intersect(sp, sc, cp, cc)
    assert res.counts == ref.counts
    del ballast
