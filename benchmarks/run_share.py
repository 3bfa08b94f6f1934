"""A whole registration's CPU and its plan's share (benchmarks/README.md, "Where the two
speed targets stand"): ``predicates.intersect`` on W1 (cube 48 × icosphere 5), W2 (96 × 5)
or W4 (120 × 7) called repeatedly in one process after one warm-up call; per call the
process CPU of the run and of its plan (``res.timings["cpu_setup"]``), then the best, the
median and the plan's share of the median run, with the load average.

    FPERR_ACCELERATE=1 python benchmarks/run_share.py [W1|W2|W4|tiny] [calls]

Run it from the tree to measure (the tree's ``predicates`` is imported); compare two
trees in fresh processes, alternating (this machine is shared: compare in the same
minutes, never across time).
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.getcwd())

SIZES = {"W1": (48, 5), "W2": (96, 5), "W4": (120, 7), "tiny": (6, 2)}


def main(argv: list[str] | None = None) -> None:
    import numpy as np

    import predicates
    from predicates.registration.examples import cube_grid, icosphere

    argv = sys.argv[1:] if argv is None else argv
    w = argv[0] if argv else "W1"
    calls = int(argv[1]) if len(argv) > 1 else 5
    n, s = SIZES[w]
    sp, sc = cube_grid(n)
    cp, cc = icosphere(s)
    predicates.intersect(sp, sc, cp, cc, memory_limit=20 << 30)  # warm-up: loads, caches
    total, plan = [], []
    for _ in range(calls):
        c = time.process_time()
        res = predicates.intersect(sp, sc, cp, cc, memory_limit=20 << 30)
        total.append(time.process_time() - c)
        plan.append(res.timings["cpu_setup"])
        print(f"{w} cpu {total[-1]:.3f} s plan {plan[-1]:.3f} s "
              f"({100 * plan[-1] / total[-1]:.1f} %)", flush=True)
    print(f"{w} {os.getcwd()} best {min(total):.3f} median {np.median(total):.3f} "
          f"plan best {min(plan):.3f} median {np.median(plan):.3f} share(median) "
          f"{100 * np.median(plan) / np.median(total):.1f} % "
          f"accelerated {res.timings['accelerated']} load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
