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

``--paired N``: after the rounds (``--rounds 0``: none), N pairs timed call by call —
the floor (best of two calls) right before one W1 call, each pair's ratio taken — so
that both see the same seconds of the machine: W1 here runs in a fast and a slow state lasting seconds
(benchmarks/README.md, "after the s24 passes"), which rounds of four calls each can
straddle. Prints the pairs' ratio median, quartiles and the share ≤ 10×.
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


def _paired(call, pairs: int) -> None:
    """``--paired``: the floor (its inputs built once, best of two calls) and one W1 call,
    alternating; the ratio of each pair."""
    from accelerate_bench import N_FLOOR, _compiled_floor, floor_inputs

    T, E = floor_inputs()
    run, out = _compiled_floor(), np.empty(N_FLOOR, dtype=bool)
    run(T, E, out)  # compiled and warm
    floor, w1 = [], []
    for _ in range(pairs):
        floor.append(min(_cpu(lambda: run(T, E, out), 2)))
        w1.append(_cpu(call, 1)[0])
    f, w = np.array(floor), np.array(w1)
    r = w / f
    print(f"{pairs} pairs: floor median {1e3 * np.median(f):.1f} ms ({1e3 * f.min():.1f}–"
          f"{1e3 * f.max():.1f}), W1 median {1e3 * np.median(w):.1f} ms ({1e3 * w.min():.1f}"
          f"–{1e3 * w.max():.1f}); ratio median {np.median(r):.2f}× (quartiles "
          f"{np.quantile(r, 0.25):.2f}–{np.quantile(r, 0.75):.2f}×, {np.mean(r <= 10):.0%} of "
          f"pairs ≤ 10×), load {os.getloadavg()[0]:.2f}", flush=True)


def main(argv: list[str] | None = None) -> None:
    from accelerate_bench import floors

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--calls", type=int, default=4)
    ap.add_argument("--n", type=int, default=48, help="the cube's cells per axis (W1: 48)")
    ap.add_argument("--subdivisions", type=int, default=5, help="the icosphere's (W1: 5)")
    ap.add_argument("--paired", type=int, default=0, metavar="N",
                    help="after the rounds: N floor/W1 pairs timed call by call")
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
    if a.rounds:
        print(f"W1 (n = {a.n}, subdivisions {a.subdivisions}) / compiled floor (accelerated "
              f"{accelerated}), {a.rounds} rounds of {a.calls} calls: best "
              f"{np.median(best):.1f}× median of rounds (range {min(best):.1f}–"
              f"{max(best):.1f}×, {sum(b <= 10 for b in best)} rounds ≤ 10×); median call "
              f"{np.median(med):.1f}× (range {min(med):.1f}–{max(med):.1f}×)", flush=True)
    if a.paired:
        _paired(call, a.paired)


if __name__ == "__main__":
    main()
