"""The plan's sweep over the simulation cells (docs/resolution.md, "The first round"):
validation's check and the boxes' summary of W4's tetrahedra (cube 120 × icosphere 7)
in one compiled pass, without and with the first round's flags at the grid the cutting
mesh fixes (``CellBoxes.checked_summary(used, grid)``), process CPU per call and the
number of flagged cells.

    FPERR_ACCELERATE=1 python benchmarks/sweep_flags.py [n] [subdivisions] [calls]

Run it from the tree to measure; compare two trees in fresh processes, alternating.
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.getcwd())


def main(argv: list[str] | None = None) -> None:
    import numpy as np

    from predicates.registration.examples import cube_grid, icosphere
    from predicates.registration.plan import first_round
    from predicates.registration.plan.cellboxes import CellBoxes
    from predicates.registration.spatial.blocks import Blocks
    from predicates.registration.spatial.boxes import boxes_of

    argv = sys.argv[1:] if argv is None else argv
    n = int(argv[0]) if argv else 120
    s = int(argv[1]) if len(argv) > 1 else 7
    calls = int(argv[2]) if len(argv) > 2 else 5
    sp, sc = cube_grid(n)
    cp, cc = icosphere(s)
    blocks = Blocks(accelerate=True)
    grid = first_round.speculative(*boxes_of(cp, cc, blocks=blocks), len(sc), blocks)
    times: dict = {"without": [], "with": []}
    for _ in range(calls + 1):  # the first: compiling or loading the kernels
        for name, g in (("without", None), ("with", grid)):
            used = np.zeros(len(sp), dtype=bool)
            c = time.process_time()
            got = CellBoxes(sp, sc, blocks).checked_summary(used, g)
            times[name].append(time.process_time() - c)
    flagged = int(got.first[1][0][1][0].sum())
    print(f"sweep n={n} s={s}: {len(sc)} cells, {flagged} flagged; CPU best (median) "
          + ", ".join(f"{k} flags {min(v[1:]):.3f} ({np.median(v[1:]):.3f}) s"
                      for k, v in times.items())
          + f"; load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
