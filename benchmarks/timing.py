"""The benchmarks' timing loop: best wall time of a few runs (the machines are shared,
so the minimum is the least disturbed run; benchmarks/README.md)."""
from __future__ import annotations

import time
from typing import Callable, TypeVar

T = TypeVar("T")


def best(f: Callable[[], T], repeat: int) -> tuple[T, float]:
    """(the last result of ``f()``, the shortest of ``repeat`` wall times in seconds)."""
    out, t = None, float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        t = min(t, time.perf_counter() - t0)
    return out, t
