"""Issue 10: tolerances from the geometry that can meet, refined coarse cutting meshes,
the resolution report, ResolutionWarning / ResolutionError, the memory guard
(docs/resolution.md). Exact references: fractions.Fraction orientations, and the exact
oracle of test_intersect_oracle for the soundness of the L taken over the cells that
can meet."""
from __future__ import annotations

import itertools
import os
import subprocess
import sys
import warnings
from fractions import Fraction
from pathlib import Path

import meshio
import numpy as np
import pytest

import fperr
import predicates
from predicates.registration import pipeline
from predicates.registration.examples import cube_grid, square_grid
from shared_cases import check_exact, plane_case

ROOT = Path(__file__).resolve().parents[2]
SIM_EDGE_KINDS = ("edge_vertex", "edge_edge", "edge_triangle")
SIM_VERTEX_KINDS = ("vertex_vertex", "vertex_edge", "vertex_triangle")


# -- the plane: two triangles of half-width 1e4, rotated, offset --------------------
def _orient3(a, b, c, x):
    a, b, c, x = ([Fraction(float(v)) for v in p] for p in (a, b, c, x))
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    w = [x[i] - a[i] for i in range(3)]
    d = (u[1] * v[2] - u[2] * v[1]) * w[0] + (u[2] * v[0] - u[0] * v[2]) * w[1] \
        + (u[0] * v[1] - u[1] * v[0]) * w[2]
    return (d > 0) - (d < 0)


def crossing_edges(sp, sc, cp, cc):
    """Edges of the simulation mesh whose endpoints lie strictly on opposite sides of
    the cutting plane (exact orientation against each triangle, which must agree)."""
    edges = {tuple(sorted(e)) for c in sc.tolist() for e in itertools.combinations(c, 2)}
    side = {}
    for i in range(len(sp)):
        o = {_orient3(*cp[t], sp[i]) for t in cc}
        assert len(o) == 1 and 0 not in o  # both triangles agree, no vertex on the plane
        side[i] = o.pop()
    return {e for e in edges if side[e[0]] != side[e[1]]}


def registered_sim(res, kinds):
    out = set()
    for k in kinds:
        out |= {tuple(sorted(r)) for r in res[k].sim.tolist()}
    return out


@pytest.fixture(scope="module")
def plane():
    return plane_case()


@pytest.fixture(scope="module")
def plane_res(plane):
    with warnings.catch_warnings():
        warnings.simplefilter("error", fperr.ResolutionWarning)  # resolved: no warning
        return predicates.intersect(*plane)


def test_plane_registers_exactly_the_crossing_edges(plane, plane_res):
    expect = crossing_edges(*plane)
    assert len(expect) > 300
    assert registered_sim(plane_res, SIM_EDGE_KINDS) == expect
    assert all(plane_res.counts[k] == 0 for k in SIM_VERTEX_KINDS)
    r = plane_res.resolution
    assert not r.coarse and r.ratio < 0.01 and r.refined[1] > 100
    assert r.L_global > 1e3 and plane_res.L_a + plane_res.L_b < 0.25
    print(f"sigma+/shortest sim edge near the cut: {r.ratio:.3g} (refined)")


def test_plane_without_refinement_warns_and_strict_refuses(plane):
    with pytest.warns(fperr.ResolutionWarning, match="refine"):
        res = predicates.intersect(*plane, refine_cut=False)
    assert res.resolution.coarse and res.resolution.ratio > 100
    assert res.counts["edge_triangle"] == 0  # what the warning is about: no crossing found
    print(f"sigma+/shortest sim edge near the cut: {res.resolution.ratio:.3g} (as given)")
    with pytest.raises(ValueError, match="refine_cut=True") as err:
        predicates.intersect(*plane, refine_cut=False, strict=True)
    assert isinstance(err.value, fperr.ResolutionError)
    assert "COARSE" in str(res) and "resolution:" in str(res)


