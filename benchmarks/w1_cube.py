"""W1: 3D registration — the unit cube as an n×n×n grid of Kuhn tetrahedra (n = 16, 32,
48: 24,576 / 196,608 / 663,552 tetrahedra) cut by the grid-aligned plane z = k/n
(maximum degeneracy), by the same plane with its vertices offset by half a cell (its
edges then lie in the grid's faces) and by icospheres of 5,120 and 20,480 triangles.

    python benchmarks/w1_cube.py [--sizes 16,32,48] [--cuts plane,sphere4,sphere5]
                                 [--no-compare] [--json OUT.json] [--md OUT.md]

Each case runs in its own subprocess (see intersect_bench.py). Targets (benchmarks/README.md, "W1"): at
n = 32 with the 20,480-triangle sphere, registration ≤ 10 s and peak memory ≤ 2 GiB;
time close to linear in the candidate pair count from n = 16 to 48 (the exponent is
printed).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import intersect_bench as B  # noqa: E402

LEVELS = [("vertex-vertex", ["vertex_vertex"]),
          ("edge-vertex level", ["vertex_edge", "edge_vertex"]),
          ("edge-edge level", ["edge_edge", "vertex_triangle", "triangle_vertex"]),
          ("top level", ["edge_triangle", "triangle_edge", "tetrahedron_vertex"])]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="16,32,48")
    ap.add_argument("--cuts", default="plane,plane_offset,sphere4,sphere5")
    ap.add_argument("--no-compare", action="store_true", help="skip trimesh")
    ap.add_argument("--compare-max-n", type=int, default=32,
                    help="run the trimesh comparison up to this n (default 32; it takes "
                         "minutes at n = 32)")
    ap.add_argument("--json")
    ap.add_argument("--md")
    args = ap.parse_args(argv)
    cases = []
    for n in [int(x) for x in args.sizes.split(",")]:
        for cut in args.cuts.split(","):
            case = {"dim": 3, "n": n}
            if cut.startswith("sphere"):
                case.update(cut="sphere", subdivisions=int(cut[6:] or 5))
            elif cut not in ("plane", "plane_offset"):
                ap.error(f"unknown cut {cut!r}")
            else:
                case.update(cut=cut)
            case["compare"] = (not args.no_compare and case["cut"] == "sphere"
                               and n <= args.compare_max_n)
            cases.append(case)
    results = B.run_cases(cases)
    md = B.report("W1: cube grid × plane / sphere (3D, float64)", results, LEVELS)
    md += B.scaling_report(results, key=lambda r: B.label(r["case"]).split("× ")[1])
    target = [r for r in results if "error" not in r and r["case"]["n"] == 32
              and r["case"].get("subdivisions") == 5]
    for r in target:
        ok_t = r["timings"]["total"] <= 10
        ok_m = r["peak_rss_mib"] <= 2048
        md += (f"\nTarget n = 32 × sphere 20,480: registration {r['timings']['total']:.2f} s "
               f"({'met' if ok_t else 'MISSED'}: ≤ 10 s), peak RSS {r['peak_rss_mib']:.0f} MiB "
               f"({'met' if ok_m else 'MISSED'}: ≤ 2048 MiB)\n")
    B.emit(md, results, args)


if __name__ == "__main__":
    main()
