"""The client's split of a partitioned run against the number of partitions (docs/partitioned.md 5b):
does cutting k partitions stay proportional to the mesh, not to k × the mesh?

    python benchmarks/partition_split.py [--n 48] [--subdivisions 5] [--ks 2,8,32,128]
                                         [--reps 3] [--json OUT.json]

On W1 (n = 48 × icosphere 5) or W4 (``--n 120 --subdivisions 7``): the plan once, then
for each k the split (``partition.split``: the Layout — Morton order, vertex owners,
halos — and every Part) timed, best of ``--reps``, with the cells and cutting cells
the partitions receive in all and the bytes sent. Baseline timed in the same run: the
serial registration after the plan (``pipeline._ranked`` then ``Registration.run``), so the split reads as a
fraction of the work it distributes.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _best(f, reps: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(reps):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--subdivisions", type=int, default=5)
    ap.add_argument("--ks", default="2,8,32,128")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--json")
    a = ap.parse_args(argv)

    from predicates.registration import examples, pipeline
    from predicates.registration.partition.assign import split

    (sp, sc), (cp, cc) = examples.cube_grid(a.n), examples.icosphere(a.subdivisions)
    plan = pipeline._plan((sp, sc, cp, cc), np.float64, 1.0, False, pipeline.CHUNK, True,
                          {}, None, None)
    pad = max(plan.scale.reach.values())
    reg, _ = _best(lambda: pipeline._ranked(plan, pipeline.CHUNK, {})[0].run(False, {}),
                   min(a.reps, 2))
    print(f"cube n = {a.n} ({len(sc):,} tetrahedra; {len(plan.sim_cells):,} run cells, "
          f"{len(plan.P_sim):,} points) x icosphere {len(cc):,} triangles "
          f"({len(plan.cut_cells):,} refined); serial registration {reg * 1e3:.0f} ms\n")
    print("| k | split (ms) | per partition (ms) | split / registration | cells received "
          "(all partitions) | cutting cells received | MB sent |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    for k in (int(x) for x in a.ks.split(",")):
        t, parts = _best(lambda: list(split(plan.P_sim, plan.sim_cells, plan.P_cut,
                                            plan.cut_cells, k, pad)), a.reps)
        row = {"k": k, "split_s": t, "registration_s": reg,
               "cells": sum(len(p.sim_cells) for p in parts),
               "cut_cells": sum(len(p.cut_cells) for p in parts),
               "mb_sent": sum(p.nbytes for p in parts) / 1e6}
        rows.append(row)
        print(f"| {k} | {t * 1e3:.1f} | {t / k * 1e3:.2f} | {t / reg:.3f} | "
              f"{row['cells']:,} | {row['cut_cells']:,} | {row['mb_sent']:.1f} |", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
