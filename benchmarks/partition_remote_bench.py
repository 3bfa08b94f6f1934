"""The plan where the cells are (docs/partitioned.md, section 6): W4 (n = 120: 10.4 M
tetrahedra × 327,680 triangles) serial, partitioned with the mesh on the client, and
partitioned with the simulation cells on the workers (a dask array whose chunks the
workers build themselves: the client never holds them).

    python benchmarks/partition_remote_bench.py [--n 120] [--subdivisions 7]
        [--workers 2] [--partitions 2] [--reps 2] [--rounds 1] [--json OUT]
        [--modes serial,dask,remote,files,pieces,serial_pieces] [--folder DIR]
        [--cluster spawned|local]

``--cluster spawned`` (the default): the scheduler and each single-threaded worker are
processes of their own (``dask scheduler``, ``dask worker --no-nanny``, started by the
child), so the client's CPU is the client's alone — a ``LocalCluster`` (``local``) runs
its scheduler on the client's event-loop thread, whose CPU the client's figure then
includes. The scheduler's and the workers' CPU are read from /proc per run. Every child
runs with ``FPERR_ACCELERATE=1`` (the compiled chain, serial and partitioned alike).
With ``--rounds R`` the modes alternate R times; the summary gives per round the
critical-path CPU speed-up of each partitioned mode against the serial run of the same
round, then the median and range over the rounds.

Mode ``files`` (``pieces_files``): as ``remote`` (``pieces``), with one file per
partition written by each partition's task (``PartFiles``); ``remote`` then writes the
same files on the client from the merged result (``write_parts``, "client_write": wall
and CPU seconds); both print the files' SHA-256, which must be equal.

Mode ``pieces``: the mesh written once (by a separate process) as ``--partitions``
slabs of .vtu pieces with global point ids, read by the workers in every run
(:mod:`predicates.registration.partition.pieces`; "read" is that part of the wall
time); its serial baseline is ``serial_pieces`` (the same cells in the pieces' order).

Each mode runs in its own child process; the modes alternate for ``--rounds``. Per mode:
best wall time of ``--reps`` runs (the first partitioned run on a fresh cluster pays the
workers' imports: reported apart), the plan ("setup"), the client's peak RSS (VmHWM of
its own process, the mesh included when it holds it), each worker's peak (VmHWM read in
its tasks), bytes sent to and returned from each partition, and the SHA-256 of every
pair and weight array (must equal the serial run's).
"""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def digest(res) -> str:
    h = hashlib.sha256()
    for k in res.kinds:
        p = res[k]
        for a in (p.sim, p.cut, p.sim_weights, p.cut_weights):
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def cube_cells(n: int, a: int, b: int) -> np.ndarray:
    """Rows [a, b) of ``examples.cube_grid(n)[1]``, built alone (on a worker)."""
    from predicates.registration.examples import _KUHN

    r = np.arange(a, b, dtype=np.int64)
    path, q = r // n ** 3, r % n ** 3
    k, j, i = q // (n * n), (q // n) % n, q % n
    m = n + 1
    out = np.empty((len(r), 4), dtype=np.int64)
    for p, steps in enumerate(_KUHN):
        sel = path == p
        for v, (di, dj, dk) in enumerate(steps):
            out[sel, v] = (i[sel] + di) + m * ((j[sel] + dj) + m * (k[sel] + dk))
    return out


def status(field: str) -> float:
    """/proc/self/status ``field`` in MiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def write_pieces(n: int, k: int, folder: str) -> list[str]:
    """W-n as k pieces with global point ids (docs/partitioned.md section 6): slabs of
    cube layers (the cells of cube_grid in their order within each slab), each piece
    the points its cells use, by global id; .vtu without compression."""
    import meshio

    from predicates.registration.examples import cube_grid
    from predicates.registration.partition.pieces import GLOBAL_IDS

    sp, sc = cube_grid(n)
    layer = (np.arange(len(sc)) % n ** 3) // (n * n)
    paths = []
    cuts = np.linspace(0, n, k + 1).astype(int)
    for r in range(k):
        cells = sc[(layer >= cuts[r]) & (layer < cuts[r + 1])]
        ids, local = np.unique(cells, return_inverse=True)
        path = f"{folder}/piece{r}.vtu"
        meshio.Mesh(sp[ids], [("tetra", local.reshape(-1, 4))],
                    point_data={GLOBAL_IDS: ids}).write(path, compression=None)
        paths.append(path)
    return paths


def pieces_order(n: int, k: int) -> np.ndarray:
    """The cells of cube_grid(n) in the order the pieces of :func:`write_pieces` hold
    them (the serial baseline of the pieces mode runs on this order)."""
    layer = (np.arange(6 * n ** 3) % n ** 3) // (n * n)
    cuts = np.linspace(0, n, k + 1).astype(int)
    return np.concatenate([np.flatnonzero((layer >= cuts[r]) & (layer < cuts[r + 1]))
                           for r in range(k)])


def proc_cpu(pid: int) -> float:
    """CPU seconds (user + system) of process ``pid`` so far (/proc/PID/stat)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@contextlib.contextmanager
