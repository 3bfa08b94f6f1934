"""Reused output buffers of the compiled kernels, per thread.

A kernel writes at most as many rows as it proposes (a block's worst case), usually far
fewer; a fresh array of the worst-case size per block costs more — in page faults of
fresh memory and ``munmap`` — than the kernel itself on this kind of machine
(benchmarks/README.md). The kernels write into a buffer kept per thread (so that the
threads of a partitioned run never share one) and the callers copy the rows written.
Likewise a call's scratch arrays (:func:`scratch`) up to ``HELD`` bytes: fresh pages cost
about as much as the passes themselves at W1's sizes (benchmarks/README.md, "W1 toward
10x the floor (s18-w1)"); larger ones are fresh and not held past the call (a serial
run's peak, docs/partitioned.md section 2).
"""
from __future__ import annotations

import threading

import numpy as np

__all__ = ["buffer", "scratch"]

_LOCAL = threading.local()


def buffer(name: str, n: int, dtype, cols: int | None = None) -> np.ndarray:
    """A buffer of this thread named ``name`` with at least ``n`` rows (of ``cols``
    columns), ``dtype``: its first n rows (contents undefined)."""
    bufs = _LOCAL.__dict__.setdefault("buffers", {})
    key = (name, np.dtype(dtype).str, cols)
    b = bufs.get(key)
    if b is None or len(b) < n:
        b = np.empty((max(n, 1),) if cols is None else (max(n, 1), cols), dtype=dtype)
        bufs[key] = b
    return b[:n]


#: scratch arrays up to this many bytes reuse a per-thread buffer (module docstring)
HELD = 1 << 23


def scratch(name: str, n: int, dtype, fill=None) -> np.ndarray:
    """n entries of ``dtype`` for the duration of one call (``fill``: set to it): the
    thread's buffer ``name`` up to :data:`HELD` bytes, else a fresh array."""
    dtype = np.dtype(dtype)
    if n * dtype.itemsize > HELD:
        return np.empty(n, dtype) if fill is None else np.full(n, fill, dtype)
    out = buffer(name, n, dtype)
    if fill is not None:
        out.fill(fill)
    return out
