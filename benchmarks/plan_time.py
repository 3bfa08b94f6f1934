"""The plan's CPU time on one mesh (benchmarks/README.md, "Plan passes, eighth pass"):
``pipeline._plan`` (validation, boxes, refinement, L, scaling, report) called
repeatedly in one process after two warm-up calls, process CPU per call, best and
median, and each plan stage's wall time (best and median).

    FPERR_ACCELERATE=1 python benchmarks/plan_time.py [W1|W4|tiny] [calls]

Run it from the tree to measure (the tree's ``predicates`` is imported); compare two
trees in fresh processes, alternating.
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.getcwd())
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__))))


def main() -> None:
    import numpy as np

    from speed_bench import meshes
    from predicates.registration import pipeline

    w = sys.argv[1] if len(sys.argv) > 1 else "W1"
    calls = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    spec = {"W1": {"w": "W1", "n": 48, "subdivisions": 5},
            "W4": {"w": "W4", "n": 120, "subdivisions": 7},
            "tiny": {"w": "W1", "n": 8, "subdivisions": 2}}[w]  # tiny: the smoke test's
    sim, cut = meshes(spec)

    def plan() -> dict:
        stages: dict = {}
        pipeline._plan([sim, cut], np.float64, 1.0, False, pipeline.CHUNK, True, stages,
                       None, None, None, accelerate=None)
        return stages

    plan(), plan()
    cpu, stages = [], []
    for _ in range(calls):
        c = time.process_time()
        stages.append(plan())
        cpu.append(time.process_time() - c)
    print(f"{w} plan CPU best {min(cpu):.4f} s, median {np.median(cpu):.4f} s "
          f"({calls} calls; {pipeline.__file__})")
    for k in pipeline.PLAN_STAGES:
        v = [s[k] for s in stages if k in s]
        if v:
            print(f"  {k:14s} best {min(v):.4f} s, median {np.median(v):.4f} s")


if __name__ == "__main__":
    main()
