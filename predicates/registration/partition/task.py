"""One partition's Dask task (docs/partitioned.md 4–5a): the serial levels on its slice,
the pairs it owns in global ids, its statistics and — in a run that writes one file per
partition (:mod:`.outputs`) — its file, written where the task runs."""
from __future__ import annotations

import os
import resource
import socket
import time

from predicates import compiled
from predicates.registration.levels.loop import Registration
from predicates.registration.partition.assign import CutSide, Part, cut_slice, owned
from predicates.registration.partition.memory import peak_rss_mib, rss_mib
from predicates.registration.spatial.blocks import Blocks

__all__ = ["run_part"]


def run_part(part: Part, dim: int, tol, reach: dict, chunk: int,
             accelerate: bool = False, file_spec=None,
             file_path: str | None = None,
             cut_side: CutSide | None = None) -> tuple[dict, dict]:
    """One Dask task: the serial levels on the partition's slice; returns its owned
    pairs (global ids) and statistics (time, the peak RSS of the worker process's own
    address space, ``VmHWM`` read when the task ends (:mod:`.memory`), its RSS when the
    task began, its host and pid, bytes; for
    the timeline and the worker's overheads: wall-clock start and end ``t_begin``,
    ``t_end``, the process's CPU ``proc_cpu`` and the thread's voluntary and involuntary
    context switches, minor and major page faults ``ctx``). ``file_spec`` and
    ``file_path``: write the partition's file there (a staged name the client renames
    once every partition succeeded: :class:`~.outputs.Staged`); "file_bytes" and
    "cpu_file_s" in the statistics. ``cut_side``: the run's cutting mesh (sent once per
    worker), from which a part sent without its cutting slice (``part.cut_pending``)
    takes it here (:func:`~.assign.cut_slice`: the client's slice, bit for bit); an empty
    slice registers nothing."""
    t, cpu, t0 = time.perf_counter(), time.thread_time(), time.time()
    r0, p0 = resource.getrusage(resource.RUSAGE_THREAD), time.process_time()
    rss0 = rss_mib()
    bytes_in = part.nbytes  # as sent (the slice cut here is not)
    fast = accelerate and compiled.available()
    if part.cut_pending:  # compiled when the registration is (the same slice)
        part = cut_slice(part, cut_side, Blocks(accelerate=fast))
    cpu_slice = time.thread_time() - cpu
    if len(part.cut_cells):
        reg = Registration(dim, part.P_sim, part.sim_cells, part.P_cut, part.cut_cells,
                           tol, reach, chunk, accelerate=fast)
        local = reg.run(False, {})
    else:  # no cutting cell within reach of the halo: it owns no pair
        local = {}
    c = time.thread_time()
    pairs = owned(part, local)
    cpu_owned = time.thread_time() - c
    sent_back = sum(a.nbytes for p in pairs.values()
                    for a in (p.sim, p.cut, p.sim_weights, p.cut_weights))
    stats = {"part": part.index, "owned_cells": part.owned_cells,
             "sim_cells": len(part.sim_cells), "cut_cells": len(part.cut_cells),
             "bytes_in": bytes_in, "bytes_out": sent_back,
             "cpu_slice_s": cpu_slice, "cpu_owned_s": cpu_owned}
    if file_path is not None:
        from predicates.registration.partition.outputs import write_part

        c = time.thread_time()
        stats["file_bytes"] = write_part(file_path, file_spec, part, local)
        stats["cpu_file_s"] = time.thread_time() - c
    stats.update({"seconds": time.perf_counter() - t, "cpu_s": time.thread_time() - cpu,
                  "pid": os.getpid(), "host": socket.gethostname(), "t_begin": t0,
                  "t_end": time.time(), "proc_cpu": time.process_time() - p0,
                  "ctx": _thread_counts(r0), "rss_begin_mib": rss0})
    # the worker's own high-water mark, read now (not ru_maxrss: the client's survives
    # fork + exec); under "threads"/"synchronous" the process is the client's
    stats["peak_rss_mib"], stats["peak_rss_source"] = peak_rss_mib()
    return pairs, stats


def _thread_counts(before) -> list[int]:
    """This thread's context switches (voluntary, involuntary) and page faults (minor,
    major) since the ``getrusage`` record ``before``."""
    now = resource.getrusage(resource.RUSAGE_THREAD)
    return [getattr(now, a) - getattr(before, a)
            for a in ("ru_nvcsw", "ru_nivcsw", "ru_minflt", "ru_majflt")]
