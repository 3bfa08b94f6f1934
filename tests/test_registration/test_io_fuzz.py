"""Issue 11, input files: truncated and corrupt mesh files through the command line.

Every run is a real ``python -m fperr intersect`` process with a time limit. Properties:
no meshio exit (status 1), no traceback, no hang, and a rejected input writes nothing
(exit 2, one line on stderr naming the file). Formats: OFF, PLY, VTU, MSH, STL, OBJ;
corruptions: header only, truncated bodies, random bytes, flipped bytes.
"""
from __future__ import annotations

import os
import pathlib
import random
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import meshio
import pytest

from predicates.registration.examples import example

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
FORMATS = {".off": {}, ".ply": {}, ".vtu": {}, ".msh": {"file_format": "gmsh"},
           ".stl": {}, ".obj": {}}
HEADERS = {".off": b"OFF\n", ".ply": b"ply\n", ".vtu": b'<?xml version="1.0"?>\n',
           ".msh": b"$MeshFormat\n", ".stl": b"solid\n", ".obj": b"# obj\n"}
TIME_LIMIT = 60


def _fperr(*args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fperr", *args], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=TIME_LIMIT)


def _corruptions(good: bytes, ext: str, rng: random.Random):
    yield "header", HEADERS[ext]
    yield "first-line", good.split(b"\n", 1)[0] + b"\n"
    for frac in (0.1, 0.35, 0.6, 0.9):
        yield f"cut{frac}", good[: max(1, int(len(good) * frac))]
    yield "random", bytes(rng.randrange(256) for _ in range(600))
    yield "random-after-header", HEADERS[ext] + bytes(rng.randrange(256) for _ in range(300))
    flipped = bytearray(good)
    for _ in range(8):
        i = rng.randrange(len(flipped) // 4, len(flipped))
        flipped[i] = rng.randrange(256)
    yield "flipped", bytes(flipped)


def _cases(tmp_path):
    ex = example("plane_offset", 2)
    sim = tmp_path / "sim.vtu"
    meshio.Mesh(ex["sim"][0], [("tetra", ex["sim"][1])]).write(sim)
    rng = random.Random(11)
    cases = []
    for ext, kw in FORMATS.items():
        good = tmp_path / f"good{ext}"
        meshio.Mesh(ex["cut"][0], [("triangle", ex["cut"][1])]).write(good, **kw)
        data = good.read_bytes()
        for name, bad in _corruptions(data, ext, rng):
            path = tmp_path / f"bad-{name}{ext}"
            path.write_bytes(bad)
            cases.append((sim, path, "cut"))
    # corrupt simulation meshes too (the first argument)
    for ext in (".vtu", ".msh", ".off"):
        path = tmp_path / f"badsim{ext}"
        path.write_bytes(HEADERS[ext] + b"1 2 3\n")
        cases.append((path, tmp_path / "good.stl", "sim"))
    return cases


def _run_case(case):
    sim, cut, which = case
    out = cut.parent / f"out-{cut.name}-{which}.vtu"
    try:
        r = _fperr("intersect", str(sim), str(cut), "-o", str(out), "--quiet",
                   cwd=cut.parent)
    except subprocess.TimeoutExpired:
        return case, "hang", None, out.exists()
    return case, r.returncode, r.stderr, out.exists()


def test_fuzzed_files_never_hang_exit_1_or_trace(tmp_path):
    cases = _cases(tmp_path)
    assert len(cases) > 50
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(_run_case, cases))
    problems = []
    for (sim, cut, which), rc, err, wrote in results:
        bad = sim if which == "sim" else cut
        if rc == "hang":
            problems.append(f"{bad.name}: hang")
        elif rc == 0:
            if not wrote:
                problems.append(f"{bad.name}: exit 0 but no output")
        elif rc != 2:
            problems.append(f"{bad.name}: exit {rc}: {err[-200:]}")
        else:
            lines = err.strip().splitlines()
            if wrote:
                problems.append(f"{bad.name}: rejected but wrote the output")
            if "Traceback" in err or len(lines) != 1:
                problems.append(f"{bad.name}: stderr not one line: {err[-300:]}")
            elif str(bad) not in lines[0]:
                problems.append(f"{bad.name}: message does not name the file: {lines[0]}")
    assert problems == [], "\n".join(problems)
    # the fuzz does reject: most corrupt files are refused
    assert sum(rc == 2 for _, rc, _, _ in results) > len(results) // 2


@pytest.mark.parametrize("ext", [".off", ".ply"])
def test_header_only_file_is_refused_quickly(tmp_path, ext):
    """meshio's OFF and PLY readers loop forever on a file holding only its header."""
    ex = example("plane_offset", 2)
    sim = tmp_path / "sim.vtu"
    meshio.Mesh(ex["sim"][0], [("tetra", ex["sim"][1])]).write(sim)
    bad = tmp_path / f"cut{ext}"
    bad.write_bytes(HEADERS[ext])
    r = _fperr("intersect", str(sim), str(bad), "-o", "hits.vtu", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]
    assert str(bad) in r.stderr and "truncated" in r.stderr
    assert not (tmp_path / "hits.vtu").exists()