def spawned_cluster(workers: int):
    """(Client, scheduler pid, worker pids): a ``dask scheduler`` and ``workers``
    ``dask worker --nthreads 1 --no-nanny`` processes, each its own process with the
    environment of ``client_for``'s workers (WORKER_ENV, no profiler); the workers
    import the registration first. Stopped (by their own pids) on exit."""
    import tempfile

    from distributed import Client

    from predicates.registration.partition.run import WORKER_ENV, _warm

    dask_exe = str(Path(sys.executable).parent / "dask")
    env = dict(os.environ, **WORKER_ENV, DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED="False")
    folder = tempfile.mkdtemp(prefix="fperr-cluster-")
    sfile = f"{folder}/scheduler.json"
    quiet = dict(env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([dask_exe, "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", sfile], **quiet)]
    try:
        for _ in range(600):
            if Path(sfile).exists() and Path(sfile).stat().st_size:
                break
            time.sleep(0.05)
        procs += [subprocess.Popen([dask_exe, "worker", "--scheduler-file", sfile,
                                    "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                    "--memory-limit", "0"], **quiet)
                  for _ in range(workers)]
        with Client(scheduler_file=sfile) as client:
            client.wait_for_workers(workers, timeout=120)
            client.run(_warm)
            yield client, procs[0].pid, [p.pid for p in procs[1:]]
    finally:
        for p in reversed(procs):  # the workers first, then the scheduler
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:  # a worker still closing its comms
                p.kill()
                p.wait()
        shutil.rmtree(folder, ignore_errors=True)


def child(mode: str, n: int, sub: int, workers: int, k: int, reps: int,
          folder: str | None = None, cluster: str = "spawned") -> dict:
    import predicates
    from predicates.registration.examples import cube_grid, grid_coordinates, icosphere

    cp, cc = icosphere(sub)
    m = 6 * n ** 3
    out = {"mode": mode, "runs": [], "setup": [], "cpu": []}
    if mode.startswith("pieces"):  # nothing: the workers read the pieces
        sp = sc = None
    elif mode in ("remote", "files"):  # the points only: the cells are built on the workers
        x = grid_coordinates(n)
        Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
        sp = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
        del X, Y, Z
        sc = None
    else:
        sp, sc = cube_grid(n)
        if mode == "serial_pieces":  # the serial baseline in the pieces' cell order
            sc = sc[pieces_order(n, k)]
    out["mesh_mib"] = (3 * 8 * (n + 1) ** 3 + m * 32) / 2**20
    if mode.startswith("serial"):
        for _ in range(reps):
            t, c = time.perf_counter(), time.process_time()
            res = predicates.intersect(sp, sc, cp, cc, memory_limit=16 << 30)
            out["runs"].append(time.perf_counter() - t)
            out["cpu"].append(time.process_time() - c)
            out["setup"].append(res.timings["setup"])
    else:
        res = partitioned(mode, out, sp, sc, cp, cc, n, workers, k, reps, folder, cluster)
    out["timings"] = {key: round(v, 3) for key, v in res.timings.items()
                      if isinstance(v, float)}  # the last run's stages (wall, CPU)
    out["client_peak_mib"] = status("VmHWM")
    out["digest"] = digest(res)
    return out


def partitioned(mode: str, out: dict, sp, sc, cp, cc, n: int, workers: int, k: int,
                reps: int, folder: str | None, cluster: str = "spawned"):
    """The partitioned runs of ``mode`` on a fresh local cluster (records in ``out``).
    Mode ``files``: the cells on the workers and one file per partition written by
    each task (``PartFiles``); mode ``remote`` then times the client writing the same
    files from the merged result (``write_parts``), as before 2026-11-27. Both record
    the files' SHA-256 (must be equal)."""
    import tempfile

    import predicates
    from predicates.registration.partition.files import write_parts
    from predicates.registration.partition.outputs import PartFiles
    from predicates.registration.partition.run import client_for

    m = 6 * n ** 3
    tmp = tempfile.mkdtemp(prefix="fperr-parts-")
    if cluster == "spawned":
        started = spawned_cluster(workers)
    else:  # the scheduler on the client's event-loop thread: no pids of its own
        started = contextlib.nullcontext()
    with started as spawned, (client_for(workers) if spawned is None
                              else contextlib.nullcontext(spawned[0])) as client:
        pids = [] if spawned is None else [spawned[1], *spawned[2]]
        out["scheduler_cpu"], out["workers_cpu"], out["thread_cpu"] = [], [], []
        if mode in ("remote", "files"):
            import dask
            import dask.array as da

            cuts = np.linspace(0, m, k + 1).astype(int)
            sc = client.persist(da.concatenate([
                da.from_delayed(dask.delayed(cube_cells)(n, a, b), shape=(b - a, 4),
                                dtype=np.int64) for a, b in zip(cuts[:-1], cuts[1:])]))
        out["read"] = []
        for _ in range(reps):
            before = [proc_cpu(pid) for pid in pids]
            t, c = time.perf_counter(), time.process_time()
            main = time.thread_time()
            if mode.startswith("pieces"):  # read by the workers, the client: the points
                from predicates.registration.partition.pieces import read_pieces_on_workers

                got = read_pieces_on_workers(sorted(Path(folder).glob("*.vtu")), client)
                sp, sc = got.points, got.cells
                out["read"].append(time.perf_counter() - t)
            parts = PartFiles(f"{tmp}/hits_{{part}}.vtu", k) if mode.endswith("files") else k
            res = predicates.intersect(sp, sc, cp, cc, partitions=parts, scheduler=client,
                                       memory_limit=16 << 30)
            out["runs"].append(time.perf_counter() - t)
            out["cpu"].append(time.process_time() - c)
            out["thread_cpu"].append(time.thread_time() - main)  # the main thread's
            out["setup"].append(res.timings["setup"])
            if pids:  # the scheduler's own CPU, the workers' (all their threads)
                spent = [proc_cpu(pid) - b for pid, b in zip(pids, before)]
                out["scheduler_cpu"].append(spent[0])
                out["workers_cpu"].append(spent[1:])
        if mode == "remote":  # the files written by the client, from the merged result
            t, c = time.perf_counter(), time.process_time()
            write_parts(res, k, f"{tmp}/hits_{{part}}.vtu")
            out["client_write"] = [time.perf_counter() - t, time.process_time() - c]
        record_partitions(out, res)
    out["files_sha256"] = files_digest(tmp, k) if mode.endswith("files") or mode == "remote" \
        else None
    shutil.rmtree(tmp)  # 40 MB per W4 file
    return res


def record_partitions(out: dict, res) -> None:
    """Per partition: cells, bytes, peaks, times; the critical path's CPU seconds."""
    out["parts"] = [{key: p.get(key) for key in (
        "sim_cells", "cut_cells", "bytes_in", "bytes_out", "peak_rss_mib", "pid",
        "seconds", "cpu_s", "cpu_slice_s", "cpu_owned_s", "file_bytes", "cpu_file_s")} for p in res.timings["partitions"]]
    # CPU seconds on the critical path (load-independent; docs/partitioned.md 5b): the
    # client's, the plan's per-chunk passes (largest chunk each), the busiest task
    # client, the plan's per-chunk passes (largest chunk each), the busiest task — with
    # the split on the workers (split_remote), the chunks' and ranges' steps on that
    # task's longest path ("cpu_split_path") before it
    remote = res.timings.get("plan_remote") or {}
    out["critical_cpu"] = {
        "client": out["cpu"][-1],
        "plan_on_workers": sum(c for _, c in remote.get("worker_cpu", [])),
        "busiest_task": max(p["cpu_s"] + p.get("cpu_split_path", 0.0)
                            for p in res.timings["partitions"]),
        "split_path": max(p.get("cpu_split_path", 0.0) for p in res.timings["partitions"])}
    out["plan_remote"] = remote or None
    out["split"] = res.timings.get("split")  # where, rounds, the client's bytes in the graph


def summarise(got: dict) -> None:
    """Per round, each partitioned mode's critical-path CPU against the serial run of the
    same round (``serial_pieces`` for the pieces modes); median and range over rounds."""
    for mode, recs in got.items():
        base = got.get("serial_pieces" if mode.startswith("pieces") else "serial")
        if mode.startswith("serial") or not base:
            continue
        ratios, crit = [], []
        for rec, ref in zip(recs, base):
            c = rec["critical_cpu"]
            crit.append(c["client"] + c["plan_on_workers"] + c["busiest_task"])
            ratios.append(ref["cpu"][-1] / crit[-1])
        print(f"{mode}: critical CPU {np.median(crit):.2f} s (range {min(crit):.2f}–"
              f"{max(crit):.2f}), serial {np.median([r['cpu'][-1] for r in base]):.2f} s; "
              f"speed-up median {np.median(ratios):.2f}× (range {min(ratios):.2f}–"
              f"{max(ratios):.2f}×, {len(ratios)} rounds: "
              f"{', '.join(f'{x:.2f}' for x in ratios)})", flush=True)


def files_digest(folder: str, k: int) -> str:
    """SHA-256 of the k per-partition files' bytes, in order."""
    h = hashlib.sha256()
    for r in range(k):
        h.update(Path(f"{folder}/hits_{r}.vtu").read_bytes())
    return h.hexdigest()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=120)
    ap.add_argument("--subdivisions", type=int, default=7)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--partitions", type=int, default=2)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--modes", default="serial,dask,remote")
    ap.add_argument("--json")
    ap.add_argument("--child")
    ap.add_argument("--accelerate", choices=("0", "1"), default="1",
                    help="FPERR_ACCELERATE of every child: 1 the compiled chain, 0 numpy")
    ap.add_argument("--folder", help="the pieces' folder (mode pieces: written once)")
    ap.add_argument("--cluster", choices=("spawned", "local"), default="spawned",
                    help="spawned: scheduler and workers in processes of their own; "
                         "local: a LocalCluster (its scheduler in the client's process)")
    a = ap.parse_args(argv)
    if a.child == "write":
        write_pieces(a.n, a.partitions, a.folder)
        return
    if a.child:
        print(json.dumps(child(a.child, a.n, a.subdivisions, a.workers, a.partitions,
                               a.reps, a.folder, a.cluster)))
        return
    if {"pieces", "pieces_files"} & set(a.modes.split(",")):
        import tempfile

        a.folder = a.folder or tempfile.mkdtemp(prefix="fperr-pieces-")
        if not list(Path(a.folder).glob("*.vtu")):  # in its own process: the client of
            # the pieces mode never holds the mesh
            subprocess.run([sys.executable, __file__, "--child", "write", "--n", str(a.n),
                            "--partitions", str(a.partitions), "--folder", a.folder],
                           check=True)
    if a.n > 24:  # numba's on-disk cache first (a fresh tree compiles every kernel:
        # seconds that would land on whichever run came first), on a small mesh
        for mode in dict.fromkeys(m for m in a.modes.split(",")
                                  if m in ("serial", "remote", "dask")):
            subprocess.run([sys.executable, __file__, "--child", mode, "--n", "24",
                            "--subdivisions", "4", "--workers", str(a.workers),
                            "--partitions", str(a.partitions), "--reps", "1",
                            "--cluster", a.cluster], capture_output=True, check=True,
                           env=dict(os.environ, FPERR_ACCELERATE="1"))
    got = {}
    for _ in range(a.rounds):
        for mode in a.modes.split(","):
            cmd = [sys.executable, __file__, "--child", mode, "--n", str(a.n),
                   "--subdivisions", str(a.subdivisions), "--workers", str(a.workers),
                   "--partitions", str(a.partitions), "--reps", str(a.reps),
                   "--cluster", a.cluster] + (["--folder", a.folder] if a.folder else [])
            with open("/proc/loadavg") as f:
                load = float(f.read().split()[0])
            r = subprocess.run(cmd, capture_output=True, text=True,
                               env=dict(os.environ, FPERR_ACCELERATE=a.accelerate))
            if r.returncode:
                raise SystemExit(f"{mode} failed:\n{r.stderr[-3000:]}")
            rec = json.loads(r.stdout.strip().splitlines()[-1])
            with open("/proc/loadavg") as f:  # the machine is shared: before and after
                rec["load"] = [load, float(f.read().split()[0])]
            got.setdefault(mode, []).append(rec)
            print(json.dumps({key: rec[key] for key in rec if key != "parts"}), flush=True)
            for p in rec.get("parts", []):
                print("   ", p, flush=True)
    # the pieces hold the cells in another order: their baseline is serial_pieces
    digests = {r["digest"] for recs in got.values() for r in recs}
    print("identical results:", len(digests) == 1, "(digests:", len(digests), ")")
    summarise(got)
    if a.json:
        Path(a.json).write_text(json.dumps(got, indent=1))


if __name__ == "__main__":
    main()
