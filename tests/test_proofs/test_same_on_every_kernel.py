"""The same answer on every machine (docs/design.md): ``fperr demo`` prints byte-identical
tables and writes byte-identical VTU files under the default OpenBLAS kernel and under
each ``OPENBLAS_CORETYPE`` this CPU can run (Haswell, SkylakeX, Sandybridge, Prescott);
a kernel the CPU lacks is skipped and named. Nothing the demo computes may go through
BLAS/LAPACK, whose last bits differ per kernel: before the examples were built from
exact rotations, a LAPACK QR made the demo fail under three of the four kernels."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from blas_kernels import KERNELS, supported

ROOT = Path(__file__).resolve().parents[2]
SUPPORTED, LACKING = supported()


def _demo(tmp: Path, kernel: str | None) -> tuple[str, dict]:
    """(stdout without the timing lines, {vtu name: bytes}) of ``fperr demo --n 8``."""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
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


@pytest.mark.parametrize("kernel", list(KERNELS))
def test_demo_identical_under_every_kernel(kernel, default_run, tmp_path):
    if kernel in LACKING:
        pytest.skip(f"this CPU lacks the instructions of OpenBLAS's {kernel} kernel")
    text, files = _demo(tmp_path / kernel, kernel)
    ref_text, ref_files = default_run
    assert "degenerate cases" in ref_text and len(ref_files) == 6  # a real run
    assert text == ref_text
    assert files.keys() == ref_files.keys()
    differ = [name for name in files if files[name] != ref_files[name]]
    assert not differ, f"under {kernel}: {differ} differ from the default kernel's"


def test_kernel_list_reads_this_cpu():
    """The skip decision is made from the CPU's flags, not assumed: every x86-64 CPU
    has SSE3 (Prescott), and a kernel is either supported or lacking."""
    assert set(SUPPORTED) | set(LACKING) == set(KERNELS)
    assert not set(SUPPORTED) & set(LACKING)
    if os.uname().machine == "x86_64" and Path("/proc/cpuinfo").exists():
        assert "Prescott" in SUPPORTED
