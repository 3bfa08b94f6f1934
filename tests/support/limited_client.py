"""A client process whose address space is limited below the mesh it registers, against
a 2-worker LocalCluster (docs/partitioned.md 7): the tests that show a mesh larger than
the client runs with the cells, or the pieces, on the workers."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

#: one malloc arena, big blocks mapped and unmapped (not kept as heap): the client's
#: address space then follows what it holds
LEAN_MALLOC = {"MALLOC_ARENA_MAX": "1", "MALLOC_MMAP_THRESHOLD_": "65536",
               "MALLOC_TRIM_THRESHOLD_": "65536", "OMP_NUM_THREADS": "1"}


def run_client(script: str, tmp_path: Path, argv) -> dict:
    """Run ``script`` in a fresh Python process with the arguments ``argv(address)``
    (the cluster's scheduler address given) against a new 2-worker LocalCluster with
    unlimited workers; the client's last stdout line is JSON, returned parsed."""
    import distributed

    path = tmp_path / "client.py"
    path.write_text(script)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, memory_limit=0) as cluster:
        r = subprocess.run([sys.executable, str(path), *argv(cluster.scheduler_address)],
                           capture_output=True, text=True, env={**os.environ, **LEAN_MALLOC},
                           timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def assert_pairs_equal_saved(ref, npz: Path) -> None:
    """Every kind's pairs and weights of the result ``ref`` bit for bit those the client
    saved to ``npz`` (keys ``kind.field``)."""
    with np.load(npz) as got:
        for k in ref.kinds:
            for f in ("sim", "cut", "sim_weights", "cut_weights"):
                x, y = getattr(ref[k], f), got[f"{k}.{f}"]
                assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), (k, f)
