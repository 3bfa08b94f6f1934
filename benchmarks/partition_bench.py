"""Partitioned registration on Dask (docs/partitioned.md 5b): serial vs a LocalCluster of W worker
processes, on the cube grid × icosphere cases (W1: n = 48 × 20,480 triangles; W4:
n = 120, 10.4 M tetrahedra × 327,680 triangles).

    python benchmarks/partition_bench.py [--n 48] [--subdivisions 5] [--workers 2]
                                         [--partitions 2,4] [--reps 2] [--rounds 2]
                                         [--skip-serial] [--memory-limit GIB]
                                         [--json OUT.json]

Each mode runs in its own subprocess (its own peak RSS). Serial: ``intersect`` as is.
Partitioned: a LocalCluster (``partition_run.client_for``: single-threaded worker
processes) is started first (its start-up time is reported apart), then ``intersect(...,
partitions=k, scheduler=client)`` runs ``--reps`` times; ``--rounds`` alternates the
modes' child processes (the machine is shared: each mode sees the same load). Reported
per mode: the best wall time with the 1-minute load average of every run, and — since
wall time on a shared machine measures the other sessions as much as this code — the
CPU critical path: the client's serial CPU (plan, split, merge: ``res.timings``
"cpu_*") plus the busiest worker's task CPU (thread CPU of its tasks), against the
serial run's CPU. Per partition: cells received (own + halo), cutting cells, bytes sent
to the worker and back, task wall and CPU seconds, the worker process's peak RSS; and the
timeline (median over the runs): when the first and last tasks start after the plan,
and how long after the last task ends the result is back.
Every partitioned result is checked against the serial one (SHA-256 of every pair and
weight array, per kind).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def digest(res) -> str:
    h = hashlib.sha256()
    for k in res.kinds:
        p = res[k]
        for a in (p.sim, p.cut, p.sim_weights, p.cut_weights):
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def child(mode: str, n: int, subdivisions: int, workers: int, k: int, reps: int,
          refine_cut: bool = True, memory_gib: float | None = None) -> dict:
    import predicates
    from predicates.registration.examples import cube_grid, icosphere

    sp, sc = cube_grid(n)
    cp, cc = icosphere(subdivisions)
    out = {"mode": mode, "n": n, "sim_cells": len(sc), "cut_cells": len(cc), "runs": [],
           "cpu": [], "loads": []}

    limit = None if memory_gib is None else int(memory_gib * 2**30)

    def timed(**kw):
        t, c, t0 = time.perf_counter(), time.process_time(), time.time()
        res = predicates.intersect(sp, sc, cp, cc, refine_cut=refine_cut, **kw,
                                   memory_limit=limit)
        out["runs"].append(time.perf_counter() - t)
        if "partitions" in res.timings:  # the timeline: when tasks start and end
            tm, end = res.timings, t0 + out["runs"][-1]
            for key, v in (("first_start", min(p["t_begin"] for p in tm["partitions"])),
                           ("last_start", max(p["t_begin"] for p in tm["partitions"]))):
                out.setdefault(key, []).append(v - t0 - tm["setup"])  # after the plan
            out.setdefault("tail", []).append(end - max(p["t_end"] for p in tm["partitions"]))
        out["cpu"].append(time.process_time() - c)  # the client process: every thread
        out["loads"].append(load1())
        return res

    if mode == "serial":
        for _ in range(reps):
            res = timed()
    else:
        from predicates.registration.partition.run import client_for

        t = time.perf_counter()
        with client_for(workers) as client:
            out["cluster_start_s"] = time.perf_counter() - t
            for _ in range(reps):
                tm = timed(partitions=k, scheduler=client).timings
                # the CPU critical path: the client's serial CPU (plan, split, merge) +
                # the busiest worker's task CPU (its tasks run one after the other);
                # Dask's client CPU (serialisation, event loop while waiting) apart
                serial_cpu = tm["cpu_setup"] + tm["cpu_partition"] + tm["cpu_merge"]
                per_worker = {}
                for p in tm["partitions"]:
                    per_worker[p["pid"]] = per_worker.get(p["pid"], 0.0) + p["cpu_s"]
                task = max(per_worker.values())
                for key, v in (("client_serial_cpu", serial_cpu), ("task_cpu", task),
                               ("critical_cpu", serial_cpu + task),
                               ("dask_client_cpu", tm["cpu_dask"])):
                    out.setdefault(key, []).append(v)
            res = predicates.intersect(sp, sc, cp, cc, refine_cut=refine_cut, partitions=k,
                                       scheduler=client, memory_limit=limit)  # statistics
        out["partitions"] = res.timings["partitions"]
        out["split_s"] = res.timings["partition"]
        out["merge_s"] = res.timings["merge"]
    out["best_s"] = min(out["runs"])
    out["setup_s"] = res.timings["setup"]  # the global plan, on the client
    out["client_peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out["counts"] = res.counts
    out["digest"] = digest(res)
    return out


def load1() -> float:
    """The 1-minute load average (the machine is shared)."""
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run(mode, args, k=0) -> dict:
    cmd = [sys.executable, __file__, "--child", mode, "--n", str(args.n), "--subdivisions",
           str(args.subdivisions), "--workers", str(args.workers), "--k", str(k),
           "--reps", str(args.reps)] + (["--no-refine-cut"] if args.no_refine_cut else []) \
        + ([] if args.memory_limit is None else ["--memory-limit", str(args.memory_limit)])
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        raise SystemExit(f"{mode} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def _best(old, new):
    """Merge two children's records of one mode: all runs, the fastest run's details."""
    if old is None:
        return new
    keep = new if new["best_s"] < old["best_s"] else old
    assert old["digest"] == new["digest"]
    lists = {key: old[key] + new[key] for key in ("runs", "cpu", "loads", "task_cpu",
                                                  "critical_cpu", "client_serial_cpu",
                                                  "dask_client_cpu", "first_start",
                                                  "last_start", "tail") if key in old}
    return {**keep, **lists, "best_s": min(lists["runs"])}


def _fmt(xs) -> str:
    return ", ".join(f"{x:.2f}" for x in xs)


def report(serial, parts) -> str:
    import intersect_bench as B

    scpu = min(serial["cpu"]) if serial["cpu"] else float("nan")
    lines = [f"machine: {B.machine()}; load at start: {B.load()}",
             f"cube n = {serial['n']} ({serial['sim_cells']:,} tetrahedra) × icosphere "
             f"{serial['cut_cells']:,} triangles; serial best {serial['best_s']:.2f} s wall "
             f"(runs {_fmt(serial['runs'])}; load {_fmt(serial['loads'])}), best CPU "
             f"{scpu:.2f} s (global plan {serial.get('setup_s', float('nan')):.2f} s wall), "
             f"peak RSS {serial['client_peak_rss_mib']:.0f} MiB", "",
             "Wall: best run. CPU critical path (run with the smallest): the client's "
             "serial CPU (plan, split, merge) + the busiest worker's task CPU; idle-"
             "machine estimate: serial best CPU / that critical path. Dask's client CPU "
             "(serialisation, event loop while the tasks run) is listed apart.", ""]
    lines.append("| partitions | best wall (s) | runs (s) | load per run | wall speed-up | "
                 "client serial CPU (s) | busiest worker CPU (s) | critical path (s) | idle "
                 "estimate | Dask client CPU (s) | identical | split (s) | merge (s) | "
                 "client peak RSS (MiB) |")
    lines.append("|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|")
    for p in parts:
        i = min(range(len(p["critical_cpu"])), key=p["critical_cpu"].__getitem__)
        lines.append(f"| {len(p['partitions'])} | {p['best_s']:.2f} | {_fmt(p['runs'])} | "
                     f"{_fmt(p['loads'])} | {serial['best_s'] / p['best_s']:.2f}× | "
                     f"{p['client_serial_cpu'][i]:.2f} | {p['task_cpu'][i]:.2f} | "
                     f"{p['critical_cpu'][i]:.2f} | {scpu / p['critical_cpu'][i]:.2f}× | "
                     f"{p['dask_client_cpu'][i]:.2f} | "
                     f"{'yes' if p['digest'] == serial['digest'] else 'NO'} | "
                     f"{p['split_s']:.2f} | {p['merge_s']:.2f} | "
                     f"{p['client_peak_rss_mib']:.0f} |")
    lines += ["", "Timeline (ms, median over the runs): tasks start after the plan ends "
              "(split, submission, Dask's dispatch), and the results are merged after the "
              "last task ends (Dask's notification, result transfer, merge).", "",
              "| partitions | first task starts | last task starts | last task end → "
              "result |", "|---:|---:|---:|---:|"]
    for p in parts:
        med = {key: 1e3 * float(np.median(p[key])) for key in ("first_start", "last_start",
                                                               "tail")}
        lines.append(f"| {len(p['partitions'])} | {med['first_start']:.0f} | "
                     f"{med['last_start']:.0f} | {med['tail']:.0f} |")
    for p in parts:
        lines += ["", f"{len(p['partitions'])} partitions (last run):", "",
                  "| part | owned cells | cells received | cutting cells | MB sent | "
                  "MB back | task wall (s) | task CPU (s) | worker peak RSS (MiB) |",
                  "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for s in p["partitions"]:
            lines.append(f"| {s['part']} | {s['owned_cells']:,} | {s['sim_cells']:,} | "
                         f"{s['cut_cells']:,} | {s['bytes_in'] / 1e6:.2f} | "
                         f"{s['bytes_out'] / 1e6:.2f} | {s['seconds']:.2f} | "
                         f"{s['cpu_s']:.2f} | {s['peak_rss_mib']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--subdivisions", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--partitions", default="2,4")
    ap.add_argument("--reps", type=int, default=2, help="runs per child process")
    ap.add_argument("--rounds", type=int, default=2,
                    help="child processes per mode, alternating serial and partitioned")
    ap.add_argument("--skip-serial", action="store_true", help="partitioned runs only")
    ap.add_argument("--no-refine-cut", action="store_true",
                    help="intersect(..., refine_cut=False): without the (global) refinement")
    ap.add_argument("--memory-limit", type=float, metavar="GIB",
                    help="intersect(memory_limit=): the memory guard's limit in GiB (default "
                    "half the available memory; W4's serial estimate is 7.1 GiB)")
    ap.add_argument("--json")
    ap.add_argument("--child")
    ap.add_argument("--k", type=int, default=0)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child, args.n, args.subdivisions, args.workers, args.k,
                               args.reps, not args.no_refine_cut, args.memory_limit)))
        return
    serial = {"n": args.n, "sim_cells": 0, "cut_cells": 0, "best_s": float("nan"),
              "runs": [], "cpu": [], "loads": [], "client_peak_rss_mib": float("nan"),
              "digest": ""}
    ks = [int(k) for k in args.partitions.split(",")]
    parts = {}
    # rounds alternate the modes, so that each sees the same (shared machine's) load
    for _ in range(args.rounds):
        if not args.skip_serial:
            serial = _best(serial if serial["runs"] else None, run("serial", args))
        for k in ks:
            parts[k] = _best(parts.get(k), run("dask", args, k))
    parts = [parts[k] for k in ks]
    print(report(serial, parts))
    if args.json:
        Path(args.json).write_text(json.dumps({"serial": serial, "partitioned": parts},
                                              indent=1))


if __name__ == "__main__":
    main()
