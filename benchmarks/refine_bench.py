"""Refinement of a coarse cutting mesh (predicates.registration.plan.refine): process CPU
time against the number of cutting cells it creates, the time per created cell, and the
fitted exponent k of time ~ created^k (target: linear, k <= 1.15;
benchmarks/README.md, "Refinement").

Case: a slab of n×n×1 Kuhn cubes (6n² tetrahedra of size 1/n) cut by a tilted plane
given as two triangles of half-width 1e4, so every cutting edge starts long. The plane
crosses the slab in a strip of width ~10/n, so the refinement creates Θ(n) triangles
(~330·n, plus O(1) per round far from the slab) while the simulation mesh grows as n²:
any per-round pass over the simulation cells, or per-edge work growing with the cells
an edge's box spans, shows as an exponent well above 1. The time includes the per-run
index over the simulation cells (O(n²) but cheap). Times: process CPU (the machine is
shared: the steadier figure) and wall, best of ``--repeat``; k fitted over every size
(least squares in log–log); the load average is printed before and after.

    PYTHONPATH=. python3 benchmarks/refine_bench.py [--sizes 32 64 128 256] [--repeat 3]

``--w1 48 96`` instead times refine on W1 (benchmarks/README.md) (cube_grid(n) × icosphere(5)), one
fresh process per n: the first call (cold: fresh pages) and two warm ones, CPU time
split into user and system (page faults) with the load average.
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import time

import numpy as np

from predicates.registration.spatial.boxes import boxes_of
from predicates.registration.examples import cube_grid, icosphere
from predicates.registration.plan.refine import refine
from predicates.registration.plan.resolution import cell_boxes


def slab(n: int):
    """n×n×1 Kuhn cubes of size 1/n: the bottom layer of cube_grid(n)."""
    sp, sc = cube_grid(n)
    keep = (sp[sc][:, :, 2] <= 1.0 / n + 1e-12).all(axis=1)
    return sp, sc[keep]


def case(n: int):
    sp, sc = slab(n)
    nrm = np.array([0.05, 0.08, 1.0])
    nrm /= np.linalg.norm(nrm)
    u = np.cross(nrm, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(nrm, u)
    c = np.array([0.5, 0.5, 0.37 / n])
    cp = np.array([c + 1e4 * (a * u + b * v) for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])
    return sp, sc, cp, np.array([[0, 1, 2], [0, 2, 3]])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[32, 64, 128, 256])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--w1", type=int, nargs="+", help="time W1 at these n instead")
    ap.add_argument("--w1-child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.w1_child:
        return w1_child(args.w1_child)
    if args.w1:
        for n in args.w1:  # a fresh process each: the first call is a cold one
            subprocess.run([sys.executable, __file__, "--w1-child", str(n)], check=True)
        return
    rows = []
    print(f"load average: {_load()}")
    print(f"{'n':>5} {'sim tets':>9} {'created':>9} {'rounds':>6} {'wall s':>8} {'cpu s':>8} "
          f"{'us/cell':>8}")
    for n in args.sizes:
        sp, sc, cp, cc = case(n)
        boxes = cell_boxes(sp, sc)
        best, cpu = np.inf, np.inf
        for _ in range(args.repeat):
            t, c = time.perf_counter(), time.process_time()
            R = refine(cp, cc, *boxes)
            best = min(best, time.perf_counter() - t)
            cpu = min(cpu, time.process_time() - c)
        created = len(R.cells) - len(cc)
        rows.append((created, best, cpu))
        print(f"{n:>5} {len(sc):>9} {created:>9} {R.rounds:>6} {best:>8.3f} {cpu:>8.3f} "
              f"{1e6 * cpu / created:>8.2f}", flush=True)
    x = np.log([r[0] for r in rows])
    kw = np.polyfit(x, np.log([r[1] for r in rows]), 1)[0]
    kc = np.polyfit(x, np.log([r[2] for r in rows]), 1)[0]
    per = [1e6 * r[2] / r[0] for r in rows]
    print(f"fitted exponent against cells created (time ~ created^k, {len(rows)} sizes): "
          f"k = {kc:.2f} (CPU), {kw:.2f} (wall)")
    print(f"CPU time per created cell: {min(per):.2f}-{max(per):.2f} us "
          f"(largest size {per[-1]:.2f} us)")
    print(f"load average: {_load()}")


def w1_child(n: int) -> None:
    sp, sc = cube_grid(n)
    cp, cc = icosphere(5)
    lo, hi = boxes_of(sp, sc)
    for call in ("cold", "warm", "warm"):
        r0, c0 = resource.getrusage(resource.RUSAGE_SELF), time.process_time()
        R = refine(cp, cc, lo, hi)
        c1, r1 = time.process_time(), resource.getrusage(resource.RUSAGE_SELF)
        print(f"W1 n={n} ({len(sc)} tets) {call}: cpu {c1 - c0:.3f} s (user "
              f"{r1.ru_utime - r0.ru_utime:.3f}, sys {r1.ru_stime - r0.ru_stime:.3f}), "
              f"{len(cc)} -> {len(R.cells)} cells in {R.rounds} rounds, load {_load()}",
              flush=True)


def _load() -> str:
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "unavailable"


if __name__ == "__main__":
    main()
