"""Refinement of a coarse cutting mesh (predicates.registration.refine): time against
the number of cutting cells it creates, with a fitted exponent (issue 10: linear).

Case: a slab of n×n×1 Kuhn cubes (6n² tetrahedra of size 1/n) cut by a tilted plane
given as two triangles of half-width 1e4: the refinement creates Θ(n²) triangles near
the slab (plus O(log) per round far from it). The simulation mesh grows as n² too, so
the per-round pass over it (rounds ≈ log2(1e4·n)) is part of what is measured.

    PYTHONPATH=. python3 benchmarks/refine_bench.py [--sizes 8 16 32 64 128]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from predicates.registration.examples import cube_grid
from predicates.registration.refine import refine
from predicates.registration.resolution import cell_boxes


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
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 16, 32, 64, 128])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    rows = []
    print(f"{'n':>5} {'sim tets':>9} {'created':>9} {'rounds':>6} {'time s':>8} {'us/cell':>8}")
    for n in args.sizes:
        sp, sc, cp, cc = case(n)
        boxes = cell_boxes(sp, sc)
        best = np.inf
        for _ in range(args.repeat):
            t = time.perf_counter()
            R = refine(cp, cc, *boxes)
            best = min(best, time.perf_counter() - t)
        created = len(R.cells) - len(cc)
        rows.append((created, best))
        print(f"{n:>5} {len(sc):>9} {created:>9} {R.rounds:>6} {best:>8.3f} "
              f"{1e6 * best / created:>8.2f}")
    x, y = np.log([r[0] for r in rows]), np.log([r[1] for r in rows])
    k = np.polyfit(x[-3:], y[-3:], 1)[0]
    print(f"fitted exponent (time ~ created^k, last 3 sizes): k = {k:.2f}")


if __name__ == "__main__":
    main()
