"""The registration's cell broad phase alone (``facepairs.cell_pairs``: cell boxes, the
top grid, the compiled grid join, the kept cells) on the inputs of a run of cube_grid(n)
× icosphere(s), captured once; process CPU per call, best and median, and a hash of the
pairs (the same on every tree for one path; the numpy and compiled joins order the
pairs differently). benchmarks/README.md, "Part 2, tenth pass".

    FPERR_ACCELERATE=1 python benchmarks/cell_pairs_bench.py [--n 48] [--subdivisions 5]
        [--reps 20]

Run it from the tree under test (its modules are imported from the working directory),
alternating trees in fresh processes for an A/B.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time

sys.path.insert(0, os.getcwd())

import numpy as np  # noqa: E402

import predicates  # noqa: E402
import predicates.registration.levels.loop as loop  # noqa: E402
from predicates.registration.examples import cube_grid, icosphere  # noqa: E402


def captured_inputs(n: int, subdivisions: int) -> tuple:
    """The arguments of the run's one ``cell_pairs`` call."""
    seen, real = [], loop.cell_pairs

    def spy(*args):
        seen.append(args)
        return real(*args)

    loop.cell_pairs = spy
    try:
        predicates.intersect(*cube_grid(n), *icosphere(subdivisions), memory_limit=20 << 30)
    finally:
        loop.cell_pairs = real
    return seen[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--subdivisions", type=int, default=5)
    ap.add_argument("--reps", type=int, default=20)
    a = ap.parse_args()
    args = captured_inputs(a.n, a.subdivisions)
    out = loop.cell_pairs(*args)
    digest = hashlib.sha256(b"".join(x.tobytes() for x in out)).hexdigest()[:16]
    times = []
    for _ in range(a.reps):
        t = time.process_time()
        loop.cell_pairs(*args)
        times.append(time.process_time() - t)
    print(f"cell_pairs n={a.n} s={a.subdivisions}: {len(out[0])} pairs, hash {digest}, "
          f"CPU best {1000 * min(times):.1f} ms, median {1000 * np.median(times):.1f} ms "
          f"(load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
