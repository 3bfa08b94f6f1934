"""W2: 2D registration — the unit square as an n×n grid of triangle pairs (n = 256, 1024:
131,072 / 2,097,152 triangles) cut by circles of 4,096 and 65,536 segments and by the
diagonal y = x through the grid vertices (maximum degeneracy).

    python benchmarks/w2_square.py [--sizes 256,1024] [--cuts circle4096,circle65536,diagonal]
                                   [--dtype float64] [--no-compare] [--json OUT] [--md OUT]

Each case runs in its own subprocess (see intersect_bench.py); shapely 2's STRtree runs
the nearest comparable job (grid edges × cutting segments, any contact) when installed.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import intersect_bench as B  # noqa: E402

LEVELS = [("vertex-vertex", ["vertex_vertex"]),
          ("edge-vertex level", ["vertex_edge", "edge_vertex"]),
          ("top level", ["edge_edge", "triangle_vertex"])]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="256,1024")
    ap.add_argument("--cuts", default="circle4096,circle65536,diagonal")
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--no-compare", action="store_true", help="skip shapely")
    ap.add_argument("--json")
    ap.add_argument("--md")
    args = ap.parse_args(argv)
    cases = []
    for n in [int(x) for x in args.sizes.split(",")]:
        for cut in args.cuts.split(","):
            case = {"dim": 2, "n": n, "dtype": args.dtype}
            if cut.startswith("circle"):
                case.update(cut="circle", segments=int(cut[6:] or 4096))
            else:
                case.update(cut=cut)
            case["compare"] = not args.no_compare
            cases.append(case)
    results = B.run_cases(cases)
    md = B.report(f"W2: square grid × circle / diagonal (2D, {args.dtype})", results, LEVELS)
    md += B.scaling_report(results, key=lambda r: B.label(r["case"]).split("× ")[1])
    B.emit(md, results, args)


if __name__ == "__main__":
    main()
