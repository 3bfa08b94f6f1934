"""What two workers can give on this machine (docs/partitioned.md 5b): the throughput of 2 concurrent
processes against 1, for the same work, timed in the same run.

    python benchmarks/parallel_ceiling.py [--n 48] [--rounds 3] [--json OUT.json]

A partitioned run on 2 workers cannot be faster than 2 copies of its work running side
by side allow. Each workload runs alone in one process, then as two processes started
together (each does the same work); the **ceiling** is 2 × t_alone / t_pair (t_pair:
the later of the two to finish) — 2.0 on two free cores, 1.0 when the two processes get
one core's worth between them. Workloads:

* ``python``: a pure-Python integer loop (the interpreter's own speed);
* ``numpy``: ``np.sin`` over 2^20 doubles (SIMD floating point);
* ``registration``: the serial W1 registration (cube n × icosphere 20,480, what each
  worker runs on its half in a partitioned run: rank space, broad phase, the nine
  kinds), after the plan, in a warm process.

Each process reports its own CPU and wall time; ``rounds`` alternate alone / pair.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _prepare(kind: str, n: int):
    """The workload as a callable returning its wall seconds (set up and warmed first:
    the registration's plan, imports and page faults are not timed)."""
    import numpy as np

    if kind == "python":
        def run() -> float:
            t, x = time.perf_counter(), 0
            for i in range(6_000_000):
                x += i
            return time.perf_counter() - t
        return run
    if kind == "numpy":
        x = np.random.default_rng(0).random(1 << 20)
        out = np.empty_like(x)

        def run() -> float:
            t = time.perf_counter()
            for _ in range(40):
                np.sin(x, out=out)
            return time.perf_counter() - t
        return run
    sys.path.insert(0, os.path.dirname(HERE))
    from predicates.registration import examples, pipeline

    (sp, sc), (cp, cc) = examples.cube_grid(n), examples.icosphere(5)
    plan = pipeline._plan((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True,
                          {}, None, None)
    pipeline._register(plan, pipeline.CHUNK, False, {})  # warm

    def run() -> float:
        t = time.perf_counter()
        pipeline._register(plan, pipeline.CHUNK, False, {})
        return time.perf_counter() - t
    return run


def child(kind: str, n: int, start_at: float) -> None:
    run = _prepare(kind, n)
    while time.time() < start_at:  # both processes of a pair start the timed work together
        time.sleep(0.001)
    c = time.process_time()
    wall = run()
    print(json.dumps({"wall": wall, "cpu": time.process_time() - c}))


def _spawn(kind: str, n: int, copies: int, lead: float) -> list[dict]:
    start = time.time() + lead
    procs = [subprocess.Popen([sys.executable, __file__, "--child", kind, "--n", str(n),
                               "--start", repr(start)], stdout=subprocess.PIPE, text=True)
             for _ in range(copies)]
    return [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--kinds", default="python,numpy,registration")
    ap.add_argument("--json")
    ap.add_argument("--child")
    ap.add_argument("--start", type=float)
    a = ap.parse_args(argv)
    if a.child:
        child(a.child, a.n, a.start)
        return
    out = {"load_at_start": os.getloadavg()[0], "n": a.n, "kinds": {}}
    print(f"load average at start {out['load_at_start']:.2f}; cpus {os.cpu_count()}")
    lead = 8.0  # seconds for the registration children to build their plan first
    for kind in a.kinds.split(","):
        alone, pair = [], []
        for _ in range(a.rounds):
            alone.append(_spawn(kind, a.n, 1, lead if kind == "registration" else 0.3)[0])
            pair.append(_spawn(kind, a.n, 2, lead if kind == "registration" else 0.3))
        t1 = min(r["wall"] for r in alone)
        t2 = min(max(r["wall"] for r in p) for p in pair)
        ceiling = 2 * t1 / t2
        out["kinds"][kind] = {"alone_wall": [r["wall"] for r in alone],
                              "pair_wall": [[r["wall"] for r in p] for p in pair],
                              "pair_cpu": [[r["cpu"] for r in p] for p in pair],
                              "ceiling": ceiling}
        each = ", ".join(f"{r['wall']:.3f}" for r in min(pair, key=lambda p: max(
            r["wall"] for r in p)))
        print(f"{kind:13s} alone best {t1:.3f} s; two at once best {t2:.3f} s (each "
              f"{each}); ceiling 2 x {t1:.3f} / {t2:.3f} = {ceiling:.2f}x")
    out["load_at_end"] = os.getloadavg()[0]
    print(f"load average at end {out['load_at_end']:.2f}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
