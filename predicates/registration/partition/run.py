"""Partitioned registration on Dask (section 1 of the paper, scaled out): the plan
(tolerances, reach, scaling) is global, each partition of
:mod:`predicates.registration.partition.assign` runs the serial levels on its slice as one Dask
task, and the owned pairs merge into a result identical to the serial one
(docs/partitioned.md).

Schedulers: Dask's local ``"threads"``, ``"processes"``, ``"synchronous"``, a
``dask.distributed.Client`` or a scheduler address (``"tcp://host:8786"``). Dask is
imported only here, only when a partitioned run is asked for.
"""
from __future__ import annotations

import contextlib
import logging
import os
import sys
import time

import numpy as np

from predicates.registration.partition.assign import CutSide, Part, merge, split
from predicates.registration.partition.counts import (  # noqa: F401 (re-exported)
    CELLS_PER_PART, slots, count_partitions)
from predicates.registration.partition.outputs import PartFiles, Staged
from predicates.registration.partition.run_arrays import materialised
from predicates.registration.partition.split_remote import (on_workers, settled_side,
                                                            split_on_workers)
from predicates.registration.partition.task import run_part

__all__ = ["DaskMissingError", "LOCAL_SCHEDULERS", "PartitionError", "check_timeout",
           "client_for", "connected", "run_part", "run_partitioned"]

LOCAL_SCHEDULERS = ("threads", "processes", "synchronous")
#: seconds before the partitions' progress bar shows (as the serial run's bar)
PROGRESS_DELAY = 1.0


class DaskMissingError(ImportError):
    """Dask is needed for a partitioned run but is not installed."""


class PartitionError(RuntimeError):
    """A partitioned run's tasks did not all finish: a Dask worker died running one
    (``distributed.KilledWorker``: typically its memory limit) or the run's ``timeout``
    passed. The unfinished tasks are cancelled and nothing is returned."""


def check_timeout(timeout, partitioned: bool, scheduler=None):
    """``timeout`` of :func:`~predicates.registration.intersect`: None, or seconds > 0
    for a partitioned run on a dask.distributed scheduler; refused (before any work)
    otherwise."""
    if timeout is None:
        return None
    if isinstance(timeout, (bool, np.bool_)) or \
            not isinstance(timeout, (int, float, np.integer, np.floating)):
        raise TypeError(f"timeout must be a number of seconds, got {timeout!r}")
    if not timeout > 0:
        raise ValueError(f"timeout must be more than 0 seconds, got {timeout!r}")
    if not partitioned or scheduler is None or scheduler in LOCAL_SCHEDULERS:
        raise ValueError("timeout limits a partitioned run's tasks on a dask.distributed "
                         "scheduler (a Client or an address; fperr intersect --workers/"
                         "--scheduler); the local schedulers run their tasks to the end")
    return float(timeout)


def _dask():
    try:
        import dask
    except ImportError:
        raise DaskMissingError(
            "partitioned registration (partitions=/scheduler=, fperr intersect --workers/"
            "--scheduler) runs on Dask, which is not installed: pip install 'fperr[dask]' "
            "(or leave partitions/scheduler unset for the serial run)") from None
    return dask


def _client(scheduler):
    """The distributed Client meant by ``scheduler``, or None for a local scheduler."""
    if isinstance(scheduler, str):
        if scheduler in LOCAL_SCHEDULERS:
            return None
        if "://" in scheduler:
            try:
                from distributed import Client
            except ImportError:
                raise DaskMissingError("a scheduler address needs dask.distributed: pip "
                                       "install 'fperr[dask]'") from None
            _reachable(scheduler)
            return Client(scheduler)
        raise ValueError(f"scheduler must be one of {', '.join(LOCAL_SCHEDULERS)}, a "
                         f"dask.distributed.Client or an address like tcp://host:8786; got "
                         f"{scheduler!r}")
    if "Client" in type(scheduler).__name__ and hasattr(scheduler, "scatter"):
        return scheduler
    raise TypeError(f"scheduler must be a string or a dask.distributed.Client, got "
                    f"{type(scheduler).__name__}")


