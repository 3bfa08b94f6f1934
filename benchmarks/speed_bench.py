"""End-to-end registration speed and memory against the cost of the predicates.

    python benchmarks/speed_bench.py [--cases w1,w2,w4,w5,scaling] [--w5-sizes 500,1000,2000,4000]
                                     [--no-naive] [--json OUT.json] [--md OUT.md]

* **Naive predicate baseline**, timed first in the parent (process CPU time, best of 3):
  a naive numpy orient3d triangle-edge test (five 3×3 determinants with their sign
  tests) over 2^20 random pairs. Every registration's time is reported as a ratio to it.
* **W1** cube n = 48 (663,552 Kuhn tetrahedra) × icosphere of 20,480 triangles; **W2**
  square n = 1024 (2.1 M triangles) × circle of 65,536 segments; **W4** cube n = 120
  (10.4 M tetrahedra) × icosphere of 327,680 triangles; **W5** the crowded broad-phase
  cell (:func:`crowded`), N = 500 … 4000; **scaling**: W1 n = 32, 48, 64, 96 × sphere
  20,480 and W2 n = 256, 512, 1024 × circle 65,536, with least-squares exponents (of
  the CPU time, and of the registration's own stages after the global plan).

Every case runs in its own subprocess (``--child``). There a thread samples the resident
set size (``/proc/self/statm``) every 2 ms; the stages' time intervals are rebuilt from
``res.timings`` (sequential stages, insertion order), so each stage gets its own peak
RSS; ``VmHWM`` gives the case's overall peak. Times are process CPU time (the
pipeline runs on one thread, so on an idle machine CPU ≈ wall; this machine is shared)
and wall time. ``tolerance_scale=0`` (the naive zero-tolerance registration) runs in the
same child for the robust/naive ratio, followed by a second robust run; the reported CPU
time is then the better of the two robust runs (the first pays the page faults of fresh
memory).
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from intersect_bench import load, machine  # noqa: E402

PAGE_MIB = os.sysconf("SC_PAGE_SIZE") / 2 ** 20


# -- the naive predicate ------------------------------------------------------------------
def _orient(a, b, c, d):
    """orient3d(a, b, c, d) = det[b − a, c − a, d − a], per column arrays (x, y, z)."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    wx, wy, wz = d[0] - a[0], d[1] - a[1], d[2] - a[2]
    return ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx)


def naive_triangle_edge(T, E):
    """Naive segment-triangle test: P, Q on opposite sides of ABC and PQ passing
    inside all three edges (signs of orient3d, no tolerance). T (3, 3, n), E (2, 3, n)."""
    A, B, C = T
    P, Q = E
    sp, sq = _orient(A, B, C, P), _orient(A, B, C, Q)
    e1, e2, e3 = _orient(P, Q, A, B), _orient(P, Q, B, C), _orient(P, Q, C, A)
    cross = (sp > 0) != (sq > 0)
    inside = ((e1 > 0) & (e2 > 0) & (e3 > 0)) | ((e1 < 0) & (e2 < 0) & (e3 < 0))
    return cross & inside


def naive_baseline(n=1 << 20, repeat=3, seed=0):
    """Best process CPU time of the naive test over n random pairs (in [−½, ½]³)."""
    rng = np.random.default_rng(seed)
    T = rng.uniform(-0.5, 0.5, size=(3, 3, n))
    E = rng.uniform(-0.5, 0.5, size=(2, 3, n))
    best = float("inf")
    for _ in range(repeat):
        t = time.process_time()
        hits = naive_triangle_edge(T, E)
        best = min(best, time.process_time() - t)
    return {"pairs": n, "cpu_s": best, "pairs_per_s": n / best, "hit_rate": float(hits.mean())}


# -- meshes -------------------------------------------------------------------------------
def _examples():
    try:  # the example generators move with the registration subpackage
        from predicates.registration import examples
    except ImportError:
        from predicates import meshes as examples
    return examples


