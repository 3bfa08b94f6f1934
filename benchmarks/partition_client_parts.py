"""The client's CPU per wrapped function in a 2-worker W4 run with the cells on the
workers (benchmarks/README.md "The 2-worker W4 client, fifth pass"; functions a tree
lacks are skipped, "… seventh pass").

W4 = cube_grid(120) × icosphere(7), the simulation cells a persisted dask array in two
chunks on 2 spawned single-threaded workers (``partition_remote_bench.spawned_cluster``),
the points on the client, k = 2. After one warm call, each call prints the client
process's CPU seconds and, per wrapped function, the process CPU (every thread: the
plan's pool and Dask's event loop included) spent while it ran, in ms. Nested functions
count in each of their callers; "cut_and_flag_boxes" is every ``remote.boxes_of`` call
(the cutting boxes for the first round's grid and the flagged cells' boxes — from the
fifth pass to s23-cells those came from a kernel of their own, not counted here).

    cd TREE && FPERR_ACCELERATE=1 PYTHONPATH=TREE:TREE/benchmarks \\
        python benchmarks/partition_client_parts.py 3 [--n 120 --subdivisions 7]

(the spawned workers import ``cube_cells`` from this folder: it must be on the path).
"""
from __future__ import annotations

import collections
import importlib
import os
import sys
import time

import numpy as np

ROOT = os.getcwd()
sys.path[:0] = [ROOT, ROOT + "/benchmarks"]

T = collections.defaultdict(float)

TARGETS = [
    ("predicates.registration.pipeline", "_plan", None),
    ("predicates.registration.pipeline", "_report", None),
    ("predicates.registration.pipeline", "consistent_scale", "L"),
    ("predicates.registration.pipeline", "estimate_cell_pairs", "paircount"),
    ("predicates.registration.pipeline", "shortest_edge", "cut_edge"),
    ("predicates.registration.plan.first_round", "fixed_grid", None),
    ("predicates.registration.partition.remote", "validate_remote", None),
    ("predicates.registration.partition.remote", "RemoteCells.check", None),
    ("predicates.registration.partition.remote", "RemoteCells.flag_pass", None),
    ("predicates.registration.partition.remote", "RemoteCells.__init__", "RC_init"),
    ("predicates.registration.partition.remote", "boxes_of", "cut_and_flag_boxes"),
    ("predicates.registration.partition.remote", "cut_flags_from", None),
    ("predicates.registration.partition.run_arrays", "checked_scaling", None),
    ("predicates.registration.partition.run", "_split_there", None),
    ("predicates.registration.partition.run", "split_on_workers", None),
    ("predicates.registration.partition.run", "_gather", None),
    ("predicates.registration.partition.run", "_merged", None),
    ("predicates.registration.partition.run", "merge", "assign_merge"),
    ("predicates.registration.partition.split_remote", "run_hull", None),
    ("predicates.registration.partition.split_remote", "_compute", None),
    ("predicates.registration.partition.split_remote", "select_boundaries", None),
    ("predicates.registration.partition.assign", "merge_runs", None),
]


def wrap(modname: str, attr: str, label: str | None = None) -> None:
    """Replace ``modname.attr`` (or ``Class.method``) by a wrapper adding the process
    CPU seconds of each call to ``T[label or attr]``."""
    mod = importlib.import_module(modname)
    obj, name = mod, attr
    if "." in attr:
        cls, name = attr.split(".")
        obj = getattr(mod, cls)
    f = getattr(obj, name, None)
    if f is None:  # (an older tree without it: base and branch alternated)
        return

    def timed(*a, **k):
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            T[label or attr] += time.process_time() - c

    setattr(obj, name, timed)


def main(calls: int = 3, n: int = 120, subdivisions: int = 7) -> None:
    import dask
    import dask.array as da

    import predicates
    from partition_remote_bench import cube_cells, spawned_cluster
    from predicates.registration.examples import grid_coordinates, icosphere

    for target in TARGETS:
        wrap(*target)
    cp, cc = icosphere(subdivisions)
    k = 2
    x = grid_coordinates(n)
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    sp = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    m = 6 * n ** 3
    with spawned_cluster(2) as (client, _, _):
        cuts = np.linspace(0, m, k + 1).astype(int)
        sc = client.persist(da.concatenate([
            da.from_delayed(dask.delayed(cube_cells)(n, lo, hi), shape=(hi - lo, 4),
                            dtype=np.int64) for lo, hi in zip(cuts[:-1], cuts[1:])]))

        def call():
            return predicates.intersect(sp, sc, cp, cc, partitions=k, scheduler=client,
                                        memory_limit=16 << 30)

        call()  # warm: imports, the kernels' cache, the workers' first tasks
        for _ in range(calls):
            T.clear()
            c = time.process_time()
            call()
            total = time.process_time() - c
            parts = sorted(T.items(), key=lambda kv: -kv[1])
            print(f"client {total:.3f} |", " ".join(f"{a} {v * 1e3:.0f}" for a, v in parts),
                  flush=True)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("calls", type=int, nargs="?", default=3)
    ap.add_argument("--n", type=int, default=120)
    ap.add_argument("--subdivisions", type=int, default=7)
    a = ap.parse_args()
    main(a.calls, a.n, a.subdivisions)