#: The local workers' malloc: temporaries come from the heap and stay mapped (no fresh,
#: zero-filled pages per numpy temporary; distributed's default MALLOC_TRIM_THRESHOLD_
#: = 65536 made every large temporary a new mmap: 11 s instead of 7 s per W1 partition at
#: n = 96). Arrays above 256 MiB are still mmapped and returned at once, and at most
#: 1 GiB of free heap is kept, so a worker's RSS stays near its peak, not above it.
WORKER_ENV = {"MALLOC_TRIM_THRESHOLD_": str(1 << 30), "MALLOC_MMAP_THRESHOLD_": str(1 << 28)}


@contextlib.contextmanager
def client_for(workers: int | None = None, address: str | None = None):
    """A ``dask.distributed.Client``: connected to the scheduler at ``address``, or to a
    new local cluster of ``workers`` single-threaded worker processes (closed on exit).
    The local workers run with :data:`WORKER_ENV` and without distributed's statistical
    profiler (a thread taking the GIL every 10 ms in the middle of the task), and each
    starts importing the registration at once (:func:`_warm`): the imports overlap the
    client's reading and planning instead of delaying the first task (when the first
    run follows at once they cost the same either way)."""
    _dask()
    try:
        import dask
        from distributed import Client, LocalCluster, wait
    except ImportError:
        raise DaskMissingError("--workers/--scheduler need dask.distributed: pip install "
                               "'fperr[dask]'") from None
    if address is not None:
        _reachable(address)
        with Client(address) as client:
            yield client
        return
    if workers is None or workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    with dask.config.set({"distributed.worker.profile.enabled": False}):
        # the nannies give the workers os.environ over their pre-spawn-environ config
        # (and write that config into os.environ for good: a default LocalCluster
        # started earlier in this process would impose MALLOC_TRIM_THRESHOLD_=65536);
        # so WORKER_ENV goes through os.environ, restored once the workers are spawned
        with _environ(WORKER_ENV):
            # no dashboard: the scheduler's HTTP server still starts, by default on
            # port 8787, and warns on stderr when that port is taken (another cluster,
            # another fperr run); a free port on loopback only never collides
            # worker warnings (a task cancelled under a timeout logs one with a
            # traceback) are not the user's: fperr reports the failure itself
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                   processes=True, dashboard_address=None,
                                   silence_logs=logging.ERROR,
                                   scheduler_kwargs={"dashboard": False,
                                                     "dashboard_address": "127.0.0.1:0"})
    with cluster, Client(cluster) as client:
        # not waited for: the workers import while the client reads and plans (kept
        # referenced, or the scheduler would drop them unrun)
        warm = [client.submit(_warm, pure=False, workers=[w], allow_other_workers=False)
                for w in client.scheduler_info()["workers"]]
        try:
            yield client
        finally:
            # closing the cluster under a running import logs a cancelled-task warning
            # (on an error too: a run refused or failed within a second of the start)
            with contextlib.suppress(TimeoutError):
                wait(warm, timeout=30)


def _reachable(address: str, seconds: float = 5.0) -> None:
    """Fail at once, with what to do, when a tcp:// scheduler address cannot be reached:
    its host does not resolve or nothing listens at its port (distributed would retry
    for its whole connect timeout, 30 s, before saying so). A host that does not answer
    within ``seconds`` is left to distributed's own timeout (it may be slow, not gone)."""
    import socket

    if not address.startswith("tcp://"):
        return
    host, _, port = address[len("tcp://"):].rpartition(":")
    host = host.strip("[]")  # an IPv6 literal
    try:
        port_number = int(port)
    except ValueError:
        raise ValueError(f"{address}: a scheduler address needs a port, like "
                         f"tcp://host:8786") from None
    try:
        socket.create_connection((host, port_number), timeout=seconds).close()
    except socket.gaierror as e:
        raise OSError(f"{address}: cannot resolve the host {host!r} ({e.strerror}): check "
                      f"the scheduler's address") from None
    except ConnectionRefusedError:
        raise OSError(f"{address}: connection refused: no Dask scheduler listens there "
                      f"(start one with 'dask scheduler', or check the address)") from None
    except OSError:
        return  # unreachable or slow: distributed's connect timeout decides