def crowded(N: int, far: int = 3000, size: float = 1e-3, box: float = 0.4, seed: int = 0):
    """W5: N tiny tetrahedra and N tiny triangles (edge ≈ ``size``) at random in a
    ``box``-wide cube, mostly out of each other's reach, plus ``far`` unit-size
    tetrahedron/triangle pairs (each triangle through its tetrahedron) on a lattice
    elsewhere, which make a uniform grid's cells ≫ the tiny cells."""
    rng = np.random.default_rng(seed)
    unit_tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    unit_tri = np.array([[-0.2, 0.3, 0.3], [1.0, 0.3, 0.3], [0.3, 0.3, 1.0]])
    side = int(np.ceil(far ** (1 / 3)))
    lat = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), -1).reshape(-1, 3)[:far]
    offs_far = 2.0 + 3.0 * lat.astype(np.float64)
    offs_tiny_s = rng.uniform(0, box, size=(N, 3))
    offs_tiny_c = rng.uniform(0, box, size=(N, 3))
    jit = lambda n, k: rng.uniform(-0.1, 0.1, size=(n, k, 3))  # noqa: E731
    sim = np.concatenate([offs_far[:, None] + unit_tet + jit(far, 4) * 0.5,
                          offs_tiny_s[:, None] + size * (unit_tet + jit(N, 4))])
    cut = np.concatenate([offs_far[:, None] + unit_tri,
                          offs_tiny_c[:, None] + size * (unit_tri + jit(N, 3))])
    sp = sim.reshape(-1, 3)
    sc = np.arange(len(sp), dtype=np.int64).reshape(-1, 4)
    cp = cut.reshape(-1, 3)
    cc = np.arange(len(cp), dtype=np.int64).reshape(-1, 3)
    return (sp, sc), (cp, cc)


def meshes(case):
    ex = _examples()
    if case["w"] in ("W1", "W4"):
        return ex.cube_grid(case["n"]), ex.icosphere(case["subdivisions"])
    if case["w"] == "W2":
        return ex.square_grid(case["n"]), ex.circle_polygon(case["segments"])
    return crowded(case["N"])


# -- the child ----------------------------------------------------------------------------
class _RSS:
    """Samples the resident set size every ``dt`` seconds in a thread."""

    def __init__(self, dt=0.002):
        self.dt, self.samples, self._stop = dt, [], threading.Event()
        self._f = open("/proc/self/statm")
        self._th = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            self._f.seek(0)
            self.samples.append((time.perf_counter(), int(self._f.read().split()[1]) * PAGE_MIB))
            time.sleep(self.dt)

    def __enter__(self):
        self._th.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._th.join()


#: timings measured inside another stage (``refine`` runs within ``setup``)
from predicates.registration.pipeline import PLAN_STAGES as NESTED  # noqa: E402  (inside "setup")


def _hwm_mib():
    """Peak RSS of this process (VmHWM): unlike ru_maxrss it is not inherited from the
    parent at fork, which holds the naive baseline's arrays."""
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def stage_peaks(samples, t0, timings):
    """Peak sampled RSS per stage, the stages laid end to end from t0 in the order of
    ``timings`` (the pipeline's stages are sequential)."""
    out, t = {}, t0
    s = np.array(samples) if samples else np.zeros((0, 2))
    for k, v in timings.items():
        if k in NESTED:  # inside "setup": its interval is not laid end to end
            out[k] = None
            continue
        if k in ("total", "accelerated"):  # not stages: the sum, which path ran
            continue
        sel = (s[:, 0] >= t - 0.002) & (s[:, 0] <= t + v + 0.002) if len(s) else []
        out[k] = float(s[sel, 1].max()) if len(s) and np.any(sel) else None
        t += v
    return out


def _mem_total():
    """MemTotal in bytes: the benchmark's memory_limit. The pipeline's default guard
    (half the memory available *now*) refuses W4 on a machine other jobs share — its
    estimate (256 bytes per estimated cell pair, 7 GiB for W4) is far above W4's
    measured peak (≈ 2.5 GiB); the peak is measured and reported here instead."""
    for line in open("/proc/meminfo"):
        if line.startswith("MemTotal:"):
            return int(line.split()[1]) * 1024
    return None


