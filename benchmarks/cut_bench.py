"""The cut beside the registration, timed in the same run (figures and targets in
benchmarks/README.md, "The cut"; docs/split.md): W1 (cube_grid(48), 663,552
tetrahedra × icosphere(5), 20,480 triangles) and the 2D square grid n = 512 × a circle
polygon of 4,096 segments.

Per case: the registration (``predicates.intersect``), the split (``res.split()``),
``res.intersected_cells()`` and ``res.sim_mesh()`` each on a fresh result (nothing
cached), the cut surface (``split.surface.cut_surface``) and the fragments' volumes
(``split.volume.fragment_volumes``); best of ``--repeat`` (wall, the machine may be
shared). ``--cli``: ``fperr intersect`` end to end on W1 .vtu files (a subprocess)
against reading them (meshio) + the registration in this process.

    PYTHONPATH=. python3 benchmarks/cut_bench.py [--repeat 3] [--cli] [--json FILE]
    PYTHONPATH=. python3 benchmarks/cut_bench.py --alternate [--repeat 5] [--only W1]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

from timing import best  # benchmarks/timing.py (this script's folder)

from predicates import intersect
from predicates.registration.examples import circle_polygon, cube_grid, icosphere, square_grid
from predicates.registration.split.surface import cut_surface
from predicates.registration.split.volume import fragment_boundaries, fragment_volumes



def fresh(res):
    """The result without what an earlier call kept (cut_masks)."""
    res.__dict__.pop("_cut_masks", None)
    return res


def run_case(name, sim, cut, repeat, volumes=True):
    res, t_reg = best(lambda: intersect(*sim, *cut), repeat)
    sm, t_split = best(res.split, repeat)
    _, t_ic = best(lambda: fresh(res).intersected_cells(), repeat)
    _, t_sim = best(lambda: fresh(res).sim_mesh(), repeat)
    _, t_both = best(lambda: (fresh(res).intersected_cells(), res.sim_mesh()), repeat)
    cs, t_surf = best(lambda: cut_surface(res), repeat)
    row = {"case": name, "cells": len(sim[1]), "cut_cells": len(cut[1]), "pairs": res.total,
           "new_cells": len(sm.cells), "pieces": sm.n_pieces, "polygons": len(cs),
           "t_register": t_reg, "t_split": t_split, "t_intersected_cells": t_ic,
           "t_sim_mesh": t_sim, "t_ic_then_sim_mesh": t_both, "t_surface": t_surf}
    if volumes:
        fv, t_vol = best(lambda: fragment_volumes(res, sm, cs), repeat)
        _, _, _, plain = fragment_boundaries(res, sm, cs)
        row.update(t_volumes=t_vol, unresolved=len(fv.unresolved),
                   unclaimed_cells=len(fv.claim_report()),
                   plain_cells=int(plain.sum()))
    return row


def alternate_case(name, sim, cut, repeat):
    """The registration and the fragment volumes timed alternately (best of each): on a
    shared machine the load changes between consecutive blocks of repeats."""
    t_reg = t_vol = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = intersect(*sim, *cut)
        t_reg = min(t_reg, time.perf_counter() - t0)
        sm, cs = res.split(), cut_surface(res)
        t0 = time.perf_counter()
        fragment_volumes(res, sm, cs)
        t_vol = min(t_vol, time.perf_counter() - t0)
    print(f"{name} alternating x{repeat}: registration {t_reg:.3f} s, volumes {t_vol:.3f} s "
          f"({t_vol / t_reg:.2f} × registration)")
    return {"case": name, "t_register": t_reg, "t_volumes": t_vol}


SCRIPT = ("import sys, meshio, predicates\n"
          "predicates.intersect(meshio.read(sys.argv[1]), meshio.read(sys.argv[2]))\n")


def cli_case(repeat):
    """fperr intersect on W1 files against read + registration: in this process (warm:
    imports done, kernels loaded) and as a user's script in a fresh process (what the
    command does without its command line)."""
    import meshio

    with tempfile.TemporaryDirectory() as d:
        (P, T), (Q, F) = cube_grid(48), icosphere(5)
        sim, cut = os.path.join(d, "sim.vtu"), os.path.join(d, "cut.vtu")
        meshio.Mesh(P, [("tetra", T)]).write(sim)
        meshio.Mesh(Q, [("triangle", F)]).write(cut)

        def read_register():
            a, b = meshio.read(sim), meshio.read(cut)
            return intersect(a, b)

        res, t_base = best(read_register, repeat)
        env = dict(os.environ, PYTHONPATH=os.getcwd())
        cmd = [sys.executable, "-m", "proofs.cli", "intersect", sim, cut, "--quiet"]
        script = [sys.executable, "-c", SCRIPT, sim, cut]
        t_cli = t_script = float("inf")
        for _ in range(repeat):  # in turns: the machine's load drifts
            t_cli = min(t_cli, best(lambda: subprocess.run(cmd, env=env, check=True,
                                                           capture_output=True), 1)[1])
            t_script = min(t_script, best(lambda: subprocess.run(script, env=env,
                                                                 check=True), 1)[1])
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import proofs.cli, predicates, meshio"],
                       env=env, check=True)
        t_import = time.perf_counter() - t0
    return {"t_read_register": t_base, "t_fperr_intersect": t_cli,
            "t_script_read_register": t_script, "t_python_imports": t_import,
            "accelerated": bool(res.timings["accelerated"])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cli", action="store_true", help="fperr intersect end to end on W1")
    ap.add_argument("--no-volumes", action="store_true", help="skip the volumes")
    ap.add_argument("--only", choices=["W1", "2D"], help="one case only")
    ap.add_argument("--alternate", action="store_true",
                    help="only the registration and the volumes, timed alternately")
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    if args.alternate:
        out = []
        if args.only in (None, "W1"):
            out.append(alternate_case("W1", cube_grid(48), icosphere(5), args.repeat))
        if args.only in (None, "2D"):
            out.append(alternate_case("2D n=512", square_grid(512), circle_polygon(8 * 512),
                                      args.repeat))
        if args.json:
            with open(args.json, "w") as f:
                json.dump({"alternate": out}, f, indent=1)
        return
    rows = []
    if args.only in (None, "W1"):
        rows.append(run_case("W1", cube_grid(48), icosphere(5), args.repeat,
                             not args.no_volumes))
    if args.only in (None, "2D"):
        rows.append(run_case("2D n=512", square_grid(512), circle_polygon(8 * 512),
                             args.repeat, not args.no_volumes))
    for r in rows:
        reg = r["t_register"]
        print(f"{r['case']}: {r['cells']} cells, {r['pairs']} pairs, {r['new_cells']} new cells, "
              f"{r['pieces']} pieces, {r['polygons']} cut polygons")
        for k in ("t_register", "t_split", "t_intersected_cells", "t_sim_mesh",
                  "t_ic_then_sim_mesh", "t_surface", "t_volumes"):
            if k in r:
                print(f"  {k[2:]:<22} {r[k]:8.3f} s  {r[k] / reg:6.2f} × registration")
        if "unresolved" in r:
            print(f"  volumes: {r['unresolved']} cells unresolved, {r['unclaimed_cells']} "
                  f"with unclaimed material, {r['plain_cells']} plain cells summed "
                  "vectorised (the rest cell by cell)")
    out = {"rows": rows}
    if args.cli:
        c = cli_case(args.repeat)
        out["cli"] = c
        t = c["t_fperr_intersect"]
        print(f"fperr intersect W1: {t:.3f} s; read + registration in this process "
              f"{c['t_read_register']:.3f} s (ratio {t / c['t_read_register']:.2f}, "
              f"compiled chain: {c['accelerated']}); the same as a script in a fresh "
              f"process {c['t_script_read_register']:.3f} s (ratio "
              f"{t / c['t_script_read_register']:.2f}); python + imports alone "
              f"{c['t_python_imports']:.3f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