@contextlib.contextmanager
def _environ(values: dict):
    """``os.environ`` updated with ``values`` inside the block, as it was after."""
    old = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in old.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _warm() -> bool:
    """A worker's first task: import the registration (~0.4 s CPU), which the first
    partition's task would otherwise pay when it is unpickled."""
    # the imports are the point
    from predicates.registration.levels import loop  # noqa: F401
    from predicates.registration.partition import assign  # noqa: F401

    return True


@contextlib.contextmanager
def connected(scheduler):
    """``scheduler`` for a whole partitioned run: an address string (``"tcp://..."``) is
    connected once — the plan's per-chunk tasks (:mod:`.remote`) and the partitions then
    run on the same Client, closed after — and refused at once when it is not one; a
    local scheduler's name, a Client or None is yielded as given (docs/partitioned.md 6)."""
    if not isinstance(scheduler, str) or scheduler in LOCAL_SCHEDULERS:
        yield scheduler
        return
    _dask()
    client = _client(scheduler)
    try:
        yield client
    finally:
        client.close()


def run_partitioned(plan, partitions, scheduler, chunk: int, timings: dict,
                    check=None, progress: bool = False, timeout: float | None = None) -> dict:
    """Steps 3, 5, 6 in partitions on Dask: {kind: KindPairs}, identical to the serial
    run. ``check(share=, stacklevel=)``: the resolution report's checks, called before
    any work with the fraction of the cell pairs held at once. ``timings`` gets
    "partition" (client-side split; on a distributed Client the split, scatter and
    submission, task by task, overlapping the first tasks), "dask" (waiting for the
    tasks) and "merge" (wall seconds), "cpu_partition", "cpu_dask", "cpu_merge" (the
    client process's CPU seconds: "cpu_dask" is Dask's serialisation and event loop
    while the tasks run) and ``timings["partitions"]``: the per-partition statistics.
    ``progress``: a tqdm bar on stderr counting finished partitions (shown after
    :data:`PROGRESS_DELAY` s). ``timeout``: seconds to wait for the tasks once
    submitted (a dask.distributed scheduler only), else :class:`PartitionError`."""
    dask = _dask()
    client = _client("threads" if scheduler is None else scheduler)
    try:
        return _run(dask, client, plan, partitions, scheduler, chunk, timings, check,
                    progress, timeout)
    finally:
        if client is not None and isinstance(scheduler, str):
            client.close()  # we connected to the address: we disconnect (errors too)


def _run(dask, client, plan, partitions, scheduler, chunk, timings, check, progress,
         timeout) -> dict:
    files = partitions if isinstance(partitions, PartFiles) else None
    k = count_partitions(files.partitions if files else partitions, client,
                         len(plan.sim_cells))
    timings["partition_count"] = k  # (per-partition output: one file per partition)
    if check is not None:  # before any work
        check(share=min(k, slots(client, scheduler)) / k, stacklevel=5)
    plan = materialised(plan) if files else plan  # the client's split: its run arrays
    # the files' paths checked and their owners computed, before any task
    staged = files and Staged(files, k, plan, client or scheduler or "threads")
    with _bar(progress, k) as bar:
        if staged is None:
            return _tasks(dask, client, plan, k, scheduler, chunk, timings, bar, timeout)
        try:
            pairs = _tasks(dask, client, plan, k, scheduler, chunk, timings, bar, timeout,
                           staged)
            staged.commit(p["part"] for p in timings["partitions"])
        except BaseException:
            staged.discard()  # nothing written unless every partition succeeded
            raise
        timings["files"] = staged.paths
        return pairs