def test_refined_plane_against_the_exact_oracle():
    """Soundness of L over the cells that can meet: the paper's guarantee, checked in
    exact arithmetic for every pair within 2σ+ (including pairs never processed)."""
    sp, sc, cp, cc = plane_case(n=3, half=50.0)
    res = predicates.intersect(sp, sc, cp, cc)
    assert res.resolution.L_global > 10 > 10 * (res.L_a + res.L_b)
    stats = check_exact(res)
    assert stats["registered"] > 20


def test_giant_far_tetrahedron_changes_nothing(plane, plane_res):
    sp, sc, cp, cc = plane
    nrm = np.cross(cp[1] - cp[0], cp[2] - cp[0])
    nrm /= np.linalg.norm(nrm)
    base = np.array([0.5, 0.5, 0.5]) + 1000 * nrm
    giant = base + 100 * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    sp2 = np.concatenate([sp, giant])
    sc2 = np.concatenate([sc, len(sp) + np.arange(4)[None]])
    res = predicates.intersect(sp2, sc2, cp, cc)
    assert float(res.tolerances.L) == float(plane_res.tolerances.L)
    assert res.scale_exponent == plane_res.scale_exponent

    def by_coords(r):  # cutting ids differ (the cut is refined near the giant too)
        return {k: {(tuple(sorted(s)), tuple(sorted(map(tuple, r.cut_points[c].tolist()))))
                    for s, c in zip(r[k].sim.tolist(), r[k].cut.tolist())} for k in r.kinds}
    assert by_coords(res) == by_coords(plane_res)


def test_2d_float32_long_segment():
    sp, sc = square_grid(10)
    # normal ∝ (-1, 2): vertex heights on levels 1/(10√5) = 0.045 apart; halfway: ≥ 0.022
    nrm = np.array([-1.0, 2.0]) / np.sqrt(5.0)
    d = np.array([2.0, 1.0]) / np.sqrt(5.0)
    off = 7.5 / (10 * np.sqrt(5.0))
    assert np.min(np.abs(sp @ nrm - off)) > 0.02
    cp = np.array([off * nrm - 1e4 * d, off * nrm + 1e4 * d]).astype(np.float32)
    cc = np.array([[0, 1]])
    with warnings.catch_warnings():
        warnings.simplefilter("error", fperr.ResolutionWarning)
        res = predicates.intersect(sp, sc, cp, cc, dtype=np.float32)
    sp32 = sp.astype(np.float32)
    a, b = ([Fraction(float(x)) for x in p] for p in cp)

    def side(x):
        x = [Fraction(float(v)) for v in x]
        o = (b[0] - a[0]) * (x[1] - a[1]) - (b[1] - a[1]) * (x[0] - a[0])
        assert o != 0
        return o > 0
    # the grid vertices are > 0.02 from the line (in float32 too: rounding is ~1e-3)
    assert np.min(np.abs((sp32.astype(np.float64) - cp[0]) @ nrm)) > 0.01
    sides = [side(x) for x in sp32]
    edges = {tuple(sorted(e)) for c in sc.tolist() for e in itertools.combinations(c, 2)}
    expect = {e for e in edges if sides[e[0]] != sides[e[1]]}
    assert len(expect) > 15
    assert registered_sim(res, ("edge_vertex", "edge_edge")) == expect
    assert res.counts["vertex_vertex"] == 0 and res.counts["vertex_edge"] == 0
    assert res.resolution.ratio < 0.01
    with pytest.warns(fperr.ResolutionWarning):
        predicates.intersect(sp, sc, cp, cc, dtype=np.float32, refine_cut=False)


# -- item 4: thin bar with slivers, graded mesh in float32 ------------------------------------
def thin_bar(slivers=True):
    """A bar 1 × 1e-3 × 1e-3 (Kuhn cubes of 1e-3) with, optionally, a few long sliver
    tetrahedra (10 long, 1e-3 thin) beside it near the cut x = 0.5003."""
    sp, sc = cube_grid(1)
    pts, cells = [], []
    for i in range(1000):
        pts.append(sp * 1e-3 + [i * 1e-3, 0, 0])
        cells.append(sc + 8 * i)
    if slivers:
        for j in range(3):
            y = 2e-3 + j * 1e-3
            pts.append(np.array([[0.5 - 5, y, 0], [0.5 + 5, y, 0], [0.5, y + 1e-3, 0],
                                 [0.5, y, 1e-3]]))
            cells.append(8 * 1000 + 4 * j + np.arange(4)[None])
    cp = np.array([[0.5003, -1, -1], [0.5003, 1, -1], [0.5003, 0, 1]])
    return np.concatenate(pts), np.concatenate(cells), cp, np.array([[0, 1, 2]])


