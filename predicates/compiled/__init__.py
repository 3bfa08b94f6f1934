"""Optional compiled candidate chain (``pip install 'fperr[fast]'``: numba), generated
from the predicates' one source and bit-identical to the numpy batch path
(docs/design.md, "Compiled candidate chain: bit-identical to numpy").

:func:`resolve` decides whether a registration uses it. ``intersect(...,
accelerate=False)`` forces the numpy path, ``accelerate=True`` requires numba; the
environment variable ``FPERR_ACCELERATE=0`` / ``1`` does the same for the default
(``1``: whenever numba imports). Otherwise (``auto``, the default) the compiled chain
runs when numba imports and the run is large enough to repay loading it: a process
pays ~0.8 s once for numba's import and the cached kernels (benchmarks/README.md,
"First call"), while the chain saves ~0.5 µs per cell (W1, 684 k cells: ~0.3–0.5 s),
so below :data:`AUTO_CELLS` cells a one-shot run (``fperr intersect``) is faster on
numpy — unless the kernels are already loaded in this process. Both paths give the
same bits, so the choice is only about time.
"""
from __future__ import annotations

import functools
import os

__all__ = ["AUTO_CELLS", "available", "resolve"]

#: simulation + cutting cells from which ``auto`` uses the compiled chain (break-even
#: ~1.3–1.8 M cells on the figures above; W4, 10.7 M cells, saves ~5 s)
AUTO_CELLS = 2_000_000
_loaded = False  # the compiled chain ran in this process: its kernels are loaded


@functools.lru_cache(maxsize=1)
def available() -> bool:
    """numba can be imported (the ``fast`` extra is installed)."""
    try:
        import numba  # noqa: F401
    except Exception:  # ImportError, or a numba that fails to load its LLVM
        return False
    return True


def resolve(accelerate: bool | None, cells: int | None = None) -> bool | None:
    """Whether to run the compiled chain: ``accelerate`` if given (True without numba is
    an error); else ``FPERR_ACCELERATE`` (``0``: no, ``1``: if numba imports); else
    (``auto``) numba imports and the run has at least :data:`AUTO_CELLS` simulation +
    cutting ``cells`` or the chain already ran in this process. ``cells`` None (not
    known yet): None when ``auto`` has to wait for the count."""
    global _loaded
    if accelerate is None:
        mode = os.environ.get("FPERR_ACCELERATE", "auto").strip().lower()
        if mode == "0":
            return False
        if mode != "1" and not _loaded:  # the count first: importing numba costs ~0.25 s
            if cells is None:
                return None
            if cells < AUTO_CELLS:
                return False
        if not available():
            return False
        _loaded = True
        return True
    if not isinstance(accelerate, bool):
        raise TypeError(f"accelerate must be True, False or None, got {accelerate!r}")
    if accelerate and not available():
        raise ImportError("accelerate=True needs numba: pip install 'fperr[fast]'")
    _loaded = _loaded or accelerate
    return accelerate
