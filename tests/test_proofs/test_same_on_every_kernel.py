"""The same answer on every machine (docs/design.md): ``fperr demo`` prints byte-identical
tables and writes byte-identical VTU files under the default OpenBLAS kernel and under
each ``OPENBLAS_CORETYPE`` this CPU can run (Haswell, SkylakeX, Sandybridge, Prescott);
a kernel the CPU lacks is skipped and named; and under each lower level of numpy's own
SIMD dispatch this CPU runs (``NPY_DISABLE_CPU_FEATURES``: what an older CPU's numpy
runs; its transcendental functions differ in the last bit per level). Nothing the demo
computes may go through BLAS/LAPACK, whose last bits differ per kernel: before the
examples were built from exact rotations, a LAPACK QR made the demo fail under three of
the four kernels."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from blas_kernels import KERNELS, supported
from numpy_dispatch import settings as numpy_dispatch_settings

ROOT = Path(__file__).resolve().parents[2]
SUPPORT = ROOT / "tests" / "support"
SUPPORTED, LACKING = supported()


def _demo(tmp: Path, kernel: str | None, numpy_off: str | None = None) -> tuple[str, dict]:
    """(stdout without the timing lines, {vtu name: bytes}) of ``fperr demo --n 8``
    under OpenBLAS kernel ``kernel`` with numpy's dispatch targets ``numpy_off`` off."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
    if numpy_off:
        env["NPY_DISABLE_CPU_FEATURES"] = numpy_off
    tmp.mkdir()
    r = subprocess.run([sys.executable, "-m", "fperr", "demo", "--n", "8", "--quiet",
                        "--out", "out"], cwd=tmp, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, f"fperr demo under {kernel or 'the default kernel'}: {r.stderr}"
    text = re.sub(r"(?m)^time: .*$", "time: -", r.stdout)
    return text, {p.name: p.read_bytes() for p in sorted((tmp / "out").glob("*.vtu"))}


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    return _demo(tmp_path_factory.mktemp("demo") / "default", None)


def _assert_same_as_default(run, default_run, what: str) -> None:
    """The demo's tables and VTU files byte for byte those of the default run."""
    text, files = run
    ref_text, ref_files = default_run
    assert "degenerate cases" in ref_text and len(ref_files) == 6  # a real run
    assert text == ref_text
    assert files.keys() == ref_files.keys()
    differ = [name for name in files if files[name] != ref_files[name]]
    assert not differ, f"{what}: {differ} differ from the default run's"


@pytest.mark.parametrize("kernel", list(KERNELS))
def test_demo_identical_under_every_kernel(kernel, default_run, tmp_path):
    if kernel in LACKING:
        pytest.skip(f"this CPU lacks the instructions of OpenBLAS's {kernel} kernel")
    _assert_same_as_default(_demo(tmp_path / kernel, kernel), default_run,
                            f"under {kernel}")


@pytest.mark.parametrize("numpy_off", numpy_dispatch_settings() or [None])
def test_demo_identical_under_every_numpy_dispatch_level(numpy_off, default_run, tmp_path):
    if numpy_off is None:
        pytest.skip("this CPU runs no numpy dispatch target above numpy's baseline")
    _assert_same_as_default(_demo(tmp_path / "numpy", None, numpy_off), default_run,
                            f"with numpy's {numpy_off} off")


def test_numpy_dispatch_levels_change_what_numpy_runs():
    """The settings really lower numpy's dispatch (a setting numpy ignored would make the
    test above vacuous): in a subprocess with a setting, its targets are off."""
    for off in numpy_dispatch_settings():
        code = (f"import sys; sys.path.insert(0, {str(SUPPORT)!r}); "
                "from numpy_dispatch import running; print(' '.join(running()))")
        env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": off}
        r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                           text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        assert not set(off.split()) & set(r.stdout.split()), (off, r.stdout)


def test_kernel_list_reads_this_cpu():
    """The skip decision is made from the CPU's flags, not assumed: every x86-64 CPU
    has SSE3 (Prescott), and a kernel is either supported or lacking."""
    assert set(SUPPORTED) | set(LACKING) == set(KERNELS)
    assert not set(SUPPORTED) & set(LACKING)
    if os.uname().machine == "x86_64" and Path("/proc/cpuinfo").exists():
        assert "Prescott" in SUPPORTED
