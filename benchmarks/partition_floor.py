"""Where a partitioned W1 run's time goes, and what each part bounds (docs/partitioned.md 5b).

    python benchmarks/partition_floor.py [--n 48] [--subdivisions 5] [--reps 9]
                                         [--json OUT.json]

One process, one LocalCluster of 2 single-threaded workers
(``partition_run.client_for``), every quantity timed in alternation with the others
(this machine is shared: each sees the same load), best and median of ``--reps``:

* ``serial``: ``intersect`` as is; ``plan``: its global plan (``pipeline._plan``);
  ``plan_threaded``: the same on 2 threads (a partitioned run's; the bounds take the
  faster of the two);
  ``register``: the rest (``pipeline._ranked`` then ``Registration.run``);
* ``partitioned``: ``intersect(partitions=2, scheduler=client)``; ``post_plan``: the
  same run given the finished plan (``run_partitioned``: split, Dask, merge);
  ``post_plan_presplit``: the parts cut beforehand, only their tasks and the merge;
* ``plan_cells_client``: the plan's per-cell work over every simulation cell on the
  client (boxes, their largest edge, the near flags against the cutting boxes);
  ``plan_cells_hop``: the same work sent to the 2 workers as one task each (half the
  cells each, int32 ids, the points and the cutting boxes; the flags and the largest
  edge come back): what distributing the plan's per-cell passes would cost, Dask's
  round trip and the transfer included.

Bounds printed, each an upper bound on the speed-up of the partitioned run:
``serial / (plan + post_plan_presplit)`` (a free split), ``serial / (plan −
plan_cells_client + plan_cells_hop + post_plan_presplit)`` (the per-cell plan
distributed in one extra round trip, the rest of the plan free of cost), ``serial /
(plan on 1 thread / 2 + post_plan_presplit)`` (the plan perfectly parallel, a free
split), and
``serial / post_plan_presplit`` (a free plan); and the registration's own speed-up,
``register / post_plan_presplit`` (what the tasks give without plan or split).

Two more quantities, the machine's share of the bound (same cluster, same run):

* ``register_one`` / ``register_pair``: the whole serial registration (after the plan,
  the plan's arrays broadcast to both workers once) run as a task on one worker alone,
  then on both workers at once, each timed inside its task: the concurrency ``c`` =
  2 × one / pair of exactly this work on these two workers (2.0 on two free cores);
* ``dask_round_trip``: one trivial task on each worker, submitted and gathered.

From them the **overhead budget** of 1.6×: a partitioned run takes at least the plan
on 2 threads + the registration's work at the concurrency c + what it adds (split,
Dask's round trips, halo cells computed twice, imbalance, merge); 1.6× leaves for that
addition ``serial / 1.6 − plan_threaded − register / c`` — printed beside what the
run adds (``post_plan − register / c``) and Dask's bare round trip.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def plan_cells(P, cells, clo, chi, pad):
    """The plan's per-cell passes over ``cells``: boxes, the largest box edge, the
    near flags against the cutting boxes (``near_flags`` sides "a")."""
    from predicates.registration.spatial.boxes import box_extent, boxes_of
    from predicates.registration.spatial.broadphase import near_flags

    lo, hi = boxes_of(P, cells)
    L = float(box_extent(lo, hi).max())
    near, _ = near_flags(lo, hi, clo, chi, pad, sides="a")
    return L, near


def register_task(lean, chunk: int) -> float:
    """The serial registration of ``lean`` (a broadcast :func:`_lean` plan) as one task:
    its wall seconds, timed inside the task."""
    from predicates.registration.levels.loop import Registration

    t = time.perf_counter()
    Registration(lean.dim, lean.P_sim, lean.sim_cells, lean.P_cut, lean.cut_cells, lean.tol,
                 lean.scale.reach, chunk, accelerate=lean.accelerate).run(False, {})
    return time.perf_counter() - t


def _lean(plan):
    """What the registration (``levels.loop.Registration``) reads of a plan (dim, scaled
    points, run cells, tolerances, reach, the compiled chain's flag), nothing more."""
    from types import SimpleNamespace

    return SimpleNamespace(dim=plan.dim, P_sim=plan.P_sim, sim_cells=plan.sim_cells,
                           P_cut=plan.P_cut, cut_cells=plan.cut_cells, tol=plan.tol,
                           scale=SimpleNamespace(reach=plan.scale.reach),
                           accelerate=plan.accelerate)


def _stats(ts: list) -> dict:
    s = sorted(ts)
    return {"best": s[0], "median": s[len(s) // 2]}


def _steps(client, meshes, pl, inside: dict) -> dict:
    """The quantities timed in alternation (module docstring), as name -> callable."""
    import predicates
    from predicates.registration import pipeline
    from predicates.registration.partition import assign as partition
    from predicates.registration.partition.run import _gather, run_part, run_partitioned
    from predicates.registration.spatial.boxes import boxes_of

    sp, sc, cp, cc = meshes
    workers = list(client.scheduler_info()["workers"])
    reach = pl.scale.reach
    pad = max(reach.values())
    task_args = (pl.dim, pl.tol, reach, pipeline.CHUNK)
    parts = list(partition.split(pl.P_sim, pl.sim_cells, pl.P_cut, pl.cut_cells, 2, pad))
    P = np.ascontiguousarray(pl.sim.points)
    clo, chi = boxes_of(pl.cut.points, pl.cut.cells)
    halves = np.array_split(pl.sim.cells.astype(np.int32), 2)
    lean = client.scatter(_lean(pl), broadcast=True, hash=False)

    def on(ws, name):
        fs = [client.submit(register_task, lean, pipeline.CHUNK, pure=False,
                            workers=[w], allow_other_workers=False) for w in ws]
        inside.setdefault(name, []).append(max(client.gather(fs)))

    def presplit():
        out = _gather([client.submit(run_part, p, *task_args, pure=False) for p in parts])
        partition.merge(pl.kinds, [o[0] for o in out], pl.dtype)

    def pinned(f, *args_of_worker):
        return [client.submit(f, *a, pure=False, workers=[w], allow_other_workers=False)
                for a, w in zip(args_of_worker, workers)]

    return {
        "serial": lambda: predicates.intersect(sp, sc, cp, cc),
        "plan": lambda: _plan(meshes),
        "plan_threaded": lambda: _plan(meshes, 2),
        "register": lambda: pipeline._ranked(pl, pipeline.CHUNK, {})[0].run(False, {}),
        "partitioned": lambda: predicates.intersect(sp, sc, cp, cc, partitions=2,
                                                    scheduler=client),
        "post_plan": lambda: run_partitioned(pl, 2, client, pipeline.CHUNK, {}),
        "post_plan_presplit": presplit,
        "plan_cells_client": lambda: plan_cells(P, pl.sim.cells, clo, chi, pad),
        "plan_cells_hop": lambda: client.gather(pinned(
            plan_cells, *[(P, h, clo, chi, pad) for h in halves])),
        "register_one": lambda: on(workers[:1], "register_one"),
        "register_pair": lambda: on(workers, "register_pair"),
        "dask_round_trip": lambda: client.gather(pinned(int, *[(0,)] * len(workers))),
    }


def _plan(meshes, threads: int = 1):
    from predicates.registration import pipeline

    return pipeline._plan(meshes, np.dtype(np.float64), 1.0, False, pipeline.CHUNK, True,
                          {}, None, None, threads=threads)


def _bounds(best: dict, one_thread: float) -> dict:
    """Upper bounds on the partitioned run's speed-up (module docstring)."""
    return {
        "free split": best["serial"] / (best["plan"] + best["post_plan_presplit"]),
        "per-cell plan on the workers": best["serial"] / (
            best["plan"] - best["plan_cells_client"] + best["plan_cells_hop"]
            + best["post_plan_presplit"]),
        "the plan perfectly parallel on 2 workers, a free split": best["serial"] / (
            one_thread / 2 + best["post_plan_presplit"]),
        "free plan": best["serial"] / best["post_plan_presplit"],
        "the registration alone (register / post_plan_presplit)": (
            best["register"] / best["post_plan_presplit"]),
    }


def _report(st: dict, args, n_cells: int, n_tris: int) -> dict:
    """Print the table, the bounds and the 1.6× budget; returns the JSON record."""
    best = {k: v["best"] for k, v in st.items()}
    c = 2 * best["register_one"] / best["register_pair"]
    one_thread = best["plan"]
    best["plan"] = min(best["plan"], best["plan_threaded"])  # what a partitioned run uses
    bounds = _bounds(best, one_thread)
    print(f"W1: cube n = {args.n} ({n_cells:,} tetrahedra) x icosphere {n_tris:,} "
          f"triangles; 2 workers; {args.reps} reps, alternating")
    print("\n| step | best (ms) | median (ms) |\n|---|---:|---:|")
    for k, v in st.items():
        print(f"| {k} | {v['best'] * 1e3:.1f} | {v['median'] * 1e3:.1f} |")
    print(f"\nmeasured speed-up (best/best): {best['serial'] / best['partitioned']:.2f}x")
    for k, v in bounds.items():
        print(f"bound, {k}: {v:.2f}x")
    work = best["register"] / c
    budget = best["serial"] / 1.6 - best["plan"] - work
    added = best["post_plan"] - work
    print(f"\nconcurrency of the registration on the 2 workers: c = 2 x "
          f"{best['register_one'] * 1e3:.1f} / {best['register_pair'] * 1e3:.1f} ms = "
          f"{c:.2f}")
    print(f"1.6x = {best['serial'] / 1.6 * 1e3:.1f} ms = plan on 2 threads "
          f"{best['plan'] * 1e3:.1f} + registration at c {work * 1e3:.1f} + at most "
          f"{budget * 1e3:.1f} ms for split, Dask, halo, imbalance and merge; this run "
          f"adds {added * 1e3:.1f} ms (post_plan - register / c); Dask's bare round trip "
          f"{best['dask_round_trip'] * 1e3:.1f} ms")
    print(f"with the plan perfectly parallel ({one_thread / 2 * 1e3:.1f} ms) the budget "
          f"is {(best['serial'] / 1.6 - one_thread / 2 - work) * 1e3:.1f} ms")
    return {"steps": st, "bounds": bounds, "c": c, "budget_s": budget, "added_s": added}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--subdivisions", type=int, default=5)
    ap.add_argument("--reps", type=int, default=9)
    ap.add_argument("--json")
    args = ap.parse_args(argv)

    from predicates.registration.examples import cube_grid, icosphere
    from predicates.registration.partition.run import client_for

    meshes = (*cube_grid(args.n), *icosphere(args.subdivisions))
    pl = _plan(meshes)
    times: dict[str, list] = {}
    inside: dict[str, list] = {}
    with client_for(2) as client:
        time.sleep(2)  # the workers' imports (client_for warms them) are not timed
        steps = _steps(client, meshes, pl, inside)
        for f in steps.values():  # warm-up
            f()
        for _ in range(args.reps):
            for name, f in steps.items():
                t = time.perf_counter()
                f()
                times.setdefault(name, []).append(time.perf_counter() - t)
    for name in ("register_one", "register_pair"):  # the tasks' own times, not Dask's
        times[name] = inside[name][1:]  # (the first was the warm-up)
    record = _report({k: _stats(v) for k, v in times.items()}, args, len(meshes[1]),
                     len(meshes[3]))
    if args.json:
        Path(args.json).write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