def _tasks(dask, client, plan, k, scheduler, chunk, timings, bar, timeout=None,
           staged=None) -> dict:
    """Split, the tasks, the merge (:func:`run_partitioned`); ``staged``: each task
    writes its partition's file (:mod:`.outputs`)."""
    clock = _Clock(timings)
    reach = plan.scale.reach
    pad = max(reach.values())
    if staged is None and on_workers(plan) and len(plan.cut_cells) and len(plan.sim_cells):
        return _split_there(dask, client, plan, k, scheduler, chunk, timings, bar,
                            timeout, clock)
    plan = materialised(plan)  # deferred when the cells are on the workers (run_arrays.py)
    owner, write = (None, None) if staged is None else (staged.owner, staged.write)
    # on a Client the tasks cut their own cutting slices (the mesh sent once per worker)
    parts = () if len(plan.cut_cells) == 0 or len(plan.sim_cells) == 0 else (
        p for p in split(plan.P_sim, plan.sim_cells, plan.P_cut, plan.cut_cells, k, pad,
                         owner, write, cut_in_task=client is not None,
                         vertex_ids=plan.sim_vertex_ids)
        if p.cut_pending or len(p.cut_cells))  # none within reach: nothing to own
    args = (plan.dim, plan.tol, reach, chunk, plan.accelerate)
    spec = None if staged is None else staged.spec
    path = (lambda r: None) if staged is None else (lambda r: staged.staged[r])
    if client is not None:
        # sent once to each worker, not with every task
        spec = None if spec is None else client.scatter(spec, hash=False)
        side = CutSide(plan.P_cut, plan.cut_cells, pad)
        timings["cut_side_bytes"] = side.nbytes  # to each worker, once
        side = client.scatter(side, hash=False, broadcast=True)
        # each partition's task starts as soon as its slice is cut and sent: the split
        # of the next ones overlaps the workers' tasks ("partition": split and send)
        futures, index = [], []
        for p in parts:
            futures.append(client.submit(run_part, _payload(client, p), *args, spec,
                                         path(p.index), side, pure=False))
            index.append(p.index)
        bar.total = len(futures)  # partitions without a cutting cell in reach run none
        clock("partition")
        out = _gather(futures, bar, timeout, index)
    else:
        parts = list(parts)
        bar.total = len(parts)
        clock("partition")
        tasks = [dask.delayed(run_part, pure=False)(p, *args, spec, path(p.index))
                 for p in parts]
        # no cells can meet: nothing to register
        with _finished(bar, {t.key for t in tasks}):
            out = dask.compute(*tasks, scheduler=scheduler or "threads") if tasks else []
        del parts, tasks
    return _merged(plan, out, timings, clock)


def _split_there(dask, client, plan, k, scheduler, chunk, timings, bar, timeout,
                 clock) -> dict:
    """:func:`_tasks` with the split on the workers (:mod:`.split_remote`): the run
    cells stay where they are, each partition's task assembles its Part there."""
    args = (plan.dim, plan.tol, plan.scale.reach, chunk, plan.accelerate)
    try:
        tasks = split_on_workers(plan, k, max(plan.scale.reach.values()), args, client,
                                 scheduler or "threads", timings, timeout)
    except TimeoutError as e:  # the selection's rounds: cancelled, nothing returned
        raise PartitionError(f"the split on the workers did not finish within the timeout"
                             f" of {timeout:g} s: its tasks were cancelled and nothing was"
                             " returned; give a longer timeout or more workers") from e
    clock("partition")
    if client is not None:
        out = _gather(tasks, bar, timeout, list(range(k)))
    else:
        with _finished(bar, {t.key for t in tasks}):
            out = dask.compute(*tasks, scheduler=scheduler or "threads")
    out = [o for o in out if o is not None]  # no cell, or no cutting cell within reach
    return _merged(plan, out, timings, clock)


