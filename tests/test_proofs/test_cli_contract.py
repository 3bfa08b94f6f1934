"""The command line's contract on a fresh machine, through real processes: exit 2 for
bad arguments and input only and exit 1 with one line for an internal error (a bug);
worker counts within the machine; every output in the format its extension says (or
refused before any work) with the user's umask; progress on stderr only; and
``fperr cut`` with ``fperr intersect``'s inputs, options, notes and usage."""
from __future__ import annotations

import json
import os
import pathlib
import re
import socket
import stat
import subprocess
import sys
import time
import tomllib

import meshio
import numpy as np
import pytest
from capped_registration import CAPPED, capped_env

from predicates.registration.examples import circle_polygon, cube_grid, grid_plane, square_grid

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def fperr(*args, cwd=ROOT, umask=None, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fperr", *map(str, args)], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=timeout,
                          preexec_fn=None if umask is None else (lambda: os.umask(umask)))


def _pad3(p):
    return np.column_stack([p, np.zeros(len(p))]) if p.shape[1] == 2 else p


def _write(path, mesh, cell_type):
    meshio.Mesh(_pad3(np.asarray(mesh[0], dtype=float)), [(cell_type, mesh[1])]).write(path)
    return str(path)


@pytest.fixture
def cube_plane(tmp_path):
    """3D: the cube as 4³ × 6 tetrahedra, cut by the plane z = 1/2 through grid vertices."""
    return (_write(tmp_path / "cube.vtu", cube_grid(4), "tetra"),
            _write(tmp_path / "plane.vtu", grid_plane(4, k=2), "triangle"))


@pytest.fixture
def square_circle(tmp_path):
    """2D: an 8×8 grid of squares cut by a 32-gon."""
    return (_write(tmp_path / "sq.vtu", square_grid(8), "triangle"),
            _write(tmp_path / "circ.vtu", circle_polygon(32), "line"))


# -- 1. exit codes: internal errors are bugs (1), bad input is 2 ----------------------------
_FAULT = ("import sys, predicates.tables as t\n"
          "def boom(*a, **k):\n"
          "    raise RuntimeError('injected fault')\n"
          "t.records = boom\n"
          "from proofs.cli import main\n"
          "sys.exit(main(sys.argv[1:]))\n")