def test_thin_bar_with_slivers_warns_before_the_work(monkeypatch):
    case = thin_bar()
    seen = []
    real, real_warn = pipeline.Registration, warnings.warn

    def spy(*a, **kw):
        seen.append("registration")
        return real(*a, **kw)
    monkeypatch.setattr(pipeline, "Registration", spy)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        monkeypatch.setattr(pipeline.warnings, "warn",
                            lambda *a, **kw: (seen.append("warning"), real_warn(*a, **kw)))
        res = predicates.intersect(*case)
    assert seen == ["warning", "registration"]
    msg = str([x for x in w if x.category is fperr.ResolutionWarning][0].message)
    assert "sliver" in msg and res.resolution.coarse
    with pytest.raises(fperr.ResolutionError, match="sliver"):
        predicates.intersect(*case, strict=True)
    # without the slivers the same bar is resolved
    with warnings.catch_warnings():
        warnings.simplefilter("error", fperr.ResolutionWarning)
        ok = predicates.intersect(*thin_bar(slivers=False))
    assert ok.resolution.ratio < 0.1


def graded_grid(h0=2e-5, h1=0.25, growth=3.0):
    """Tensor-product Kuhn grid on [-1, 1]³ with spacing growing geometrically from h0
    at the centre to about h1: a stand-in for a graded (gmsh) mesh."""
    x = [h0 / 2]
    while x[-1] < 1:
        x.append(x[-1] + min(h0 * growth ** len(x), h1))
    x = np.array(x)
    x = np.concatenate([-x[::-1], x])
    n = len(x) - 1
    sp, sc = cube_grid(n)
    idx = np.rint(sp * n).astype(int)
    return x[idx], sc


def test_graded_float32_warns_and_the_memory_guard_refuses():
    sp, sc = graded_grid()
    cp = np.array([[1e-6, -2, -2], [1e-6, 2, -2], [1e-6, 0, 2]])
    cc = np.array([[0, 1, 2]])
    with pytest.warns(fperr.ResolutionWarning, match="float64"):
        with pytest.raises(ValueError, match="float64") as err:
            predicates.intersect(sp, sc, cp, cc, dtype=np.float32, memory_limit=1 << 20)
    assert isinstance(err.value, fperr.ResolutionError)
    assert "refused before the work" in str(err.value) and "GiB" in str(err.value)
    with pytest.raises(fperr.ResolutionError):  # strict refuses before the guard
        predicates.intersect(sp, sc, cp, cc, dtype=np.float32, strict=True)


def test_report_lines_and_dict(plane_res):
    text = str(plane_res)
    assert "resolution: sigma+ =" in text and "shortest edge near the cut" in text
    assert "cutting mesh refined: 2 ->" in text
    d = plane_res.resolution.to_dict()
    assert d["coarse"] is False and d["threshold"] == 0.1 and d["refined"][0] == 2


def test_permutation_invariance_of_the_scale(plane, plane_res):
    sp, sc, cp, cc = plane
    rng = np.random.default_rng(3)
    perm = rng.permutation(len(sc))
    res = predicates.intersect(sp, sc[perm][:, ::-1], cp, cc[::-1][:, [0, 2, 1]])
    assert float(res.tolerances.L) == float(plane_res.tolerances.L)
    assert res.total == plane_res.total


# -- command line ----------------------------------------------------------------------------
def _fperr(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "fperr", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=300)


