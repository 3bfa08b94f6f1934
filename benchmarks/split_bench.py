"""Split time against registration time (docs/split.md, "Implementation"): the virtual-node split
(``res.split()``, predicates.registration.split.mesh) beside the robust registration
(``predicates.intersect``) on the cube grid n³ × 6 Kuhn tetrahedra cut by an icosphere,
and the square grid n² × 2 cut by a circle polygon, several n; the fitted exponent of
time against the number of cells (least squares on log-log; 1 = linear).

    PYTHONPATH=. python3 benchmarks/split_bench.py [--quick] [--json FILE]

Wall time, best of ``--repeat`` runs (the machine may be shared: see README.md).
"""
from __future__ import annotations

import argparse
import json

import numpy as np
from timing import best  # benchmarks/timing.py (this script's folder)

from predicates import intersect
from predicates.registration.examples import circle_polygon, cube_grid, icosphere, square_grid

CASES = {3: (8, 12, 16, 24, 32), 2: (64, 128, 256, 512)}
QUICK = {3: (8, 12, 16), 2: (64, 128, 256)}



def run_case(dim: int, n: int, repeat: int) -> dict:
    if dim == 3:
        sim, cut = cube_grid(n), icosphere(4)
    else:
        sim, cut = square_grid(n), circle_polygon(8 * n)
    res, t_reg = best(lambda: intersect(sim, cut), repeat)
    sm, t_split = best(res.split, repeat)
    return {"dim": dim, "n": n, "cells": len(sim[1]), "cut_cells": len(cut[1]),
            "pairs": res.total, "new_cells": len(sm.cells), "pieces": sm.n_pieces,
            "t_register": t_reg, "t_split": t_split}


def exponent(rows, key):
    x = np.log([r["cells"] for r in rows])
    y = np.log([r[key] for r in rows])
    return float(np.polyfit(x, y, 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    cases = QUICK if args.quick else CASES
    out = {}
    for dim in (3, 2):
        rows = [run_case(dim, n, args.repeat) for n in cases[dim]]
        out[dim] = {"rows": rows, "exponent_split": exponent(rows, "t_split"),
                    "exponent_register": exponent(rows, "t_register")}
        print(f"\n{dim}D  {'n':>4} {'cells':>9} {'pairs':>8} {'new cells':>9} {'pieces':>6} "
              f"{'register s':>10} {'split s':>8} {'split/reg':>9}")
        for r in rows:
            print(f"    {r['n']:>4} {r['cells']:>9} {r['pairs']:>8} {r['new_cells']:>9} "
                  f"{r['pieces']:>6} {r['t_register']:>10.3f} {r['t_split']:>8.3f} "
                  f"{r['t_split'] / r['t_register']:>9.2f}")
        print(f"    fitted exponent (time ~ cells^k): split k = {out[dim]['exponent_split']:.2f}"
              f", registration k = {out[dim]['exponent_register']:.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