def _merged(plan, out: list, timings: dict, clock) -> dict:
    """The tasks' owned pairs merged in the serial order (:func:`.assign.merge`), their
    statistics in ``timings["partitions"]``."""
    clock("dask")
    settled_side(timings)  # the side's boxes tasks (split on the workers): their CPU
    pairs = merge(plan.kinds, [o[0] for o in out], plan.dtype, plan.accelerate)
    clock("merge")
    timings["partitions"] = [o[1] for o in out]
    return pairs


def _gather(futures, bar=None, timeout=None, parts=None) -> list:
    """The futures' results in order, each fetched as soon as its task ends (a plain
    ``gather`` fetches them all after the last one: the first results' transfer would
    follow the slowest task instead of overlapping it); ``bar`` counts them. A worker
    lost under a task, or ``timeout`` seconds passed: the rest are cancelled and
    :class:`PartitionError` names the partitions (``parts``: their numbers)."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    index = {f.key: i for i, f in enumerate(futures)}
    parts = list(range(len(futures))) if parts is None else parts
    out, done = [None] * len(futures), set()
    try:
        for future, result in as_completed(futures, with_results=True, timeout=timeout):
            out[index[future.key]] = result
            done.add(future.key)
            if bar is not None:
                bar.update(1)
    except (KilledWorker, TimeoutError) as e:
        left = [parts[index[f.key]] for f in futures if f.key not in done]
        # cancelled, not left running on the workers (or queued behind the failure)
        futures[0].client.cancel([f for f in futures if f.key not in done])
        raise PartitionError(_failure(e, left, len(futures), timeout)) from e
    return out


def _failure(e, left: list, n: int, timeout) -> str:
    """What went wrong with a partitioned run's tasks, and what to do."""
    which = ", ".join(map(str, left[:8])) + (" ..." if len(left) > 8 else "")
    if isinstance(e, TimeoutError):
        return (f"{len(left)} of {n} partitions ({which}) not finished after the timeout of "
                f"{timeout:g} s: their tasks were cancelled and nothing was returned; give "
                f"a longer timeout, more workers or more partitions")
    return (f"a Dask worker died while running a partition's task ({e}); {len(left)} of "
            f"{n} partitions ({which}) did not finish and nothing was returned. A worker "
            f"that exceeds its memory limit is killed: give the workers more memory or "
            f"run with more partitions, each holding less (partitions=; fperr intersect "
            f"--partitions K)")


@contextlib.contextmanager
def _bar(progress: bool, k: int):
    """The partitions' progress bar (tqdm on stderr, after :data:`PROGRESS_DELAY` s, gone
    when done; ``progress`` False: a disabled bar that prints nothing)."""
    from tqdm import tqdm

    bar = tqdm(total=k, desc="registering", unit="partition", delay=PROGRESS_DELAY,
               file=sys.stderr, disable=not progress, leave=False)
    try:
        yield bar
    finally:
        bar.close()


def _finished(bar, keys):
    """A Dask local-scheduler callback (a context manager): ``bar.update(1)`` as each
    task of ``keys`` finishes (the local schedulers call it in the client's process)."""
    from dask.callbacks import Callback

    class _Count(Callback):
        def _posttask(self, key, result, dsk, state, worker_id):
            if key in keys:
                bar.update(1)

    return _Count()


#: A partition's slice up to this many bytes travels inside its task's message (no
#: scatter round trip: the client does not wait); larger ones are scattered to a worker
#: first (the scheduler never holds them, no "large graph" warning).
INLINE_BYTES = 8 << 20


def _payload(client, part: Part):
    """What the task receives for ``part``: the Part itself or its scattered future."""
    return part if part.nbytes <= INLINE_BYTES else client.scatter(part, hash=False)


class _Clock:
    """Wall seconds (``timings[step]``) and client-process CPU seconds
    (``timings["cpu_" + step]``) of consecutive steps."""

    def __init__(self, timings: dict):
        self.timings = timings
        self.t, self.c = time.perf_counter(), time.process_time()

    def __call__(self, step: str) -> None:
        t, c = time.perf_counter(), time.process_time()
        self.timings[step], self.timings["cpu_" + step] = t - self.t, c - self.c
        self.t, self.c = t, c
