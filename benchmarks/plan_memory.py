"""The serial run's plan share and peak memory on one mesh (docs/partitioned.md, section
2, "the lean plan"): W4 by default (cube n = 120 × icosphere 7).

    python benchmarks/plan_memory.py [--n 120] [--subdivisions 7]

The mesh is built first, then the process's high-water mark is reset
(``/proc/self/clear_refs``), so the peak printed is the run's (with the mesh it holds);
prints the plan's stages and CPU, the run's CPU, the peak RSS against the mesh's bytes
and the SHA-256 of every pair and weight array (W4: db30dc9b…).
"""
from __future__ import annotations

import argparse
import gc
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def status(field: str) -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=120)
    ap.add_argument("--subdivisions", type=int, default=7)
    a = ap.parse_args(argv)
    import predicates
    from predicates.registration.examples import cube_grid, icosphere

    sp, sc = cube_grid(a.n)
    cp, cc = icosphere(a.subdivisions)
    mesh = (sp.nbytes + sc.nbytes) / 2**20
    gc.collect()
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    base = status("VmRSS")
    t, c = time.perf_counter(), time.process_time()
    res = predicates.intersect(sp, sc, cp, cc, memory_limit=20 << 30)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    tm = res.timings
    print(f"mesh {mesh:.0f} MiB; before the run {base:.0f} MiB RSS")
    print("plan stages (wall s):", {k: round(tm[k], 3) for k in
                                    ("plan_validate", "plan_boxes", "refine", "plan_scale",
                                     "plan_report") if k in tm})
    print(f"plan {tm['setup']:.2f} s wall, {tm['cpu_setup']:.2f} s CPU; run {wall:.2f} s "
          f"wall, {cpu:.2f} s CPU: plan {100 * tm['cpu_setup'] / cpu:.1f} % of the CPU")
    peak = status("VmHWM")
    print(f"peak RSS {peak:.0f} MiB = {peak / mesh:.2f} x the mesh")
    h = hashlib.sha256()
    for k in res.kinds:
        p = res[k]
        for arr in (p.sim, p.cut, p.sim_weights, p.cut_weights):
            h.update(np.ascontiguousarray(arr).tobytes())
    print("digest", h.hexdigest())


if __name__ == "__main__":
    main()
