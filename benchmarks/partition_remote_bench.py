"""The plan where the cells are (docs/partitioned.md, section 6): W4 (n = 120: 10.4 M
tetrahedra × 327,680 triangles) serial, partitioned with the mesh on the client, and
partitioned with the simulation cells on the workers (a dask array whose chunks the
workers build themselves: the client never holds them).

    python benchmarks/partition_remote_bench.py [--n 120] [--subdivisions 7]
        [--workers 2] [--partitions 2] [--reps 2] [--rounds 1] [--json OUT]
        [--modes serial,dask,remote,files,pieces,serial_pieces] [--folder DIR]

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
import hashlib
import json
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


def child(mode: str, n: int, sub: int, workers: int, k: int, reps: int,
          folder: str | None = None) -> dict:
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
        res = partitioned(mode, out, sp, sc, cp, cc, n, workers, k, reps, folder)
    out["timings"] = {key: round(v, 3) for key, v in res.timings.items()
                      if isinstance(v, float)}  # the last run's stages (wall, CPU)
    out["client_peak_mib"] = status("VmHWM")
    out["digest"] = digest(res)
    return out


def partitioned(mode: str, out: dict, sp, sc, cp, cc, n: int, workers: int, k: int,
                reps: int, folder: str | None):
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
    with client_for(workers) as client:
        if mode in ("remote", "files"):
            import dask
            import dask.array as da

            cuts = np.linspace(0, m, k + 1).astype(int)
            sc = client.persist(da.concatenate([
                da.from_delayed(dask.delayed(cube_cells)(n, a, b), shape=(b - a, 4),
                                dtype=np.int64) for a, b in zip(cuts[:-1], cuts[1:])]))
        out["read"] = []
        for _ in range(reps):
            t, c = time.perf_counter(), time.process_time()
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
            out["setup"].append(res.timings["setup"])
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
        "seconds", "cpu_s", "file_bytes", "cpu_file_s")} for p in res.timings["partitions"]]
    # CPU seconds on the critical path (load-independent; docs/partitioned.md 5b): the
    # client's, the plan's per-chunk passes (largest chunk each), the busiest task
    remote = res.timings.get("plan_remote") or {}
    out["critical_cpu"] = {
        "client": out["cpu"][-1],
        "plan_on_workers": sum(c for _, c in remote.get("worker_cpu", [])),
        "busiest_task": max(p["cpu_s"] for p in res.timings["partitions"])}
    out["plan_remote"] = remote or None


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
    ap.add_argument("--folder", help="the pieces' folder (mode pieces: written once)")
    a = ap.parse_args(argv)
    if a.child == "write":
        write_pieces(a.n, a.partitions, a.folder)
        return
    if a.child:
        print(json.dumps(child(a.child, a.n, a.subdivisions, a.workers, a.partitions,
                               a.reps, a.folder)))
        return
    if {"pieces", "pieces_files"} & set(a.modes.split(",")):
        import tempfile

        a.folder = a.folder or tempfile.mkdtemp(prefix="fperr-pieces-")
        if not list(Path(a.folder).glob("*.vtu")):  # in its own process: the client of
            # the pieces mode never holds the mesh
            subprocess.run([sys.executable, __file__, "--child", "write", "--n", str(a.n),
                            "--partitions", str(a.partitions), "--folder", a.folder],
                           check=True)
    got = {}
    for _ in range(a.rounds):
        for mode in a.modes.split(","):
            cmd = [sys.executable, __file__, "--child", mode, "--n", str(a.n),
                   "--subdivisions", str(a.subdivisions), "--workers", str(a.workers),
                   "--partitions", str(a.partitions), "--reps", str(a.reps)] + (
                       ["--folder", a.folder] if a.folder else [])
            with open("/proc/loadavg") as f:
                load = float(f.read().split()[0])
            r = subprocess.run(cmd, capture_output=True, text=True)
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
    if a.json:
        Path(a.json).write_text(json.dumps(got, indent=1))


if __name__ == "__main__":
    main()
