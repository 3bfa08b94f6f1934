"""The benchmarks still run (benchmarks/README.md, "Smoke run"): CI does not run them, so
the cheapest ones run here at their tiny sizes, each as a subprocess, checked for exit
code 0 and a line of their report (benchmarks/smoke.py's ``TINY``: a regular expression
with a property that holds at any size, e.g. the robust registration's 0 inconsistencies).
The whole file takes ~30 s on the shared 2-core machine at load 6 (CI's budget: ≤ 60 s).

Not run here (each takes 10 s to minutes even at its tiny size: Dask clusters, numba's
cold compile, the conforming cut, a subprocess per case): synth_compare.py,
analysis_scale.py, cut_cells_scaling.py, conform_cases_bench.py, speed_bench.py,
accelerate_bench.py, floor_ratio.py, parallel_ceiling.py, partition_floor.py, partition_bench.py and
partition_remote_bench.py (about 4.5 min together).
Smoke-run them all with

    python benchmarks/smoke.py
"""
from __future__ import annotations

import importlib.util
import pathlib

import pytest

BENCH = pathlib.Path(__file__).resolve().parents[2] / "benchmarks"


def _smoke():
    spec = importlib.util.spec_from_file_location("benchmarks_smoke", BENCH / "smoke.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


SMOKE = _smoke()


def test_every_benchmark_has_a_tiny_run():
    """A new script in benchmarks/ needs its tiny run in smoke.py, or nothing runs it."""
    scripts = {p.name for p in BENCH.glob("*.py")} - {"smoke.py"}
    assert scripts == set(SMOKE.TINY), (scripts ^ set(SMOKE.TINY))
    assert set(SMOKE.CHEAP) < set(SMOKE.TINY)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("script", SMOKE.CHEAP)
def test_cheap_benchmark_runs(script):
    ok, info, _ = SMOKE.run(script, timeout=50.0)
    assert ok, f"benchmarks/{script} at its tiny size: {info}"


@pytest.mark.timeout(300)
def test_w1_cube_runs_on_the_compiled_chain(monkeypatch):
    """The benchmarks' timers wrap the registration's methods; with the compiled chain
    (FPERR_ACCELERATE=1) they wrap what the fused path calls too (its cold compile
    allowed for: the kernels' disk cache may be empty)."""
    pytest.importorskip("numba")
    monkeypatch.setenv("FPERR_ACCELERATE", "1")
    ok, info, _ = SMOKE.run("w1_cube.py", timeout=280.0)
    assert ok, f"benchmarks/w1_cube.py at its tiny size, compiled chain: {info}"


def test_smoke_reports_a_failure(tmp_path):
    """The runner is not vacuous: a script that exits 1, and one whose report lacks the
    expected line, both fail."""
    for code, args in (("raise SystemExit(1)", ["-c", "raise SystemExit(1)"]),
                       ("print('nothing')", ["-c", "print('nothing')"])):
        SMOKE.TINY["_probe.py"] = (args, r"^something$")
        try:
            ok, info, _ = SMOKE.run("_probe.py", timeout=30.0)
        finally:
            del SMOKE.TINY["_probe.py"]
        assert not ok, code
        assert ("exit 1" in info) == (code.startswith("raise")), info
