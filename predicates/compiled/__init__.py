"""Optional compiled candidate chain (``pip install 'fperr[fast]'``: numba), generated
from the predicates' one source and bit-identical to the numpy batch path
(docs/design.md, "Compiled candidate chain: bit-identical to numpy").

:func:`resolve` decides whether a registration uses it: by default when numba imports
and the environment variable ``FPERR_ACCELERATE`` is not ``0``; ``intersect(...,
accelerate=False)`` forces the numpy path, ``accelerate=True`` requires numba.
"""
from __future__ import annotations

import functools
import os

__all__ = ["available", "resolve"]


@functools.lru_cache(maxsize=1)
def available() -> bool:
    """numba can be imported (the ``fast`` extra is installed)."""
    try:
        import numba  # noqa: F401
    except Exception:  # ImportError, or a numba that fails to load its LLVM
        return False
    return True


def resolve(accelerate: bool | None) -> bool:
    """Whether to run the compiled chain: ``accelerate`` if given (True without numba is
    an error), else numba is installed and ``FPERR_ACCELERATE`` is not ``0``."""
    if accelerate is None:
        return os.environ.get("FPERR_ACCELERATE", "1").strip() != "0" and available()
    if not isinstance(accelerate, bool):
        raise TypeError(f"accelerate must be True, False or None, got {accelerate!r}")
    if accelerate and not available():
        raise ImportError("accelerate=True needs numba: pip install 'fperr[fast]'")
    return accelerate
