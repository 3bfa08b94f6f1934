"""Issue 11, the command line through real processes: the same option names across
commands, bad arguments as argparse errors (exit 2, no traceback), output paths checked
before long runs, plain help texts, progress, and ``fperr demo --n 64`` in under 10 s of
CPU with non-trivial pictures."""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import time

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def fperr(*args, cwd=ROOT, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fperr", *map(str, args)], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=timeout)


def _options(cmd: str) -> set:
    import re

    text = fperr(cmd, "--help").stdout
    return set(re.findall(r"(--[a-z][a-z-]+)", text))


def test_option_names_are_the_same_across_commands():
    opts = {c: _options(c) for c in ("tables", "intersect", "demo", "verify", "audit")}
    for c in ("intersect", "demo", "audit"):
        assert "--dtype" in opts[c], c
    for c in ("tables", "verify", "audit"):
        assert "--dim" in opts[c], c
    for c in ("intersect", "verify", "tables", "audit"):
        assert "--format" in opts[c], c
    for c in ("intersect", "demo", "verify", "audit"):
        assert "--quiet" in opts[c], c
    assert not any({"--dims", "--formats"} & o for o in opts.values())


@pytest.mark.parametrize("argv, message", [
    (["audit", "--dims", "4"], "--dims"),
    (["audit", "--dim", "4"], "invalid choice"),
    (["audit", "--dtype", "float16"], "invalid choice"),
    (["audit", "--formats", "binary16"], "--formats"),
    (["verify", "--format", "xml"], "invalid choice"),
    (["intersect", "a.vtu", "b.vtu", "--format", "yaml"], "invalid choice"),
])
def test_bad_arguments_are_argparse_errors(argv, message):
    r = fperr(*argv)
    assert r.returncode == 2 and message in r.stderr
    assert "Traceback" not in r.stderr and r.stderr.startswith("usage: fperr")


def test_audit_output_path_is_checked_before_the_run(tmp_path):
    t = time.perf_counter()
    r = fperr("audit", "-o", tmp_path / "missing" / "x.md")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "missing" in r.stderr and r.stdout == ""
    assert time.perf_counter() - t < 60  # the audit itself takes far longer


def test_audit_new_option_names_run(tmp_path):
    import json

    r = fperr("audit", "--samples", "4", "--search-steps", "0", "--dim", "2", "--dtype",
              "float64", "--predicates", "vertex_vertex", "--format", "json", "--quiet")
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # --quiet: no progress lines
    s = json.loads(r.stdout)
    assert s["violation_count"] == 0


def test_help_of_verify_and_audit_is_plain_text():
    for cmd in ("verify", "audit"):
        r = fperr(cmd, "--help")
        assert r.returncode == 0
        assert "``" not in r.stdout and ":mod:" not in r.stdout and ":func:" not in r.stdout


def _png_stats(path):
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    rgb = (img[..., :3] * 255).round().astype(np.uint8).reshape(-1, 3)
    colours, counts = np.unique(rgb, axis=0, return_counts=True)
    return img.shape, len(colours), counts.max() / len(rgb)


def test_demo_n64_with_progress_and_real_pictures(tmp_path):
    # its time is a benchmark figure (benchmarks/README.md), not asserted here
    r = fperr("demo", "--n", "64", "--out", tmp_path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "fperr demo" in r.stderr and "step" in r.stderr  # the progress bar
    assert "Traceback" not in r.stderr
    from predicates.registration.pictures.demo import FILES

    for f in FILES:
        assert (tmp_path / f).stat().st_size > 1000, f
    for f in ("demo_2d.png", "demo_degenerate_2d.png", "demo_3d.png"):
        shape, ncol, dominant = _png_stats(tmp_path / f)
        assert shape[0] >= 500 and shape[1] >= 500, (f, shape)
        assert ncol >= 50, (f, ncol)  # mesh, cut, several kinds, labels
        assert dominant < 0.95, (f, dominant)  # not a blank canvas
    # the degenerate picture: robust 0 inconsistencies beside naive > 0
    assert "robust pairs" in r.stdout
    import meshio

    cells = meshio.read(tmp_path / "demo_3d_sim.vtu")
    assert 0 < cells.cell_data["cut"][0].sum() < len(cells.cells[0].data)


def test_demo_quiet_has_no_progress(tmp_path):
    r = fperr("demo", "--n", "4", "--out", tmp_path, "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and r.stderr == ""


@pytest.mark.parametrize("n3", [2, 8, 16])
def test_demo_3d_example_needs_no_refinement(n3):
    """The demo runs its 3D example with refine_cut=False: the icosphere is no coarser
    than the grid, so the refinement has nothing to do and the pairs are the same."""
    import predicates
    from predicates.registration.pictures.demo import sphere_case

    ex = sphere_case(n3)
    a = predicates.intersect(*ex["sim"], *ex["cut"])
    b = predicates.intersect(*ex["sim"], *ex["cut"], refine_cut=False)
    assert a.refinement is None or a.refinement.rounds == 0
    assert a.counts == b.counts and len(a.cut_cells) == len(b.cut_cells)