def test_cli_warns_on_stderr_and_strict_exits_1(tmp_path, plane):
    sp, sc, cp, cc = plane_case(n=4)
    meshio.Mesh(sp, [("tetra", sc)]).write(tmp_path / "sim.vtu")
    meshio.Mesh(cp, [("triangle", cc)]).write(tmp_path / "cut.vtu")
    r = _fperr("intersect", "sim.vtu", "cut.vtu", "--no-refine-cut", "--quiet", cwd=tmp_path)
    assert r.returncode == 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fperr intersect: warning: coarse")
    assert "COARSE" in r.stdout
    r = _fperr("intersect", "sim.vtu", "cut.vtu", "--no-refine-cut", "--strict", "-o",
               "hits.vtu", "--quiet", cwd=tmp_path)
    assert r.returncode == 1 and "error: coarse resolution" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "hits.vtu").exists()
    r = _fperr("intersect", "sim.vtu", "cut.vtu", "--strict", "-o", "hits.vtu", "--quiet",
               cwd=tmp_path)
    assert r.returncode == 0 and r.stderr == "" and (tmp_path / "hits.vtu").exists()
    assert "cutting mesh refined" in r.stdout


# -- the memory guard's pair estimate: exact integers, no BLAS (docs/design.md) ------------
def _no_blas(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("BLAS called by the pair estimate")

    for name in ("dot", "matmul", "inner", "vdot", "einsum", "tensordot"):
        monkeypatch.setattr(np, name, refuse)


def _overlap_count(ia0, ia1, ib0, ib1) -> int:
    """Brute force: Σ over every (a, b) pair of the grid cells both cover, Python ints."""
    total = 0
    for a0, a1 in zip(ia0.tolist(), ia1.tolist()):
        for b0, b1 in zip(ib0.tolist(), ib1.tolist()):
            n = 1
            for x0, x1, y0, y1 in zip(a0, a1, b0, b1):
                n *= max(0, int(min(x1, y1)) - int(max(x0, y0)) + 1)
            total += n
    return total


@pytest.mark.parametrize("seed", range(12))
def test_pair_estimate_is_the_exact_overlap_count_without_blas(seed, monkeypatch):
    """Dense and keyed counts both equal Σ over pairs of shared grid cells, with every
    BLAS entry point refusing (the estimate decides refusals: no BLAS, docs/design.md)."""
    from predicates.registration.plan import resolution as R
    from predicates.registration.spatial.blocks import Blocks

    rng = np.random.default_rng(seed)
    dim, sc_ = 2 + seed % 2, 10.0 ** rng.uniform(-3, 3)
    boxes = []
    for n in rng.integers(1, 60, size=2):
        lo = rng.uniform(-1, 1, size=(n, dim)) * sc_
        boxes += [lo, lo + rng.uniform(0, 1, size=(n, dim)) * sc_ * rng.choice([0.01, 0.3])]
    pad = sc_ * rng.choice([0.0, 1e-3, 0.2])
    expected = _overlap_count(*R._estimate_grid(*boxes, pad)[:4])
    _no_blas(monkeypatch)
    assert R.estimate_cell_pairs(*boxes, pad) == expected
    from predicates import compiled

    if compiled.available():  # the compiled occupancy counts: the same integer
        assert R.estimate_cell_pairs(*boxes, pad, Blocks(accelerate=True)) == expected
    monkeypatch.setattr(R, "_dense_pair_count", lambda *a: None)  # the keyed count
    assert R.estimate_cell_pairs(*boxes, pad) == expected


def test_pair_count_dot_is_exact_beyond_int64_and_float53(monkeypatch):
    """Σ x·y whose partial sums exceed 2^63 (Python integers) or 2^53 (int64): exact."""
    from predicates.registration.plan import resolution as R

    _no_blas(monkeypatch)
    rng = np.random.default_rng(5)
    for hi in (2 ** 27, 2 ** 33):  # sums ~2^60 (int64 path), ~2^72 (Python ints)
        x, y = rng.integers(0, hi, size=300), rng.integers(0, hi, size=300)
        exact = sum(int(a) * int(b) for a, b in zip(x, y))
        assert exact > 2 ** 53 and R._count_dot(x, y) == exact
    assert R._count_dot(np.zeros(0, np.int64), np.zeros(0, np.int64)) == 0
