"""Where a partitioned run's client spends its CPU (docs/partitioned.md 5a, "The client's
share"): W4 (cube ``--n`` 120 × icosphere ``--subdivisions`` 7) with the simulation cells
on 2 spawned single-threaded workers (``partition_remote_bench.spawned_cluster``), k = 2;
one warm-up call, then ``--calls`` calls in this process, each printed as

    client CPU (the plan's) | main thread, other live threads (Dask's event loop), the
    threads that ended (the plan's pool) | the workers' plan passes, busiest task, the
    critical CPU (client + plan on the workers + busiest task)

and the median over the calls. Thread CPU comes from /proc/self/task (Linux only, in
clock ticks of 10 ms: "pool", the rest, can come out a tick below zero on tiny runs).

    cd TREE && PYTHONPATH=TREE:TREE/benchmarks FPERR_ACCELERATE=1 \\
        python benchmarks/partition_client_cpu.py [--n 120] [--subdivisions 7] [--calls 5]

(the workers import the tree on PYTHONPATH, and ``benchmarks`` for the cells' builder;
another tree's code is timed by putting it on PYTHONPATH, this script from here).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

# after PYTHONPATH: an A/B run of another tree puts that tree first (its workers too)
ROOT = Path(__file__).resolve().parents[1]
sys.path += [str(ROOT), str(ROOT / "benchmarks")]


def thread_cpu() -> dict:
    """{thread id: CPU seconds (user + system)} of this process's live threads."""
    out, tick = {}, os.sysconf("SC_CLK_TCK")
    for t in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{t}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except FileNotFoundError:  # ended meanwhile
            continue
        out[t] = (int(fields[11]) + int(fields[12])) / tick
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=120)
    ap.add_argument("--subdivisions", type=int, default=7)
    ap.add_argument("--calls", type=int, default=5)
    a = ap.parse_args(argv)

    import dask
    import dask.array as da

    import predicates
    from partition_remote_bench import cube_cells, digest, spawned_cluster
    from predicates.registration.examples import grid_coordinates, icosphere

    cp, cc = icosphere(a.subdivisions)
    x = grid_coordinates(a.n)
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    sp = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    m, k = 6 * a.n ** 3, 2
    main_id = str(os.getpid())
    with spawned_cluster(2) as (client, _, _):
        cuts = np.linspace(0, m, k + 1).astype(int)
        sc = client.persist(da.concatenate([
            da.from_delayed(dask.delayed(cube_cells)(a.n, lo, hi), shape=(hi - lo, 4),
                            dtype=np.int64) for lo, hi in zip(cuts[:-1], cuts[1:])]))

        def call():
            return predicates.intersect(sp, sc, cp, cc, partitions=k, scheduler=client,
                                        memory_limit=16 << 30)

        first = digest(call())
        got = []
        for _ in range(a.calls):
            before, c = thread_cpu(), time.process_time()
            res = call()
            cpu, after = time.process_time() - c, thread_cpu()
            main = after[main_id] - before[main_id]
            alive = sum(v - before.get(t, 0.0) for t, v in after.items())
            t = res.timings
            workers = sum(s for _, s in (t.get("plan_remote") or {}).get("worker_cpu", []))
            busiest = max(p["cpu_s"] + p.get("cpu_split_path", 0.0) for p in t["partitions"])
            got.append((cpu, t["cpu_setup"], main, alive - main, cpu - alive, workers,
                        busiest, cpu + workers + busiest))
            print("client {:.3f} (plan {:.3f}) | main {:.3f} loop {:.3f} pool {:.3f} | "
                  "workers' passes {:.3f} busiest {:.3f} crit {:.3f}".format(*got[-1]),
                  flush=True)
            assert digest(res) == first
    med = np.median(np.array(got), axis=0)
    print("median: client {:.3f} (plan {:.3f}) | main {:.3f} loop {:.3f} pool {:.3f} | "
          "workers' passes {:.3f} busiest {:.3f} crit {:.3f}".format(*med),
          f"| digest {first[:16]} load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
