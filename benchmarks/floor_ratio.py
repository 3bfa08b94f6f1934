"""W1 against the compiled floor, both timed in the same process and the same minutes
(benchmarks/README.md, "Where the two speed targets stand"): the ratio the compiled
candidate chain's target is stated in (W1 ≤ 10× the compiled floor).

    cd TREE && FPERR_ACCELERATE=1 python benchmarks/floor_ratio.py [--rounds 10] [--calls 4]
        [--n 48] [--subdivisions 5]

Each round times the floor (:func:`accelerate_bench.floors`' compiled naive triangle–edge
test over 2^20 random pairs, process CPU, best of ``--calls``) and then W1
(``predicates.intersect`` on cube_grid(48) × icosphere(5), process CPU, best and median
of ``--calls``), so that both see the same load; the machine is shared, and a floor timed
minutes apart from the run it divides moves the ratio by ±30 % (benchmarks/README.md,
"after the s20 passes"). Prints each round's figures and the ratios' median and range.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
sys.path[:0] = [os.getcwd(), str(Path(__file__).resolve().parent)]

import numpy as np  # noqa: E402


def _w1(n: int = 48, subdivisions: int = 5):
    """A call of W1 (its meshes built once) and its ``res.timings['accelerated']``."""
    import predicates
    from predicates.registration.examples import cube_grid, icosphere

    sp, sc = cube_grid(n)
    cp, cc = icosphere(subdivisions)

    def call():
        return predicates.intersect(sp, sc, cp, cc, memory_limit=20 << 30)

    return call, bool(call().timings.get("accelerated"))  # the warm-up call


def _cpu(f, calls: int) -> list[float]:
    out = []
    for _ in range(calls):
        t = time.process_time()
        f()
        out.append(time.process_time() - t)
    return out


def main(argv: list[str] | None = None) -> None:
    from accelerate_bench import floors

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--calls", type=int, default=4)
    ap.add_argument("--n", type=int, default=48, help="the cube's cells per axis (W1: 48)")
    ap.add_argument("--subdivisions", type=int, default=5, help="the icosphere's (W1: 5)")
    a = ap.parse_args(argv)
    call, accelerated = _w1(a.n, a.subdivisions)
    best, med = [], []
    for r in range(a.rounds):
        floor = floors(a.calls)["compiled"]
        w1 = _cpu(call, a.calls)
        best.append(min(w1) / floor)
        med.append(float(np.median(w1)) / floor)
        print(f"round {r + 1}: floor {1e3 * floor:.1f} ms, W1 best {1e3 * min(w1):.1f} "
              f"median {1e3 * np.median(w1):.1f} ms: {best[-1]:.1f}× (median "
              f"{med[-1]:.1f}×), load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"W1 (n = {a.n}, subdivisions {a.subdivisions}) / compiled floor (accelerated {accelerated}), {a.rounds} rounds of "
          f"{a.calls} calls: best {np.median(best):.1f}× median of rounds (range "
          f"{min(best):.1f}–{max(best):.1f}×, {sum(b <= 10 for b in best)} rounds ≤ 10×); "
          f"median call {np.median(med):.1f}× (range {min(med):.1f}–{max(med):.1f}×)")


if __name__ == "__main__":
    main()
