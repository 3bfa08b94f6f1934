"""W3: predicate throughput — every 2D and 3D predicate in numpy batch mode (float64 and
float32, 10^6 random pairs), in scalar Python-float mode (10^4 pairs) and in exact
rational arithmetic (Fractions, 10^3 pairs), in one run, printed as pairs per second and
as ratios.

    python benchmarks/w3_predicates.py [--pairs 1000000] [--scalar 10000] [--exact 1000]
                                       [--repeat 3] [--json OUT.json] [--dims 2,3]

Single core: BLAS/OpenMP thread pools are pinned to one thread before numpy loads (the
predicates are element-wise numpy code, which is single-threaded anyway).

Inputs: coordinates uniform in [-1/2, 1/2]^d (one unit box, L_a = L_b = 1), a fresh
random configuration per pair. Most random pairs are rejected by the first checks; in
batch mode a block stops only when every lane in it is rejected, so with 32768-lane
blocks the whole algorithm runs on every block.
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
           "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import predicates  # noqa: E402
from exact_context import FractionContext, exact_tolerances  # noqa: E402
from intersect_bench import load, machine  # noqa: E402

#: The targets of benchmarks/README.md, "W3: predicate throughput".
TARGET_BATCH64 = 10e6          # pairs/s, 3D triangle_edge and tetrahedron_vertex
TARGET_BATCH_OVER_SCALAR = 100


def random_points(rng, n, dim, k, dtype):
    return [rng.uniform(-0.5, 0.5, size=(n, dim)).astype(dtype) for _ in range(k)]


#: "cpu": best process CPU time (robust when other processes share the cores; the
#: predicates run on one thread, so on an idle machine it equals wall time); "wall".
CLOCK = "cpu"


def best_time(fn, repeat):
    clock = time.process_time if CLOCK == "cpu" else time.perf_counter
    best = float("inf")
    for _ in range(repeat):
        t = clock()
        fn()
        best = min(best, clock() - t)
    return best


def bench_predicate(pred, n_batch, n_scalar, n_exact, repeat, rng):
    dim, k = pred.dim, len(pred.points)
    row = {"predicate": f"{dim}D {pred.name}"}
    hits = {}
    for dtype in (np.float64, np.float32):
        tol = predicates.tolerances(dim, 1.0, 1.0, dtype=dtype)
        pts = random_points(rng, n_batch, dim, k, dtype)
        pred(*[p[:1000] for p in pts], tol)  # warm up
        t = best_time(lambda: pred(*pts, tol), repeat)
        hit, _ = pred(*pts, tol)
        key = np.dtype(dtype).name
        row[f"batch_{key}"] = n_batch / t
        hits[key] = float(np.mean(hit))
    row["hit_rate"] = hits["float64"]
    # scalar Python floats
    tol = predicates.tolerances(dim, 1.0, 1.0, dtype=float)
    pts = [[tuple(map(float, p)) for p in arr] for arr in random_points(rng, n_scalar, dim, k,
                                                                         np.float64)]
    rows = list(zip(*pts))

    def scalar():
        for args in rows:
            pred(*args, tol)
    row["scalar_float"] = n_scalar / best_time(scalar, max(1, repeat - 1))
    # exact rationals
    tol_x = exact_tolerances(tol)
    ctx = FractionContext()
    nw = len(pred.weight_names)
    ex_rows = rows[:n_exact]

    def exact():
        for args in ex_rows:
            run = ctx.fresh(nw)
            coords = [run.coords(p, "") for p in args]
            pred.fn(run, *coords, tol_x)
    row["exact_fraction"] = len(ex_rows) / best_time(exact, 1)
    row["batch_over_scalar"] = row["batch_float64"] / row["scalar_float"]
    row["scalar_over_exact"] = row["scalar_float"] / row["exact_fraction"]
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=10**6)
    ap.add_argument("--scalar", type=int, default=10**4)
    ap.add_argument("--exact", type=int, default=10**3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dims", default="2,3")
    ap.add_argument("--only", default="", help="comma-separated predicate names")
    ap.add_argument("--json", help="write the figures to this file")
    ap.add_argument("--clock", choices=("cpu", "wall"), default="cpu",
                    help="cpu: best process CPU time (default; robust on a shared machine); "
                         "wall: best wall-clock time")
    args = ap.parse_args(argv)
    global CLOCK
    CLOCK = args.clock
    load0 = load()
    rng = np.random.default_rng(12345)
    only = {s for s in args.only.split(",") if s}
    rows = []
    for dim in [int(d) for d in args.dims.split(",")]:
        for pred in predicates.ALL[dim]:
            if only and pred.name not in only:
                continue
            rows.append(bench_predicate(pred, args.pairs, args.scalar, args.exact,
                                        args.repeat, rng))
            print(f"  done {rows[-1]['predicate']}", file=sys.stderr, flush=True)
    print(f"W3 predicate throughput — {machine()}; load average {load0} at start")
    print(f"batch: {args.pairs} pairs, best of {args.repeat}; scalar: {args.scalar}; "
          f"exact: {args.exact}; clock: {CLOCK} time\n")
    hdr = ("| predicate | batch f64 (pairs/s) | batch f32 (pairs/s) | scalar float (pairs/s) "
           "| exact Fraction (pairs/s) | batch/scalar | scalar/exact | hit rate |")
    print(hdr)
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['predicate']} | {r['batch_float64']:,.0f} | {r['batch_float32']:,.0f} | "
              f"{r['scalar_float']:,.0f} | {r['exact_fraction']:,.0f} | "
              f"{r['batch_over_scalar']:,.0f}× | {r['scalar_over_exact']:,.1f}× | "
              f"{r['hit_rate']:.4f} |")
    print()
    for r in rows:
        if r["predicate"] in ("3D triangle_edge", "3D tetrahedron_vertex"):
            ok = r["batch_float64"] >= TARGET_BATCH64
            print(f"target {r['predicate']} float64 batch ≥ 10M pairs/s: "
                  f"{r['batch_float64'] / 1e6:.1f}M — {'met' if ok else 'MISSED'}")
    worst = min(rows, key=lambda r: r["batch_over_scalar"])
    print(f"target batch ≥ 100× scalar: lowest {worst['batch_over_scalar']:.0f}× "
          f"({worst['predicate']}) — "
          f"{'met' if worst['batch_over_scalar'] >= TARGET_BATCH_OVER_SCALAR else 'MISSED'}")
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine(), "load": load0,
                                               "clock": CLOCK, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
