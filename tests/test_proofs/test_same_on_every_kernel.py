"""The same answer on every machine (docs/design.md): ``fperr demo`` prints byte-identical
tables and writes byte-identical VTU files and PNG pictures under the default OpenBLAS
kernel and under each ``OPENBLAS_CORETYPE`` this CPU can run (Haswell, SkylakeX,
Sandybridge, Prescott); a kernel the CPU lacks is skipped and named; and under each lower
level of numpy's own SIMD dispatch this CPU runs (``NPY_DISABLE_CPU_FEATURES``: what an
older CPU's numpy runs; its transcendental functions differ in the last bit per level).
So does ``fperr cut --png``'s 3D picture of a cube cut by a sphere. Nothing the demo
computes or draws may go through BLAS/LAPACK, whose last bits differ per kernel: before
the examples were built from exact rotations, a LAPACK QR made the demo fail under three
of the four kernels; before the 3D pictures were projected by exact rotations
(pictures/view.py), mplot3d's projection made demo_3d.png differ in hundreds of pixels.
Matplotlib's PNGs carry no timestamp, so they are compared byte for byte."""
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


def _env(kernel: str | None, numpy_off: str | None) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
    if numpy_off:
        env["NPY_DISABLE_CPU_FEATURES"] = numpy_off
    return env


def _run(tmp: Path, kernel: str | None, numpy_off: str | None, cut_inputs: tuple[Path, Path]
         ) -> tuple[str, dict]:
    """(stdout of ``fperr demo --n 8`` without the timing lines, {file name: bytes} of
    every VTU and PNG it writes and of ``fperr cut``'s picture ``cut_pieces.png``) under
    OpenBLAS kernel ``kernel`` with numpy's dispatch targets ``numpy_off`` off."""
    env = _env(kernel, numpy_off)
    where = f"under {kernel or 'the default kernel'}, numpy's {numpy_off or 'none'} off"
    tmp.mkdir()
    r = subprocess.run([sys.executable, "-m", "fperr", "demo", "--n", "8", "--quiet",
                        "--out", "out"], cwd=tmp, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, f"fperr demo {where}: {r.stderr}"
    text = re.sub(r"(?m)^time: .*$", "time: -", r.stdout)
    files = {p.name: p.read_bytes() for p in sorted((tmp / "out").iterdir())}
    png = tmp / "cut_pieces.png"
    r = subprocess.run([sys.executable, "-m", "fperr", "cut", *map(str, cut_inputs),
                        "--png", str(png), "--quiet"], cwd=tmp, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"fperr cut {where}: {r.stderr}"
    files[png.name] = png.read_bytes()
    return text, files


@pytest.fixture(scope="module")
def cut_inputs(tmp_path_factory):
    """A cube of 6³ × 6 tetrahedra and an icosphere, as VTU files (built exactly)."""
    import meshio

    from predicates.registration.examples import cube_grid, icosphere

    d = tmp_path_factory.mktemp("cut_inputs")
    (sim_points, tets), (cut_points, tris) = cube_grid(6), icosphere(2)
    meshio.Mesh(sim_points, [("tetra", tets)]).write(d / "sim.vtu")
    meshio.Mesh(cut_points, [("triangle", tris)]).write(d / "cut.vtu")
    return d / "sim.vtu", d / "cut.vtu"


@pytest.fixture(scope="module")
def default_run(tmp_path_factory, cut_inputs):
    return _run(tmp_path_factory.mktemp("demo") / "default", None, None, cut_inputs)


def _assert_same_as_default(run, default_run, what: str) -> None:
    """The demo's tables, VTU files and pictures and the cut's picture byte for byte
    those of the default run."""
    from predicates.registration.pictures.demo import FILES

    text, files = run
    ref_text, ref_files = default_run
    assert "degenerate cases" in ref_text  # a real run
    assert set(ref_files) == {*FILES, "cut_pieces.png"}
    assert all(ref_files[f][:4] == b"\x89PNG" for f in ref_files if f.endswith(".png"))
    assert text == ref_text
    assert files.keys() == ref_files.keys()
    differ = [name for name in files if files[name] != ref_files[name]]
    assert not differ, f"{what}: {differ} differ from the default run's"


@pytest.mark.parametrize("kernel", list(KERNELS))
def test_demo_identical_under_every_kernel(kernel, default_run, cut_inputs, tmp_path):
    if kernel in LACKING:
        pytest.skip(f"this CPU lacks the instructions of OpenBLAS's {kernel} kernel")
    _assert_same_as_default(_run(tmp_path / kernel, kernel, None, cut_inputs), default_run,
                            f"under {kernel}")


@pytest.mark.parametrize("numpy_off", numpy_dispatch_settings() or [None])
def test_demo_identical_under_every_numpy_dispatch_level(numpy_off, default_run, cut_inputs,
                                                          tmp_path):
    if numpy_off is None:
        pytest.skip("this CPU runs no numpy dispatch target above numpy's baseline")
    _assert_same_as_default(_run(tmp_path / "numpy", None, numpy_off, cut_inputs),
                            default_run, f"with numpy's {numpy_off} off")


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
