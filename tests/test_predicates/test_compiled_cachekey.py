"""numba's disk cache of the package's kernels is keyed by all of their sources
(predicates.compiled.cachekey): a cached kernel that inlines a kernel of another module
is compiled again when that module changes, where numba alone serves the stale code."""
from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

pytest.importorskip("numba")

ROOT = pathlib.Path(__file__).resolve().parents[2]

CALLEE = '''from numba import njit


@njit(cache=True, inline="always")
def g(x):
    return x + {k}
'''
CALLER = '''from numba import njit

from .b import g


@njit(cache=True)
def f(x):
    return g(x) * 10
'''
RUN = '''import sys
from pathlib import Path
if sys.argv[1] == "keyed":
    from predicates.compiled.cachekey import install
    assert install(Path("pkg"))
from pkg.a import f
print(f(1))
'''


def _f_of_1(tmp_path, how: str, k: int) -> int:
    """f(1) in a fresh process after g became x + k (the caller's file unchanged)."""
    (tmp_path / "pkg" / "b.py").write_text(CALLEE.format(k=k))
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    r = subprocess.run([sys.executable, "-c", RUN, how], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return int(r.stdout.split()[-1])


@pytest.mark.parametrize("how", ["numba", "keyed"])
def test_a_changed_callee_recompiles_its_caller(tmp_path, how):
    """g changes from x + 1 to x + 2 in b.py; a.py, whose cached f inlines g, does not
    change. numba's own stamp (a.py's content) serves f's stale code: 20 again; keyed
    by every source of the folder, f is compiled again: 30."""
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("")
    (tmp_path / "pkg" / "a.py").write_text(CALLER)
    assert _f_of_1(tmp_path, how, 1) == 20
    assert _f_of_1(tmp_path, how, 1) == 20  # (from the cache)
    assert list((tmp_path / "pkg" / "__pycache__").glob("a.f-*.nbi"))
    assert _f_of_1(tmp_path, how, 2) == (20 if how == "numba" else 30)


def test_the_package_kernels_are_keyed_by_all_sources(tmp_path):
    """Importing a kernel module installs the package's locator, first in numba's list,
    for predicates/compiled; a folder's digest changes with any of its files' content
    or names, and with nothing else there."""
    from numba.core import caching

    import predicates.compiled.cells  # noqa: F401  (its import installs the locator)
    from predicates.compiled.cachekey import FOLDER, sources_digest

    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")
    assert getattr(impl._locator_classes[0], "folder", None) == FOLDER
    assert len(sources_digest()) == 64
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "notes.txt").write_text("not a source")
    digests = []
    for change in (None, ("notes.txt", "still not"), ("a.py", "x = 2\n"), ("b.py", "")):
        if change:
            (tmp_path / change[0]).write_text(change[1])
        sources_digest.cache_clear()
        digests.append(sources_digest(tmp_path))
    assert digests[0] == digests[1] and len(set(digests[1:])) == 3
