"""numba's on-disk cache of this package's kernels keyed by all of their sources
(docs/design.md, "Compiled candidate chain: bit-identical to numpy").

numba stamps a cached function by its own file only (its content, or its mtime and
size in older versions). A kernel that calls — or inlines — a kernel of another module
here (``cells`` → ``corners``, ``gridjoin`` → ``boxtest``, ``flagpack`` → ``cellsums``,
…) is then served from the cache after that other module changed: measured with
numba 0.68, a cached ``f(x) = 10·g(x)`` still returned 20 after ``g(x) = x + 1``
became ``x + 2`` in another file. In a working copy updated in place (a developer's,
a CI machine's reused checkout) that is stale machine code, and possibly other bits.

:func:`install` puts first among numba's locators one that keeps numba's own choice of folder (``NUMBA_CACHE_DIR``, the
``__pycache__`` beside the module, or the user-wide cache) and adds to its stamp the
digest of every ``.py`` file of this folder: any change to any kernel's source
invalidates every kernel's cache entry here. The generated predicate kernels are not
concerned: each is one self-contained module named by the hash of its text
(:func:`predicates.compiled.build.load_module`). Other packages' functions are left
to numba's usual locators.
"""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path

__all__ = ["FOLDER", "install", "sources_digest"]

#: the folder whose modules' kernels share one stamp
FOLDER = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=None)
def sources_digest(folder: Path = FOLDER) -> str:
    """sha256 of the names and contents of ``folder``'s ``.py`` files (once a process)."""
    h = hashlib.sha256()
    for path in sorted(folder.glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def install(folder: Path = FOLDER) -> bool:
    """Put first among numba's cache locators one for the kernels of ``folder`` (once a
    folder); False when numba is missing or its caching module lacks the locator
    interface (numba's own locators then stay in charge, as before)."""
    try:
        from numba.core import caching
    except Exception:  # numba not installed, or fails to load
        return False
    # (numba's names for them, now and in older versions)
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    base = getattr(caching, "_CacheLocator", None) or getattr(caching, "CacheLocator", None)
    if impl is None or base is None or not isinstance(getattr(impl, "_locator_classes", None), list):
        return False
    folder = Path(folder).resolve()
    if any(getattr(c, "folder", None) == folder for c in impl._locator_classes):
        return True
    others = list(impl._locator_classes)
    impl._locator_classes.insert(0, _locator_class(base, others, folder))
    return True


def _locator_class(base, others, folder: Path):
    """A numba ``_CacheLocator`` wrapping the first of ``others`` that takes a function of
    ``folder``, its stamp extended by :func:`sources_digest` of the folder."""

    class PackageLocator(base):
        def __init__(self, inner):
            self._inner = inner

        def ensure_cache_path(self):
            self._inner.ensure_cache_path()

        def get_cache_path(self):
            return self._inner.get_cache_path()

        def get_source_stamp(self):
            return (self._inner.get_source_stamp(), sources_digest(folder))

        def get_disambiguator(self):
            return self._inner.get_disambiguator()

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                if Path(py_file).resolve().parent != folder:
                    return None
            except (OSError, TypeError, ValueError):
                return None
            for other in others:
                inner = other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner)
            return None

    PackageLocator.folder = folder
    return PackageLocator
