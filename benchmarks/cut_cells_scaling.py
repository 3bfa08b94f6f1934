"""The result's cell queries against the number of cut cells, the mesh held fixed
(docs/split.md, "Work only where the cut is"): ``res.intersected_cells()`` then
``res.sim_mesh()`` on a fresh result, the cube grid n = 48 (663,552 Kuhn tetrahedra) cut
by icospheres of growing radius, and the square grid n = 512 cut by circles. If these
queries visited every cell, a small sphere would cost what a large one costs; the fitted
exponent of their time against the cut cells (least squares on log-log) says how they
grow, beside the registration's time for the same run.

    PYTHONPATH=. python3 benchmarks/cut_cells_scaling.py [--repeat 3] [--json FILE]

Wall time, best of ``--repeat`` (each repeat registers afresh: the queries keep their
masks on the result). The machine may be shared: the ratios are the figures to quote.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from predicates import intersect
from predicates.registration.examples import circle_polygon, cube_grid, icosphere, square_grid

RADII = (0.04, 0.08, 0.16, 0.32)


def _cut(dim: int, r: float):
    """A sphere (3D) or circle (2D) of radius r about the unit box's centre."""
    return icosphere(4, radius=r) if dim == 3 else circle_polygon(4096, radius=r)


def run_case(sim, dim: int, r: float, repeat: int) -> dict:
    cut = _cut(dim, r)
    t = {"t_register": float("inf"), "t_intersected": float("inf"),
         "t_queries": float("inf")}
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = intersect(sim, cut)
        t1 = time.perf_counter()
        cells = res.intersected_cells()
        t2 = time.perf_counter()
        res.sim_mesh()  # every cell with its flags: O(cells) output, masks kept
        t3 = time.perf_counter()
        for key, s in (("t_register", t1 - t0), ("t_intersected", t2 - t1),
                       ("t_queries", t3 - t1)):
            t[key] = min(t[key], s)
    return {"dim": dim, "radius": r, "cells": len(sim[1]), "cut_cells": len(cells),
            "pairs": res.total, **t}


def exponent(rows, key) -> float:
    x = np.log([r["cut_cells"] for r in rows])
    return float(np.polyfit(x, np.log([r[key] for r in rows]), 1)[0])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    out = {}
    for dim, sim in ((3, cube_grid(48)), (2, square_grid(512))):
        rows = [run_case(sim, dim, r, args.repeat) for r in RADII]
        out[dim] = {"rows": rows, **{f"exponent_{k[2:]}": exponent(rows, k) for k in
                                     ("t_register", "t_intersected", "t_queries")}}
        print(f"\n{dim}D, {len(sim[1])} cells  {'radius':>6} {'cut cells':>9} {'pairs':>7} "
              f"{'register s':>10} {'ic s':>7} {'ic+sim_mesh s':>13} {'× reg':>6} "
              f"{'ic µs/cut cell':>14}")
        for r in rows:
            print(f"{'':>{len(str(len(sim[1]))) + 12}}{r['radius']:>6.2f} {r['cut_cells']:>9} "
                  f"{r['pairs']:>7} {r['t_register']:>10.3f} {r['t_intersected']:>7.4f} "
                  f"{r['t_queries']:>13.4f} {r['t_queries'] / r['t_register']:>6.3f} "
                  f"{1e6 * r['t_intersected'] / r['cut_cells']:>14.2f}")
        e = out[dim]
        print(f"    fitted exponent against the cut cells: intersected_cells k = "
              f"{e['exponent_intersected']:.2f}, with sim_mesh k = {e['exponent_queries']:.2f}"
              f", registration k = {e['exponent_register']:.2f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
