"""numpy's own CPU dispatch levels this CPU can run, for the tests and ``.ci/run`` that
check results and examples are the same on every machine (docs/design.md, "The same
answer on every machine").

numpy picks, at import, the best of its compiled SIMD targets the CPU supports
(``__cpu_dispatch__``: X86_V3 = AVX2/FMA, X86_V4 = AVX-512, ...); its transcendental
functions give different last bits per target (float32 ``np.exp`` differs between
X86_V3 and the baseline). ``NPY_DISABLE_CPU_FEATURES`` turns targets off, so one machine
can run what an older CPU runs. ``python tests/support/numpy_dispatch.py`` prints one
setting per line: the value of ``NPY_DISABLE_CPU_FEATURES`` that drops the best
``k`` targets this CPU runs, for k = 1, 2, ... (nothing printed when the CPU runs no
target above numpy's baseline)."""
from __future__ import annotations

import sys

import numpy as np


def _cpu_tables() -> tuple[list[str], dict[str, bool]]:
    """(numpy's dispatch targets, this CPU's features) from numpy's extension module."""
    try:
        from numpy._core import _multiarray_umath as m  # numpy >= 2
    except ImportError:  # pragma: no cover - numpy 1.x
        from numpy.core import _multiarray_umath as m
    return list(getattr(m, "__cpu_dispatch__", [])), dict(getattr(m, "__cpu_features__", {}))


def running() -> list[str]:
    """numpy's dispatch targets this process runs (CPU support, less what
    ``NPY_DISABLE_CPU_FEATURES`` turned off)."""
    targets, features = _cpu_tables()
    return [t for t in targets if features.get(t)]


def settings() -> list[str]:
    """``NPY_DISABLE_CPU_FEATURES`` values, each lowering numpy's dispatch by one more of
    the targets this CPU runs (highest first)."""
    runs = running()
    return [" ".join(runs[i:]) for i in range(len(runs) - 1, -1, -1)]


if __name__ == "__main__":
    lower = settings()
    print("\n".join(lower))
    if not lower:
        print(f"numpy {np.__version__}: this CPU runs no dispatch target above the "
              "baseline (nothing to lower)", file=sys.stderr)