def child(case):
    import predicates
    (sp, sc), (cp, cc) = meshes(case)
    limit = _mem_total()
    out = {"case": case, "sim_cells": len(sc), "cut_cells": len(cc)}
    with _RSS() as rss:
        time.sleep(0.01)
        out["rss_before_mib"] = rss.samples[-1][1] if rss.samples else None
        c0, t0 = time.process_time(), time.perf_counter()
        res = predicates.intersect(sp, sc, cp, cc, memory_limit=limit)
        out["cpu_s"], out["wall_s"] = time.process_time() - c0, time.perf_counter() - t0
    out["peak_rss_mib"] = _hwm_mib()
    out["timings"] = {k: float(v) for k, v in res.timings.items()}
    out["stage_peak_mib"] = stage_peaks(rss.samples, t0, res.timings)
    out["candidates"] = int(sum(res[k].candidates for k in res.kinds))
    out["cut_cells_registered"] = len(res.cut_cells)  # after refinement
    out["registered"] = int(sum(res.counts.values()))
    del res
    if case.get("naive", True):
        # naive, then robust again: the first run in a process pays the page faults of
        # fresh memory; the ratio compares the best robust run with the naive one
        c0 = time.process_time()
        naive = predicates.intersect(sp, sc, cp, cc, tolerance_scale=0, memory_limit=limit)
        out["naive_cpu_s"] = time.process_time() - c0
        out["naive_registered"] = int(sum(naive.counts.values()))
        del naive
        c0 = time.process_time()
        predicates.intersect(sp, sc, cp, cc, memory_limit=limit)
        out["cpu_s_first"] = out["cpu_s"]
        out["cpu_s"] = min(out["cpu_s"], time.process_time() - c0)
    return out


def run_case(case, timeout=3600):
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(case)],
                       capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        tail = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"
        return {"case": case, "error": tail}
    return json.loads(p.stdout.strip().splitlines()[-1])


# -- the parent ---------------------------------------------------------------------------
def label(case):
    if case["w"] == "W5":
        return f"W5 N={case['N']}"
    cut = (f"sphere {20 * 4 ** case['subdivisions']:,}" if "subdivisions" in case
           else f"circle {case['segments']:,}")
    return f"{case['w']} n={case['n']} × {cut}"


def cases_for(names, w5_sizes, naive):
    W1 = lambda n: {"w": "W1", "n": n, "subdivisions": 5, "naive": naive}  # noqa: E731
    W2 = lambda n: {"w": "W2", "n": n, "segments": 65536, "naive": naive}  # noqa: E731
    out = []
    for name in names:
        if name == "w1":
            out.append(W1(48))
        elif name == "w2":
            out.append(W2(1024))
        elif name == "w4":
            out.append({"w": "W4", "n": 120, "subdivisions": 7, "naive": False})
        elif name == "w5":
            out += [{"w": "W5", "N": N, "naive": False} for N in w5_sizes]
        elif name == "scaling":
            out += [W1(n) for n in (32, 48, 64, 96)] + [W2(n) for n in (256, 512, 1024)]
        else:
            raise SystemExit(f"unknown case group {name!r}")
    unique = []  # w1 and scaling both hold W1 n = 48 (w2: n = 1024): run each once
    for c in out:
        if c not in unique:
            unique.append(c)
    return unique


def registration_s(r):
    """Wall time of the registration's own stages (rank space, broad phase, kinds):
    everything after the global plan (``setup``, which includes ``refine``)."""
    return sum(v for k, v in r["timings"].items()
               if k not in ("setup", "total", "accelerated") + NESTED)


