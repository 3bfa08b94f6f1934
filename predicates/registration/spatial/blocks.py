"""Per-row passes over many cells in blocks of rows (docs/partitioned.md, section 2): the plan's work
on every simulation cell (boxes, grid indices, occupancy, look-ups) runs block by block,
so its temporaries are cache-sized and reused instead of fresh arrays the size of the
mesh (on 5.3 M cells those are page-faulted mmaps: a third of the run's time was system
time), and the same blocks run on a thread pool in a partitioned run's plan.

A pass is a function ``f(a, b)`` of a row range that writes rows [a, b) of its outputs
and returns a per-span value (or None). :meth:`Blocks.spans` cuts [0, n) into one
contiguous span per thread; :meth:`Blocks.each` cuts a span into blocks. Values that are
combined over spans (occupancy counts, minima, maxima) are exact — integers, or min/max
of floats — so every result is bit-identical to the whole-array computation, whatever
the number of threads or the block size.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import Executor

__all__ = ["BLOCK", "Blocks", "SERIAL"]

#: rows per block: 65,536 rows of a few float64 columns stay in a core's L2/L3
BLOCK = 1 << 16
#: below this many rows per span, a thread hand-off costs more than it saves
MIN_SPAN = 1 << 15


class Blocks:
    """Runs per-row passes block by block: sequentially (``Blocks()``, the serial run)
    or one span per thread on ``pool`` (``Blocks(pool, threads)``: numpy releases the
    GIL inside its loops, so the spans overlap)."""

    def __init__(self, pool: Executor | None = None, threads: int = 1,
                 block: int | None = None, accelerate: bool = False):
        if block is not None and block < 1:
            raise ValueError(f"block must be at least 1 row, got {block}")
        self.pool = pool
        #: the passes' compiled, GIL-free kernels (predicates.compiled.cells): same values
        self.accelerate = accelerate
        self.threads = max(1, int(threads)) if pool is not None else 1
        self.block = block  # None: the module's BLOCK, read at each pass

    def spans(self, n: int) -> list[tuple[int, int]]:
        """[0, n) as contiguous ranges, one per thread (fewer when n is small)."""
        parts = max(1, min(self.threads, n // MIN_SPAN))
        cut = [n * i // parts for i in range(parts + 1)]
        return list(zip(cut[:-1], cut[1:]))

    def each(self, a: int, b: int) -> Iterator[tuple[int, int]]:
        """The blocks of the range [a, b)."""
        step = self.block or BLOCK
        for lo in range(a, b, step):
            yield lo, min(lo + step, b)

    def map(self, f: Callable[[int, int], object], n: int) -> list:
        """``[f(a, b) for (a, b) in spans(n)]``, the spans run concurrently on the pool.
        ``f`` handles one span (typically looping over :meth:`each`)."""
        spans = self.spans(n)
        if self.pool is None or len(spans) == 1:
            return [f(a, b) for a, b in spans]
        futures = [self.pool.submit(f, a, b) for a, b in spans]
        return [fu.result() for fu in futures]

    def rows(self, f: Callable[[int, int], None], n: int) -> None:
        """Call ``f(lo, hi)`` on every block of [0, n) (writes of disjoint rows: safe on
        threads)."""
        def span(a: int, b: int) -> None:
            for lo, hi in self.each(a, b):
                f(lo, hi)

        self.map(span, n)

    def submit(self, f, *args):
        """``f(*args)`` on the pool (a Future), or at once (an object with ``result()``)."""
        if self.pool is None:
            return _Done(f(*args))
        return self.pool.submit(f, *args)


class _Done:
    """A finished call, shaped like a Future."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


#: the serial run's blocks: sequential, one span
SERIAL = Blocks()
