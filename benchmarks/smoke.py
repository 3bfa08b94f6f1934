"""Smoke run of every benchmark at its tiny size: each script in its own process, with a
timeout, and pass/fail per script (benchmarks/README.md, "Smoke run"). The benchmarks are
not run by CI; this says whether they still run, not how fast (sizes far below the
documented ones: the figures printed are meaningless).

    python benchmarks/smoke.py [--only NAME,...] [--timeout S] [--verbose]

Exit 0 when every script run passed, 1 otherwise (the failures' last lines printed).
``tests/test_benchmarks_smoke.py`` runs the cheapest of these (``CHEAP``) under pytest.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

#: script -> (arguments of its tiny run, a regular expression its output must match: a line
#: of its report, with a property that holds at any size where there is one). The helpers
#: timing.py, exact_context.py and intersect_bench.py (W1/W2's runner) are imported.
TINY: dict[str, tuple[list[str], str]] = {
    "timing.py": (["-c", "import timing; print('best', timing.best(lambda: 1, 2)[0])"],
                  r"^best 1$"),
    "exact_context.py": (["-c", "import exact_context as e; "
                          "print('exact', e.FractionContext().convert(0.5))"], r"^exact 1/2$"),
    "w3_predicates.py": (["--pairs", "2000", "--scalar", "20", "--exact", "5",
                          "--repeat", "1", "--dims", "2"],
                         r"\| 2D triangle_vertex \| [\d,]+ \| [\d,]+ \| [\d,]+ \| [\d,]+ \|"),
    "w1_cube.py": (["--sizes", "4", "--cuts", "plane", "--no-compare"],
                   r"\| cube n=4 × grid plane \| [\d.]+ \| [\d.]+ \| 0 \| \d+ \|"),
    "w2_square.py": (["--sizes", "16", "--cuts", "diagonal", "--no-compare"],
                     r"\| square n=16 × diagonal \| [\d.]+ \| [\d.]+ \| 0 \| \d+ \|"),
    "synth_compare.py": (["4"], r"demo 2D circle 4x4 \[float64\]: total \d+ -> \d+"),
    "analysis_scale.py": (["--quick"], r"^det7 +7 +\d+ +[\d.]+ +[\d.]+ "),
    "filtered_bench.py": (["--n", "1024", "--exact", "10", "--repeat", "1"],
                          r"\| orient3d \| random \| 40 \|"),
    "refine_bench.py": (["--sizes", "8", "16", "--repeat", "1"],
                        r"^ +16 +1536 +\d+ +\d+ "),
    "split_bench.py": (["--quick", "--repeat", "1"], r"^ +16 +24576 +\d+ +\d+ +2 "),
    "cut_cells_scaling.py": (["--repeat", "1"],
                             r"fitted exponent against the cut cells: intersected_cells k = "),
    "cut_bench.py": (["--repeat", "1", "--only", "2D", "--no-volumes"],
                    r"2D n=512: \d+ cells, \d+ pairs, \d+ new cells, 2 pieces"),
    "plan_memory.py": (["--n", "8", "--subdivisions", "2"], r"^digest [0-9a-f]{64}$"),
    "cell_pairs_bench.py": (["--n", "4", "--subdivisions", "1", "--reps", "1"],
                            r"^cell_pairs n=4 s=1: \d+ pairs, hash [0-9a-f]{16}, CPU best "),
    "floor_ratio.py": (["--rounds", "1", "--calls", "1", "--n", "4", "--subdivisions", "1",
                        "--paired", "2"],
                       r"^W1 \(n = 4, subdivisions 1\) / compiled floor .* 1 rounds of 1 calls"),
    "run_share.py": (["tiny", "2"], r"^tiny .* best [\d.]+ median [\d.]+ plan best "),
    "sweep_flags.py": (["6", "2", "1"], r"^sweep n=6 s=2: 1296 cells, \d+ flagged; CPU best "),
    "plan_time.py": (["tiny", "2"], r"^tiny plan CPU best [\d.]+ s, median [\d.]+ s \(2 calls"),
    "conform_clip_bench.py": (["--n", "4", "--repeat", "1"],
                              r"^  fperr half 1: 192 tets, 0 zero-volume, 0 open edges$"),
    # n = 16: the case list's largest tiny size that also runs the gmsh-free cases fast
    "conform_cases_bench.py": (["--n", "16", "--no-gmsh"], r'rotated icosphere\(2\)".*"pieces": 2'),
    "speed_bench.py": (["--cases", "w5", "--w5-sizes", "100", "--no-naive"],
                       r"\| W5 N=100 \| 3,100 \| 3,100 \([\d,]+\) \| [\d,]+ \|"),
    "accelerate_bench.py": (["--cases", "w1", "--repeat", "1"],
                            r"W1 numpy: [\d.]+ s CPU[\s\S]*W1 compiled: [\d.]+ s CPU"),
    "parallel_ceiling.py": (["--n", "8", "--rounds", "1"],
                           r"^registration +alone best [\d.]+ s; two at once best"),
    "partition_split.py": (["--n", "8", "--subdivisions", "2", "--ks", "2", "--reps", "1"],
                           r"^\| 2 \| [\d.]+ \| [\d.]+ \| [\d.]+ \|"),
    "partition_floor.py": (["--n", "8", "--subdivisions", "2", "--reps", "1"],
                           r"measured speed-up \(best/best\): [\d.]+x"),
    "partition_bench.py": (["--n", "8", "--subdivisions", "2", "--partitions", "2",
                            "--reps", "1", "--rounds", "1"], r"^\| 2 \| .*\| yes \|"),
    "partition_remote_bench.py": (["--n", "8", "--subdivisions", "2", "--reps", "1"],
                                  r"identical results: True"),
    "partition_client_cpu.py": (["--n", "8", "--subdivisions", "2", "--calls", "1"],
                                r"^median: client [\d.]+ \(plan [\d.]+\) .* digest [0-9a-f]{16}"),
    "partition_client_parts.py": (["1", "--n", "8", "--subdivisions", "2"],
                                  r"^client [\d.]+ \| .*_plan \d+"),
    "intersect_bench.py": (["-c", "import intersect_bench as b; "
                            "print('runner', callable(b.child), callable(b.run_cases))"],
                           r"^runner True True$"),
}

#: The scripts cheap enough for CI (a few seconds each at their tiny size).
CHEAP = ("timing.py", "exact_context.py", "w3_predicates.py", "w1_cube.py", "w2_square.py",
         "filtered_bench.py", "refine_bench.py", "split_bench.py", "cut_bench.py",
         "plan_memory.py", "conform_clip_bench.py", "partition_split.py", "intersect_bench.py")


def command(script: str) -> list[str]:
    """The tiny run of ``script`` as an argv (helpers through ``python -c``)."""
    args, _ = TINY[script]
    if args[0] == "-c":
        return [sys.executable, *args]
    return [sys.executable, str(HERE / script), *args]


def run(script: str, timeout: float) -> tuple[bool, str, float]:
    """(passed, why or the output's tail, wall seconds) of one tiny run, in a scratch folder
    (some scripts write files) with benchmarks/ and the repository on the path."""
    _, pattern = TINY[script]
    paths = [str(HERE), str(ROOT), os.environ.get("PYTHONPATH", "")]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            out = subprocess.run(command(script), capture_output=True, text=True, cwd=tmp,
                                 env=env, timeout=timeout)
        except subprocess.TimeoutExpired:
            return False, f"timed out after {timeout:.0f} s", time.perf_counter() - t0
    wall = time.perf_counter() - t0
    text = out.stdout + out.stderr
    if out.returncode != 0:
        return False, f"exit {out.returncode}:\n" + "\n".join(text.splitlines()[-15:]), wall
    if not re.search(pattern, text, re.MULTILINE):
        return False, f"exit 0 but no match of {pattern!r} in its output:\n{text[-800:]}", wall
    return True, text.splitlines()[-1] if text.strip() else "", wall


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="comma-separated script names (default: all)")
    ap.add_argument("--timeout", type=float, default=600.0, help="per script, seconds")
    ap.add_argument("--verbose", action="store_true", help="print each run's last line")
    a = ap.parse_args(argv)
    names = a.only.split(",") if a.only else list(TINY)
    unknown = [n for n in names if n not in TINY]
    if unknown:
        ap.error(f"no tiny run for {', '.join(unknown)}; known: {', '.join(TINY)}")
    failed = []
    for name in names:
        ok, info, wall = run(name, a.timeout)
        print(f"{'pass' if ok else 'FAIL'} {name:28s} {wall:6.1f} s", flush=True)
        if not ok:
            failed.append(name)
            print("    " + info.replace("\n", "\n    "), flush=True)
        elif a.verbose:
            print("    " + info, flush=True)
    print(f"{len(names) - len(failed)} of {len(names)} passed"
          + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
