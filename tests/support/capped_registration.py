"""A process whose address space is capped at the registration's entrance (the plan
done) to what it maps then plus 2 MiB (docs/partitioned.md, section 2): the tests that
show running out of memory in the registration is a clear refusal.

The cap only bites if the plan's freed blocks are not still mapped: glibc keeps a freed
block below its (dynamic, up to 32 MiB) mmap threshold in the heap, where the
registration can reuse it under the cap — measured: 38 MiB free in the heap at the
registration of cube 30 × icosphere 3 with glibc's defaults, 1 MiB with the fixed
threshold below. How much stays depends on the allocation history, so on the machine:
with the defaults, a CI machine's registration fitted in the heap and never reached the
cap. ``PREMISE`` checks the heap's free bytes at the cap and exits 3 if they are too many.
"""
from __future__ import annotations

import os

#: a fixed mmap threshold (which also turns off glibc's dynamic one) and trimming: a
#: large block is unmapped when freed, so the address space follows what is held
LEAN_MALLOC = {"MALLOC_MMAP_THRESHOLD_": "131072", "MALLOC_TRIM_THRESHOLD_": "131072",
               "MALLOC_ARENA_MAX": "1",
               "GLIBC_TUNABLES": "glibc.malloc.mmap_threshold=131072:"
                                 "glibc.malloc.trim_threshold=131072:glibc.malloc.arena_max=1"}

#: most the heap may hold free when the cap is set (bytes): beyond it the registration
#: could run in the plan's leftovers, and the test would show nothing
FREE_HEAP_MAX = 8 << 20

CAPPED = f"""\
import ctypes, resource, sys, unicodedata  # tqdm imports unicodedata lazily: mapped before
from predicates.registration import pipeline
real = pipeline.Registration


def free_heap():
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return 0
    if not hasattr(libc, "mallinfo2"):
        return 0
    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in
                    "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks "
                    "keepcost".split()]
    libc.mallinfo2.restype = MallInfo2
    return libc.mallinfo2().fordblks


def limited(*a, **k):
    free = free_heap()
    if free > {FREE_HEAP_MAX}:
        print(f"premise: {{free}} bytes free in the heap at the cap", file=sys.stderr)
        sys.exit(3)
    with open("/proc/self/status") as f:
        vm = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (vm + (2 << 20), resource.RLIM_INFINITY))
    return real(*a, **k)


pipeline.Registration = limited
"""


def capped_env(root) -> dict:
    """The environment of a capped process: the repository on the path, the numpy chain
    (its stages are the ones named) and glibc's lean malloc (module docstring)."""
    return {**os.environ, "PYTHONPATH": str(root), "FPERR_ACCELERATE": "0", **LEAN_MALLOC}