@pytest.mark.parametrize("debug", [False, True])
def test_an_internal_error_is_exit_1_with_one_line_saying_bug(debug):
    argv = (["--debug"] if debug else []) + ["tables", "--dim", "2"]
    r = subprocess.run([sys.executable, "-c", _FAULT, *argv], cwd=ROOT, env=ENV,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stderr
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("fperr tables: internal error (a bug")
    assert "RuntimeError: injected fault" in line
    for what in ("command line", "fperr --version", "input files"):
        assert what in line
    if debug:
        assert "Traceback" in r.stderr and "boom" in r.stderr
    else:
        assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_bad_input_stays_exit_2_and_is_no_bug(tmp_path):
    for argv in (["tables", "--dim", "4"], ["intersect", "missing.vtu", "missing2.vtu"],
                 ["cut", "missing.vtu", "missing2.vtu"]):
        r = fperr(*argv, cwd=tmp_path)
        assert r.returncode == 2, (argv, r.stderr)
        assert "internal error" not in r.stderr and "Traceback" not in r.stderr



_RAISE_IN_RUN = ("import sys, predicates.registration as r\n"
                 "from predicates.registration.plan.inputs import MeshTypeError\n"
                 "def boom(*a, **k):\n"
                 "    raise {exc}\n"
                 "r.intersect_files = boom\n"
                 "from proofs.cli import main\n"
                 "sys.exit(main(sys.argv[1:]))\n")


@pytest.mark.parametrize("exc, status, says", [
    ("MemoryError('injected')", 1, "error: not enough memory for this run (MemoryError: "
                                   "injected); nothing was written"),
    ("TypeError('injected')", 1, "internal error (a bug"),
    ("ZeroDivisionError('injected')", 1, "internal error (a bug"),
    ("MeshTypeError('simulation cells must be integer vertex indices')", 2,
     "error: simulation cells must be integer vertex indices"),
])
def test_run_errors_are_bad_input_only_when_the_input_is_bad(tmp_path, cube_plane, exc,
                                                              status, says):
    """Out of memory is a failure (1, with what to do), not bad input; a TypeError or an
    ArithmeticError from inside the work is a bug (1); a mesh of the wrong number type
    is bad input (2). Nothing is written in any case."""
    out = tmp_path / "hits.vtu"
    r = subprocess.run([sys.executable, "-c", _RAISE_IN_RUN.format(exc=exc), "intersect",
                        *cube_plane, "-o", str(out)], cwd=ROOT, env=ENV,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == status, r.stderr
    assert says in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()


_LIMITED_REGISTRATION = CAPPED + (
    "from proofs.cli import main\n"
    "sys.exit(main(sys.argv[1:]))\n")


def test_out_of_memory_in_the_registration_exits_1_and_writes_nothing(tmp_path):
    """The address space capped once the plan is done (at the registration's entrance,
    to what the process maps plus 2 MiB; cube 30 × icosphere 3 needs tens of MiB
    more): exit 1, one message naming the registration's stage and what to do, no
    traceback, no output file."""
    from predicates.registration.examples import icosphere

    sim = _write(tmp_path / "cube.vtu", cube_grid(30), "tetra")
    cut = _write(tmp_path / "sphere.vtu", icosphere(3), "triangle")
    out = tmp_path / "hits.vtu"
    r = subprocess.run([sys.executable, "-c", _LIMITED_REGISTRATION, "intersect", sim, cut,
                        "-o", str(out), "--quiet"], cwd=ROOT,
                       env=capped_env(ROOT),  # the capped process's lean malloc
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 1, r.stderr
    assert re.search(r"^fperr intersect: error: not enough memory for the registration "
                     r"\([a-z_ ]+\) of meshes of \d+ MiB, .* partition the run .*--workers N "
                     r"--partitions K", r.stderr, re.M), r.stderr
    assert "Traceback" not in r.stderr and "internal error" not in r.stderr
    assert not out.exists()


def test_a_mesh_of_the_wrong_number_type_is_a_mesh_type_error():
    """What the command line reports as bad input is what validation raises (and, for
    a library caller, still a TypeError)."""
    from predicates import intersect
    from predicates.registration.plan.inputs import MeshTypeError

    (P, T), (Q, F) = cube_grid(2), grid_plane(2, k=1)
    for args in ((P, T.astype(float), Q, F), (P.astype(complex), T, Q, F)):
        with pytest.raises(MeshTypeError) as e:
            intersect(*args)
        assert isinstance(e.value, TypeError)

def test_version_names_what_a_bug_report_needs():
    import fperr as pkg

    r = fperr("--version")
    assert r.returncode == 0, r.stderr
    first, second = r.stdout.strip().splitlines()
    assert first == f"fperr {pkg.__version__}"
    assert second.startswith(f"Python {sys.version.split()[0]} ")
    assert f"numpy {np.__version__}" in second and "meshio" in second


# -- 2. bounded resources -------------------------------------------------------------------
def test_too_many_workers_is_refused_before_any_work(tmp_path, square_circle):
    sim, cut = square_circle
    t0 = time.monotonic()
    r = fperr("intersect", sim, cut, "--workers", "100000", "-o", "h.vtu", cwd=tmp_path)
    assert r.returncode == 2 and "--workers 100000" in r.stderr and "CPU" in r.stderr
    assert time.monotonic() - t0 < 60 and not (tmp_path / "h.vtu").exists()
    r = fperr("cut", sim, cut, "--workers", "3", "--partitions", "2", "-o", "p.vtu",
              cwd=tmp_path)
    assert r.returncode == 2 and "--partitions 2" in r.stderr
    assert not (tmp_path / "p.vtu").exists()


# -- 3. every output honours its extension, or is refused before any work --------------
@pytest.mark.parametrize("argv, option", [
    (["synthesize", "--dim", "2", "-o", "t.txt"], "-o/--output"),
    (["synthesize", "--dim", "2", "--check", "t.yaml"], "--check"),
    (["verify", "--dim", "2", "--certificate", "c.toml"], "--certificate"),
    (["verify", "--dim", "2", "--report", "r.txt"], "--report"),
    (["audit", "--dim", "2", "-o", "a.txt"], "-o/--output"),
    (["audit", "--dim", "2", "-o", "-"], "-o/--output"),
])
def test_an_output_of_another_format_is_refused_before_any_work(tmp_path, argv, option):
    r = fperr(*argv, cwd=tmp_path)
    cmd = argv[0]
    assert r.returncode == 2 and f"fperr {cmd}: error: argument {option}" in r.stderr
    assert r.stderr.startswith(f"usage: fperr {cmd}") and r.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_audit_writes_the_format_its_extension_says(tmp_path):
    base = ["audit", "--samples", "3", "--search-steps", "0", "--dim", "2",
            "--predicates", "vertex_vertex", "--dtype", "float64", "--quiet"]
    r = fperr(*base, "--format", "md", "-o", "a.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["violation_count"] == 0 and "Violations: 0" in r.stdout
    r = fperr(*base, "--format", "json", "-o", "a.md", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["violation_count"] == 0
    md = (tmp_path / "a.md").read_text()
    assert "Violations: 0" in md and not md.lstrip().startswith("{")


def test_synthesize_json_is_read_by_verify_with_a_progress_bar_and_no_stray_lines(tmp_path):
    """One fresh 2D synthesis (~40 s): the cached table is current (--check), the JSON
    written holds its exact coefficients, verify reads it."""
    cached_toml = ROOT / "proofs" / "data" / "synth_2d.toml"
    r = fperr("synthesize", "--dim", "2", "-o", "t.json", "--check", str(cached_toml),
              cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "ratio" in r.stdout and "sigma" in r.stdout
    written = json.loads((tmp_path / "t.json").read_text())
    cached = tomllib.loads(cached_toml.read_text())
    assert written == cached  # the same exact coefficients as the TOML of the same run
    assert "fperr synthesize 2D" in r.stderr  # the tqdm bar
    assert not re.search(r"2D \w+\.(lo|mid|hi)", r.stdout + r.stderr)
    r = fperr("verify", "--dim", "2", "--tolerances", "t.json", "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and "with overrides from t.json" in r.stdout, r.stderr
    r = fperr("verify", "--dim", "2", "--quiet", "--certificate", "c.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "c.json").read_text())


_FULL_DISK = ("import builtins, io, os, sys\n"
              "real = io.open\n"
              "class Half:\n"
              "    def __init__(self, fh): self.fh = fh\n"
              "    def __enter__(self): return self\n"
              "    def __exit__(self, *a): self.fh.close()\n"
              "    def write(self, t):\n"
              "        self.fh.write(t[:len(t) // 2]); self.fh.flush()\n"
              "        raise OSError(28, 'No space left on device (injected)')\n"
              "    def close(self): self.fh.close()\n"
              "def full(path, mode='r', *a, **k):\n"
              "    fh = real(path, mode, *a, **k)\n"
              "    name = os.path.basename(str(path)).lstrip('.')\n"
              "    return Half(fh) if 'w' in mode and name.startswith({name!r}) else fh\n"
              "builtins.open = io.open = full\n"
              "from proofs.cli import main\n"
              "sys.exit(main(sys.argv[1:]))\n")


@pytest.mark.parametrize("name, argv", [
    ("c.json", ["verify", "--dim", "2", "--quiet", "--certificate", "c.json"]),
    ("e.md", ["verify", "--dim", "2", "--quiet", "--report", "e.md"]),
    ("a.md", ["audit", "--samples", "3", "--search-steps", "0", "--dim", "2", "--predicates",
              "vertex_vertex", "--dtype", "float64", "--quiet", "-o", "a.md"]),
])
def test_a_failed_proof_output_leaves_the_old_file_and_no_other(tmp_path, name, argv):
    """Certificates, reports and audits are written whole or not at all: a write that
    fails half-way (a full disk, injected) leaves the file that was there and no
    temporary file beside it."""
    (tmp_path / name).write_text("before\n")
    r = subprocess.run([sys.executable, "-c", _FULL_DISK.format(name=name), *argv],
                       cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and "No space left on device" in r.stderr, r.stderr
    assert (tmp_path / name).read_text() == "before\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


# -- 4. written files have the user's umask ------------------------------------------------
@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_written_files_have_the_users_umask(tmp_path, umask, square_circle, cube_plane):
    sim, cut = square_circle
    r = fperr("intersect", sim, cut, "-o", "h.vtu", "--sim-output", "s.vtu", "--plot",
              "h.png", "--quiet", cwd=tmp_path, umask=umask)
    assert r.returncode == 0, r.stderr
    r = fperr("cut", *cube_plane, "-o", "p.vtu", "--png", "p.png", "--quiet", cwd=tmp_path,
              umask=umask)
    assert r.returncode == 0, r.stderr
    files = [tmp_path / f for f in ("h.vtu", "s.vtu", "h.png", "p.vtu", "p.png")]
    if umask == 0o077:  # the demo's dozen files once (~8 s), under the stricter mask
        r = fperr("demo", "--n", "4", "--out", "demo", "--quiet", cwd=tmp_path, umask=umask)
        assert r.returncode == 0, r.stderr
        files += sorted((tmp_path / "demo").iterdir())
        assert len(files) > 10
    for f in files:
        assert stat.S_IMODE(f.stat().st_mode) == 0o666 & ~umask, f


# -- 5. audit sizes ---------------------------------------------------------------------------
@pytest.mark.parametrize("samples", ["0", "-1"])
def test_audit_refuses_no_samples(tmp_path, samples):
    r = fperr("audit", "--samples", samples, cwd=tmp_path)
    assert r.returncode == 2 and "argument --samples: must be at least 1" in r.stderr
    assert "Violations" not in r.stdout and r.stdout == ""


# -- 7. a local cluster prints no dashboard warning --------------------------------------------
def test_workers_print_no_dashboard_port_warning_and_cut_matches_serial(tmp_path, cube_plane):
    pytest.importorskip("distributed")
    held = socket.socket()
    try:  # provoke distributed's "Port 8787 is already in use" (already held: the same)
        held.bind(("127.0.0.1", 8787))
        held.listen()
    except OSError:
        pass
    try:
        r = fperr("cut", *cube_plane, "-o", "pw.vtu", "--workers", "2", "--quiet",
                  cwd=tmp_path)
    finally:
        held.close()
    assert r.returncode == 0, r.stderr
    assert "8787" not in r.stderr and "already in use" not in r.stderr, r.stderr
    assert fperr("cut", *cube_plane, "-o", "p.vtu", "--quiet", cwd=tmp_path).returncode == 0
    a, b = meshio.read(tmp_path / "p.vtu"), meshio.read(tmp_path / "pw.vtu")
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.cells_dict["tetra"], b.cells_dict["tetra"])
    assert np.array_equal(a.cell_data["piece"][0], b.cell_data["piece"][0])


# -- 8. cut and intersect share their inputs and options ---------------------------------------
def _options(cmd: str) -> set:
    return set(re.findall(r"(--[a-z][a-z-]+)", fperr(cmd, "--help").stdout))


def test_cut_has_intersects_inputs_and_options():
    only_intersect = {"--output", "--sim-output", "--plot", "--naive"}
    only_cut = {"--output", "--explode", "--png", "--plot", "--surface", "--no-volumes",
                "--conforming", "--then"}
    shared = _options("intersect") - only_intersect
    assert shared == _options("cut") - only_cut
    assert {"--sim-region", "--cut-region", "--format", "--strict", "--no-refine-cut",
            "--tolerances", "--workers", "--scheduler", "--partitions", "--timeout",
            "--dtype", "--quiet"} <= shared


def test_cut_errors_show_cuts_usage(tmp_path, cube_plane):
    r = fperr("cut", *cube_plane, "--frobnicate", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("usage: fperr cut ")
    assert "fperr cut: error: unrecognized arguments: --frobnicate" in r.stderr


def test_cut_prints_intersects_notes(tmp_path):
    sim = _write(tmp_path / "cube.vtu", cube_grid(8), "tetra")
    cut = _write(tmp_path / "solid.vtu", cube_grid(2), "tetra")  # a tetrahedral CUT
    notes = {}
    for cmd in ("intersect", "cut"):
        r = fperr(cmd, sim, cut, "--quiet", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        notes[cmd] = [line for line in r.stdout.splitlines() if line.startswith("note:")]
    assert any("boundary triangles" in n for n in notes["intersect"])
    assert notes["cut"] == notes["intersect"]


def test_cut_cells_counts_name_what_they_count(tmp_path, cube_plane):
    """The plane through grid vertices meets 192 tetrahedra (a vertex on it) and splits
    none into fragments: intersect's count is of the first, cut's of the second."""
    r = fperr("intersect", *cube_plane, "--sim-output", "s.vtu", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    met = int(np.count_nonzero(meshio.read(tmp_path / "s.vtu").cell_data["cut"][0]))
    assert met == 192 and f"384 cells, {met} meet the cut" in r.stdout
    r = fperr("cut", *cube_plane, "-o", "p.vtu", "--format", "json", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    origin = meshio.read(tmp_path / "p.vtu").cell_data["cell_origin"][0]
    split = int(np.count_nonzero(np.bincount(origin) > 1))
    assert doc["split"]["split_cells"] == split == 0 and doc["split"]["pieces"] == 2
    assert doc["outputs"]["p.vtu"].startswith(f"384 cells; 0 of the {met} cells the cut "
                                              f"meets split")


def test_synthesize_quiet_prints_nothing_on_stderr(tmp_path):
    """--quiet: no bar; the user example's table (docs/examples) is what is cached."""
    from proofs.synthesize import table_section

    examples = ROOT / "docs" / "examples"
    env = {**ENV, "PYTHONPATH": os.pathsep.join([str(ROOT), str(examples)])}
    r = subprocess.run([sys.executable, "-m", "fperr", "synthesize", "--predicates",
                        "incircle2d", "--quiet", "-o", "t.toml"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert table_section((tmp_path / "t.toml").read_text()) == \
        table_section((examples / "incircle2d_synth.toml").read_text())