def slope(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def report(base, results):
    t_naive = base["cpu_s"]
    L = [f"Machine: {machine()}; load average at start {load()}.", "",
         f"Naive numpy triangle-edge (orient3d signs) over 2^20 random pairs: "
         f"{t_naive * 1e3:.1f} ms CPU ({base['pairs_per_s'] / 1e6:.1f} M pairs/s).", "",
         "| case | sim cells | cut cells (refined) | candidates | CPU (s) | wall (s) | × naive 2^20 | "
         "peak RSS (MiB) | MiB / 1,000 sim cells | robust / naive reg. |",
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    ok = [r for r in results if "error" not in r]
    for r in results:
        if "error" in r:
            L.insert(0, f"- {label(r['case'])}: FAILED — {r['error']}")
    for r in ok:
        rn = f"{r['cpu_s'] / r['naive_cpu_s']:.2f}" if "naive_cpu_s" in r else "—"
        refined = r.get("cut_cells_registered", r["cut_cells"])
        L.append(f"| {label(r['case'])} | {r['sim_cells']:,} | {r['cut_cells']:,} ({refined:,}) | "
                 f"{r['candidates']:,} | {r['cpu_s']:.2f} | {r['wall_s']:.2f} | "
                 f"{r['cpu_s'] / t_naive:.1f} | {r['peak_rss_mib']:,.0f} | "
                 f"{r['peak_rss_mib'] / (r['sim_cells'] / 1000):.3f} | {rn} |")
    L += ["", "Per stage: seconds (wall) / peak sampled RSS (MiB):", ""]
    for r in ok:
        st = ", ".join(f"{k} {v:.2f} s / {r['stage_peak_mib'].get(k) or 0:,.0f}"
                       for k, v in r["timings"].items() if k != "total")
        L.append(f"- {label(r['case'])} (RSS before {r['rss_before_mib']:,.0f} MiB): {st}")
    L.append("")
    for w, key in (("W1", "n"), ("W2", "n"), ("W5", "N")):
        rs = sorted((r for r in ok if r["case"]["w"] == w), key=lambda r: r["case"][key])
        if len(rs) >= 2:
            xs = [r["case"][key] for r in rs]
            # the cutting cells registered: after refinement (W1 n = 96: 74,672 of 20,480)
            size = [r["sim_cells"] + r.get("cut_cells_registered", r["cut_cells"]) +
                    r["candidates"] for r in rs]
            L.append(f"{w} over {key} = {', '.join(map(str, xs))}: exponent of CPU time vs "
                     f"(sim cells + refined cut cells + candidates) "
                     f"{slope(size, [r['cpu_s'] for r in rs]):.2f}; of the registration "
                     f"stages alone (wall) {slope(size, [registration_s(r) for r in rs]):.2f}" +
                     (f", vs N {slope(xs, [r['cpu_s'] for r in rs]):.2f}; peak RSS vs N "
                      f"{slope(xs, [r['peak_rss_mib'] - r['rss_before_mib'] for r in rs]):.2f}"
                      if w == "W5" else ""))
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="w1,w2,w4,w5,scaling")
    ap.add_argument("--w5-sizes", default="500,1000,2000,4000")
    ap.add_argument("--no-naive", action="store_true")
    ap.add_argument("--json")
    ap.add_argument("--md")
    args = ap.parse_args(argv)
    base = naive_baseline()
    print(f"naive triangle-edge 2^20: {base['cpu_s'] * 1e3:.1f} ms", file=sys.stderr)
    results = []
    for case in cases_for(args.cases.split(","), [int(x) for x in args.w5_sizes.split(",")],
                          not args.no_naive):
        print(f"  running {label(case)} ...", file=sys.stderr, flush=True)
        r = run_case(case)
        results.append(r)
        print(f"    {r.get('error') or '%.2f s CPU, %.0f MiB' % (r['cpu_s'], r['peak_rss_mib'])}",
              file=sys.stderr, flush=True)
    md = report(base, results)
    print(md)
    if args.md:
        Path(args.md).write_text(md)
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine(), "naive": base,
                                               "results": results}, indent=1))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        print(json.dumps(child(json.loads(sys.argv[2]))))
    else:
        main()
