"""The memory a partition's task used, from the process that ran it (docs/partitioned.md,
section 5): its own high-water mark of resident memory.

``getrusage(RUSAGE_SELF).ru_maxrss`` is the wrong number for a Dask worker: Linux keeps
the largest RSS of a process across ``fork`` and ``execve``, so a worker process spawned
by a client holding a large mesh reports the *client's* peak (a W4 worker "peaked" at
824 MiB, the client's figure, while it never held more than ~260 MiB). ``VmHWM`` in
``/proc/self/status`` belongs to the current address space only: it starts at exec and
can be reset (``echo 5 > /proc/self/clear_refs``), so it is read in the task itself,
when the task ends, never cached.
"""
from __future__ import annotations

import resource
import sys

__all__ = ["peak_rss_mib", "rss_mib"]

_STATUS = "/proc/self/status"


def _status_kib(field: str) -> float | None:
    """``field`` (e.g. "VmHWM") of /proc/self/status in KiB, None where there is none."""
    try:
        with open(_STATUS) as f:
            for line in f:
                if line.startswith(field + ":"):
                    return float(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


def peak_rss_mib() -> tuple[float, str]:
    """(peak resident memory of this process's own address space in MiB, its source):
    ``VmHWM`` read now ("VmHWM"), or where /proc is missing ``ru_maxrss`` ("ru_maxrss":
    an upper bound that may include a parent's peak; bytes on macOS, KiB elsewhere)."""
    hwm = _status_kib("VmHWM")
    if hwm is not None:
        return hwm / 1024, "VmHWM"
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return (r / 2**20 if sys.platform == "darwin" else r / 1024), "ru_maxrss"


def rss_mib() -> float | None:
    """Resident memory of this process now (``VmRSS``) in MiB, None without /proc."""
    v = _status_kib("VmRSS")
    return None if v is None else v / 1024
