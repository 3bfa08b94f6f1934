"""Shared runner of the W1/W2 registration benchmarks (see w1_cube.py, w2_square.py).

Every case runs in a fresh subprocess, so that its peak memory (``ru_maxrss``, read right
after the robust registration) is its own. In the child:

1. the meshes are generated (``predicates.registration.examples``, no download);
2. the robust registration runs (``predicates.intersect``), with timers wrapped around
   the cell-level broad phase (``cell_pairs``), the sub-pair suppression (``Registration._blocked``,
   both in ``predicates.registration.levels.loop``) and the predicates (``Kind.evaluate`` of
   ``predicates.catalogue``) of every kind — wrappers installed at run time by this
   script, the library is not modified; ``res.timings`` gives setup (validation,
   scaling, tolerances), primitives, the cell-level broad phase and each kind's total;
3. peak RSS is read;
4. the naive zero-tolerance baseline runs (``tolerance_scale=0``);
5. the inconsistency count (``res.inconsistencies``: cutting vertices not located
   exactly once + cutting edges whose events do not form a walk) of both runs — a
   pure-Python counter, skipped above a size limit;
6. optionally the nearest comparable job of trimesh (3D: the tetrahedra's edges as
   segments against the sphere, through trimesh's ray queries) or shapely 2 (2D: the
   grid's edges against the cutting segments through ``STRtree.query(predicate=
   "intersects")``).
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import json  # noqa: E402
from pathlib import Path  # noqa: E402
import platform  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402

import numpy as np  # noqa: E402

#: Above this many simulation cells the pure-Python inconsistency counter is skipped
#: (it builds a set of every sub-simplex of every cell).
INCONSISTENCY_LIMIT = 250_000


def machine() -> str:
    model = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        mem = [l for l in open("/proc/meminfo") if l.startswith("MemTotal")][0].split()[1]
        mem = f", {int(mem) / 2**20:.0f} GiB RAM"
    except (OSError, IndexError):
        mem = ""
    return (f"{model}, {os.cpu_count()} cores{mem}; Python {platform.python_version()}, "
            f"numpy {np.__version__}")


def load() -> str:
    try:
        return open("/proc/loadavg").read().split()[0]
    except OSError:
        return "?"


# -- the child ------------------------------------------------------------------------------
def _meshes(case):
    from predicates.registration import examples as meshes
    n = case["n"]
    if case["dim"] == 3:
        sim = meshes.cube_grid(n)
        if case["cut"] == "sphere":
            cut = meshes.icosphere(case["subdivisions"])
        elif case["cut"] == "plane":
            cut = meshes.grid_plane(n)
        else:
            cut = meshes.grid_plane(n, offset=True)
    else:
        sim = meshes.square_grid(n)
        if case["cut"] == "circle":
            cut = meshes.circle_polygon(case["segments"])
        elif case["cut"] == "diagonal":
            cut = meshes.diagonal_cut(n)
        else:
            cut = meshes.zigzag_cut(n)
    return sim, cut


class _Timers:
    """Per-kind time of the broad phase, the suppression and the predicates, measured by
    wrappers around predicates.registration.levels.loop's functions and methods and
    predicates.catalogue.Kind.evaluate."""

    def __init__(self):
        self.t = defaultdict(lambda: defaultdict(float))
        self.kind = None

    def install(self):
        import importlib
        # the module behind predicates.intersect's level loop
        I = importlib.import_module("predicates.registration.levels.loop")
        Kind = importlib.import_module("predicates.catalogue").Kind
        timers = self
        # the cell-level broad phase (``cell_pairs``; the per-kind candidates come from
        # FacePairs inside ``_candidates``)
        orig_bp, orig_blocked, orig_eval = I.cell_pairs, I.Registration._blocked, Kind.evaluate
        orig_level = I.Registration._level

        def box_pairs(*a, **k):
            t = time.perf_counter()
            out = orig_bp(*a, **k)
            timers.t[timers.kind]["broad phase"] += time.perf_counter() - t
            if hasattr(out, "__next__"):
                return timers._wrap_gen(out)
            return out

        def _level(self, k):  # the kind's name, on the numpy and the fused path alike
            timers.kind = k.name
            return orig_level(self, k)

        def _blocked(self, *a, **k):
            t = time.perf_counter()
            out = orig_blocked(self, *a, **k)
            timers.t[timers.kind]["suppression"] += time.perf_counter() - t
            return out

        def evaluate(self, *a):
            t = time.perf_counter()
            out = orig_eval(self, *a)
            timers.t[self.name]["predicates"] += time.perf_counter() - t
            return out

        I.cell_pairs = box_pairs
        I.Registration._level = _level
        I.Registration._blocked = _blocked
        Kind.evaluate = evaluate

    def _wrap_gen(self, gen):
        kind = self.kind
        while True:
            t = time.perf_counter()
            try:
                item = next(gen)
            except StopIteration:
                self.t[kind]["broad phase"] += time.perf_counter() - t
                return
            self.t[kind]["broad phase"] += time.perf_counter() - t
            yield item


def _rss_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _current_rss_mib():
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def child(case: dict) -> dict:
    import predicates
    out = {"case": case}
    (sp, sc), (cp, cc) = _meshes(case)
    out["sim_cells"], out["cut_cells"] = len(sc), len(cc)
    dtype = np.dtype(case.get("dtype", "float64"))
    out["rss_before_mib"] = _current_rss_mib()
    timers = _Timers()
    timers.install()
    t = time.perf_counter()
    res = predicates.intersect(sp, sc, cp, cc, dtype=dtype)
    out["wall_s"] = time.perf_counter() - t
    out["peak_rss_mib"] = _rss_mib()
    out["timings"] = dict(res.timings)
    out["split"] = {k: dict(v) for k, v in timers.t.items() if k}
    out["kinds"] = list(res.kinds)
    out["registered"] = res.counts
    out["candidates"] = {k: res[k].candidates for k in res.kinds}
    out["suppressed"] = {k: res[k].suppressed for k in res.kinds}
    inside = np.ones(len(cp), dtype=bool)  # every example cut lies in the closed sim mesh
    if case.get("naive", True):
        t = time.perf_counter()
        naive = predicates.intersect(sp, sc, cp, cc, dtype=dtype, tolerance_scale=0)
        out["naive_wall_s"] = time.perf_counter() - t
        out["naive_registered"] = naive.counts
    if case.get("inconsistency", True) and len(sc) <= INCONSISTENCY_LIMIT:
        t = time.perf_counter()
        out["inconsistencies"] = res.inconsistencies(inside)
        if case.get("naive", True):
            out["naive_inconsistencies"] = naive.inconsistencies(inside)
        out["inconsistency_count_s"] = time.perf_counter() - t
    if case.get("compare"):
        out["compare"] = _compare(case, sp, sc, cp, cc)
    return out


def _compare(case, sp, sc, cp, cc):
    """The nearest comparable job in trimesh (3D) or shapely 2 (2D), if installed."""
    if case["dim"] == 3:
        try:
            import trimesh
        except ImportError:
            return {"skipped": "trimesh not installed (pip install -e '.[bench]')"}
        e = np.concatenate([sc[:, [a, b]] for a in range(4) for b in range(a + 1, 4)])
        e.sort(axis=1)
        e = np.unique(e, axis=0)
        mesh = trimesh.Trimesh(cp, cc, process=False)
        origins = sp[e[:, 0]]
        vec = sp[e[:, 1]] - origins
        length = np.linalg.norm(vec, axis=1)
        # only segments whose box meets the sphere's box: trimesh gets a free broad phase
        lo, hi = mesh.bounds
        near = np.all((np.minimum(origins, sp[e[:, 1]]) <= hi) &
                      (np.maximum(origins, sp[e[:, 1]]) >= lo), axis=1)
        t = time.perf_counter()
        try:
            from trimesh.ray.ray_triangle import RayMeshIntersector
            rmi = RayMeshIntersector(mesh)
            loc, ray_idx, tri_idx = rmi.intersects_location(
                origins[near], vec[near] / length[near, None], multiple_hits=True)
        except Exception as ex:  # pragma: no cover - optional dependency problems
            return {"skipped": f"trimesh ray query failed: {ex!r}"}
        d = np.linalg.norm(loc - origins[near][ray_idx], axis=1)
        hits = int(np.sum(d <= length[near][ray_idx]))
        return {"tool": f"trimesh {trimesh.__version__} RayMeshIntersector",
                "job": "tet-mesh edges (segments) x sphere triangles",
                "segments": int(near.sum()), "time_s": time.perf_counter() - t,
                "hits": hits}
    try:
        import shapely
    except ImportError:
        return {"skipped": "shapely not installed (pip install -e '.[bench]')"}
    e = np.concatenate([sc[:, [a, b]] for a in range(3) for b in range(a + 1, 3)])
    e.sort(axis=1)
    e = np.unique(e, axis=0)
    t0 = time.perf_counter()
    grid = shapely.linestrings(np.stack([sp[e[:, 0]], sp[e[:, 1]]], axis=1))
    cut = shapely.linestrings(np.stack([cp[cc[:, 0]], cp[cc[:, 1]]], axis=1))
    t = time.perf_counter()
    tree = shapely.STRtree(grid)
    pairs = tree.query(cut, predicate="intersects")
    t1 = time.perf_counter()
    return {"tool": f"shapely {shapely.__version__} STRtree.query(predicate='intersects')",
            "job": "grid edges x cutting segments (any contact)",
            "segments": len(e), "time_s": t1 - t, "build_geometries_s": t - t0,
            "hits": int(pairs.shape[1])}


# -- the parent -----------------------------------------------------------------------------
def emit(md: str, results: list[dict], args) -> None:
    """Print the markdown report; write it (--md) and the raw results (--json) if asked."""
    print(md)
    if args.md:
        Path(args.md).write_text(md)
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine(), "results": results},
                                              indent=1))


def run_cases(cases: list[dict]) -> list[dict]:
    """Run every case (each in its own subprocess), reporting progress on stderr."""
    results = []
    for case in cases:
        print(f"  running {label(case)} ...", file=sys.stderr, flush=True)
        r = run_case(case)
        results.append(r)
        if "error" in r:
            print(f"    FAILED: {r['error']}", file=sys.stderr)
        else:
            print(f"    {r['wall_s']:.2f} s, peak {r['peak_rss_mib']:.0f} MiB", file=sys.stderr)
    return results


def run_case(case: dict, timeout: float = 3600) -> dict:
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", json.dumps(case)],
                       capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        return {"case": case, "error": p.stderr.strip().splitlines()[-1] if p.stderr else
                f"exit {p.returncode}"}
    return json.loads(p.stdout.strip().splitlines()[-1])


def fmt_s(x):
    return "—" if x is None else (f"{x:.3f}" if x < 10 else f"{x:.1f}")


def report(title, results, level_groups):
    """Markdown tables: time split, candidates per level, registered per kind, memory,
    naive baseline, comparisons."""
    lines = [f"## {title}", "", f"Machine: {machine()}; load average at start {load()}.", ""]
    ok = [r for r in results if "error" not in r]
    for r in results:
        if "error" in r:
            lines.append(f"- {r['case']}: FAILED — {r['error']}")
    lines += ["### Wall time (s)", "",
              "| case | sim cells | cut cells | setup + tolerances | primitives | broad phase "
              "(cells) | " + " | ".join(lvl for lvl, _ in level_groups) + " | total | peak RSS (MiB) |",
              "|---|---:|---:|---:|---:|---:|" + "---:|" * len(level_groups) + "---:|---:|"]
    for r in ok:
        tm = r["timings"]
        cells = [fmt_s(sum(tm.get(k, 0) for k in kinds)) for _, kinds in level_groups]
        lines.append(f"| {label(r['case'])} | {r['sim_cells']:,} | {r['cut_cells']:,} | "
                     f"{fmt_s(tm.get('setup'))} | {fmt_s(tm.get('primitives', tm.get('ranks')))} | "
                     f"{fmt_s(tm.get('broadphase_cells'))} | " + " | ".join(cells) +
                     f" | {fmt_s(tm.get('total'))} | {r['peak_rss_mib']:,.0f} |")
    lines += ["", "Per kind: broad phase (box pairs) / suppression / predicates, seconds "
              "(the rest of a kind's time is gathering coordinates and bookkeeping):", "",
              "| case | " + " | ".join(k for _, ks in level_groups for k in ks) + " |",
              "|---|" + "---|" * sum(len(ks) for _, ks in level_groups)]
    for r in ok:
        sp = r.get("split", {})
        cells = []
        for _, ks in level_groups:
            for k in ks:
                d = sp.get(k, {})
                cells.append(f"{d.get('broad phase', 0):.2f} / {d.get('suppression', 0):.2f} / "
                             f"{d.get('predicates', 0):.2f}")
        lines.append(f"| {label(r['case'])} | " + " | ".join(cells) + " |")
    lines += ["", "### Candidate pairs (tested = candidates − suppressed) and registered "
              "pairs per kind", "",
              "| case | " + " | ".join(k for _, ks in level_groups for k in ks) + " |",
              "|---|" + "---:|" * sum(len(ks) for _, ks in level_groups)]
    for r in ok:
        cells = [f"{r['candidates'][k]:,} → {r['registered'][k]:,}"
                 for _, ks in level_groups for k in ks]
        lines.append(f"| {label(r['case'])} | " + " | ".join(cells) + " |")
    lines += ["", "### Naive zero-tolerance baseline", "",
              "| case | robust time (s) | naive time (s) | robust inconsistencies | "
              "naive inconsistencies | registered robust → naive (top level) |",
              "|---|---:|---:|---:|---:|---|"]
    for r in ok:
        top = level_groups[-1][1]
        reg = ", ".join(f"{k} {r['registered'][k]:,} → {r.get('naive_registered', {}).get(k, '—'):,}"
                        if isinstance(r.get('naive_registered', {}).get(k), int) else k
                        for k in top)
        lines.append(f"| {label(r['case'])} | {fmt_s(r['wall_s'])} | "
                     f"{fmt_s(r.get('naive_wall_s'))} | {r.get('inconsistencies', 'skipped')} | "
                     f"{r.get('naive_inconsistencies', 'skipped')} | {reg} |")
    comps = [r for r in ok if r.get("compare")]
    if comps:
        lines += ["", "### Comparable jobs in other libraries (same process)", "",
                  "| case | tool | job | segments | time (s) | hits | fperr robust total (s) |",
                  "|---|---|---|---:|---:|---:|---:|"]
        for r in comps:
            c = r["compare"]
            if "skipped" in c:
                lines.append(f"| {label(r['case'])} | — | {c['skipped']} | | | | |")
                continue
            lines.append(f"| {label(r['case'])} | {c['tool']} | {c['job']} | {c['segments']:,} | "
                         f"{fmt_s(c['time_s'])} | {c['hits']:,} | {fmt_s(r['wall_s'])} |")
    return "\n".join(lines) + "\n"


def label(case):
    if case["dim"] == 3:
        cut = {"sphere": f"sphere {20 * 4 ** case.get('subdivisions', 0):,} tris",
               "plane": "grid plane", "plane_offset": "offset plane"}[case["cut"]]
        return f"cube n={case['n']} × {cut}"
    cut = {"circle": f"circle {case.get('segments', 0):,} segs", "diagonal": "diagonal",
           "zigzag": "zig-zag"}[case["cut"]]
    return f"square n={case['n']} × {cut}" + ("" if case.get("dtype", "float64") == "float64"
                                              else f" ({case['dtype']})")


def scaling_exponent(results, key=lambda r: r["case"]["cut"]):
    """Least-squares slopes, per cut, over the sizes run: log(total time) and log(time of
    the levels alone, i.e. without setup, primitives and the cell broad phase) against
    log(candidate pairs), and log(total time) against log(simulation cells)."""
    groups = defaultdict(list)
    fixed = ("setup", "ranks", "primitives", "broadphase_cells", "total")
    for r in results:
        if "error" in r:
            continue
        tm = r["timings"]
        levels = sum(v for k, v in tm.items() if k not in fixed)
        groups[key(r)].append((sum(r["candidates"].values()), tm["total"], levels,
                               r["sim_cells"]))
    out = {}
    for k, pts in groups.items():
        if len({p[0] for p in pts}) < 2:
            continue
        lc = np.log([p[0] for p in pts])
        out[k] = {"total_vs_candidates": float(np.polyfit(lc, np.log([p[1] for p in pts]), 1)[0]),
                  "levels_vs_candidates": float(np.polyfit(lc, np.log([p[2] for p in pts]), 1)[0]),
                  "total_vs_sim_cells": float(np.polyfit(np.log([p[3] for p in pts]),
                                                         np.log([p[1] for p in pts]), 1)[0])}
    return out


def scaling_report(results, key):
    exps = scaling_exponent(results, key)
    if not exps:
        return ""
    md = ("\n### Scaling over n = " + ", ".join(str(n) for n in sorted({r["case"]["n"] for r in results}))
          + " (least-squares slopes of the logs)\n\n| cut | total time vs candidate pairs | "
          "levels' time vs candidate pairs | total time vs simulation cells |\n|---|---:|---:|---:|\n")
    for k, v in exps.items():
        md += (f"| {k} | {v['total_vs_candidates']:.2f} | {v['levels_vs_candidates']:.2f} | "
               f"{v['total_vs_sim_cells']:.2f} |\n")
    return md


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        print(json.dumps(child(json.loads(sys.argv[2]))))
    else:
        print(__doc__)
