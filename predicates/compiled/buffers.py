"""Reused output buffers of the compiled kernels, per thread.

A kernel writes at most as many rows as it proposes (a block's worst case), usually far
fewer; a fresh array of the worst-case size per block costs more — in page faults of
fresh memory and ``munmap`` — than the kernel itself on this kind of machine
(benchmarks/README.md). The kernels write into a buffer kept per thread (so that the
threads of a partitioned run never share one) and the callers copy the rows written.
"""
from __future__ import annotations

import threading

import numpy as np

__all__ = ["buffer"]

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
