"""The shadow number type and the audit (``fperr audit``).

The audit must pass on the real predicates, and it must *fail* when a bound or a bracket
is deliberately wrong — otherwise a passing audit would mean nothing.
"""
from __future__ import annotations

import dataclasses
import json
import random
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import fperr
import predicates
from fperr import round_fraction
from fperr.intervals import RInterval, compare, exact_sqrt
from fperr.shadow import Shadow, ShadowContext
from proofs import audit as A
from proofs.cli import main as cli_main

ALL_PREDS = [p for d in (2, 3) for p in predicates.ALL[d]]
BINARY64, BINARY32 = fperr.context("binary64"), fperr.context("binary32")


# --------------------------------------------------------------------------------------
# the shadow number
# --------------------------------------------------------------------------------------
def test_shadow_carries_working_and_exact_values():
    a = Shadow.exact_input(0.1, BINARY64)          # the double nearest 0.1, exactly
    b = Shadow.exact_input(0.2, BINARY64)
    s = a + b
    assert s.w == 0.1 + 0.2
    assert s.x == Fraction(0.1) + Fraction(0.2)
    assert s.error() == abs(Fraction(0.1 + 0.2) - (Fraction(0.1) + Fraction(0.2))) > 0
    p = (a - b) * (a + b) / b
    assert p.w == (0.1 - 0.2) * (0.1 + 0.2) / 0.2
    assert p.x == (Fraction(0.1) - Fraction(0.2)) * (Fraction(0.1) + Fraction(0.2)) / Fraction(0.2)


def test_shadow_float32_and_mp17_round_in_their_format():
    x32 = Shadow.exact_input(np.float32(1.1), BINARY32)
    y32 = x32 * x32
    assert type(y32.w) is np.float32 and y32.w == np.float32(1.1) * np.float32(1.1)
    assert y32.x == Fraction(float(np.float32(1.1))) ** 2
    mp17 = fperr.context("mp17")
    with mp17.session():
        t = Shadow.exact_input(mp17.from_fraction(Fraction(3, 7)), mp17)
        u = t * t + t
        with mpmath.workprec(17):
            assert u.w == t.w * t.w + t.w
    assert mp17.to_fraction(t.w) == round_fraction(Fraction(3, 7), 17)


def test_inputs_must_be_representable():
    with pytest.raises(ValueError):
        Shadow.exact_input(0.1, BINARY32)
    with pytest.raises(ValueError):
        Shadow.exact_input(Fraction(1, 3), BINARY64)


def test_irrational_exact_values_are_rigorous_intervals():
    r = exact_sqrt(Fraction(2))
    assert isinstance(r, RInterval) and r.lo < r.hi and r.hi - r.lo < Fraction(1, 2**290)
    assert r.lo * r.lo <= 2 <= r.hi * r.hi
    assert compare(r, Fraction(1414213562373095, 10**15)) == 1
    assert compare(r * r, Fraction(2)) is None       # cannot decide an exact tie
    assert exact_sqrt(Fraction(9, 4)) == Fraction(3, 2)  # rational roots stay exact
    s = Shadow.exact_input(2.0, BINARY64).sqrt()
    assert s.w == 2.0 ** 0.5 and 0 < s.error() < Fraction(2.0 ** -52)


def test_round_fraction_matches_ieee():
    rng = np.random.default_rng(3)
    for v in rng.normal(size=2000) * 10.0 ** rng.integers(-30, 30, size=2000):
        assert float(round_fraction(Fraction(float(v)), 24)) == float(np.float32(v))
    assert round_fraction(Fraction(-7, 3), 4, "zero") == Fraction(-9, 4)


def test_comparisons_do_not_decide_behind_the_context():
    a = Shadow.exact_input(1.0, BINARY64)
    with pytest.raises(TypeError):
        bool(a < 2)
    with pytest.raises(TypeError):
        bool(a)


def test_brackets_follow_the_tolerance():
    t = Shadow.bracketed(0.5, Fraction(1, 2), Fraction(1, 4), Fraction(3, 4), BINARY64, "T")
    x = Shadow.exact_input(0.375, BINARY64)
    rhs = t * t
    c = x <= rhs
    assert rhs.lo == Fraction(1, 16) and rhs.hi == Fraction(9, 16)
    assert c.decision is False and c.exact_decision("lo") is False
    assert c.exact_decision("hi") is True and c.bracketed


def test_array_working_values_match_scalars():
    rng = np.random.default_rng(5)
    pred = predicates.d2.triangle_vertex
    fmt = A.FORMATS["binary64"]
    info = A.tolerance_info(2, "binary64", 0.5, 0.5)
    pts = [rng.uniform(-0.4, 0.4, size=(64, 2)) for _ in pred.points]
    pts[3] = (pts[0] + pts[1] + pts[2]) / 3 + rng.normal(size=(64, 2)) * 0.1
    ctx = ShadowContext(fmt).fresh(3, lanes=64)
    with ctx.session():
        coords = [tuple(Shadow.exact_input(p[:, k], fmt) for k in range(2)) for p in pts]
        hit_arr, _ = pred.fn(ctx, *coords, info.shadow)
    real_hit, _ = pred(*pts, info.real)
    assert np.array_equal(hit_arr, real_hit) and real_hit.any() and not real_hit.all()
    spec = A.spec_for(pred)
    for i in range(64):  # the recorded exact values are those of the scalar runs
        cfg = A.Config(2, "binary64", (0.5, 0.5),
                       tuple(tuple(Fraction(float(v)) for v in p[i]) for p in pts))
        sc = A.run_shadow(spec, cfg)
        assert sc.quantities["a_A"].x == ctx.quantities["a_A"].x[i]


# --------------------------------------------------------------------------------------
# the shadow run is the real floating-point path
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt_name", ["binary64", "binary32", "mp17"])
def test_shadow_run_follows_the_real_path(fmt_name):
    rng = random.Random(11)
    for pred in ALL_PREDS:
        spec = A.spec_for(pred)
        gen = A.Generator(spec, fmt_name, rng)
        for _ in range(25):
            cfg = gen.sample()
            ctx = A.run_shadow(spec, cfg)
            pts = A.working_points(fmt_name, cfg.points)
            hit, w = pred(*pts, cfg.info.real, ctx=A.real_context(fmt_name))
            assert bool(np.all(hit)) == bool(ctx.result), (pred, cfg)
            if ctx.result:  # identical working weights, bit for bit
                got = [A.FORMATS[fmt_name].to_fraction(x.w) for x in ctx.weights]
                want = [A.FORMATS[fmt_name].to_fraction(x) for x in np.ravel(w)]
                assert got == want


def test_check_classification():
    spec = A.PredicateSpec(predicates.d2.edge_vertex)
    kinds = {c.label: c.kind for c in spec.checks}
    assert kinds == {"m <= sigma_hat": "bracket", "d > tau": "bracket",
                     "a_hat < 0": "sign-geometric", "a_bar < 0": "sign-geometric"}
    spec = A.PredicateSpec(predicates.d3.tetrahedron_vertex)
    assert {c.kind for c in spec.checks if c.line == 12} == {"sign-guarded"}
    assert all(spec.checks[c.guard].line == 9 for c in spec.checks if c.line == 12)


def test_lower_sub_pairs_decide_the_geometric_premise():
    spec = A.PredicateSpec(predicates.d2.edge_vertex)
    F = Fraction
    cfg = A.Config(2, "binary64", (0.5, 0.5), ((F(-1, 4), F(0)), (F(1, 4), F(0)), (F(1, 4), F(0))))
    assert A.registered_sub_pairs(spec, cfg) == ["vertex_vertex(BP)"]
    cfg = A.Config(2, "binary64", (0.5, 0.5), ((F(-1, 4), F(0)), (F(1, 4), F(0)), (F(0), F(0))))
    assert A.registered_sub_pairs(spec, cfg) == []
    assert len(A.lower_pairs(3, ("ABCD", "P"))) == 4 + 6 + 4


# --------------------------------------------------------------------------------------
# the audit
# --------------------------------------------------------------------------------------
def test_audit_passes_on_the_real_predicates():
    a = A.Audit(samples=20, search_steps=3, zone_pairs=1, seed=1).run()
    s = a.summary()
    assert s["violation_count"] == 0, s["violations"][:3]
    for row in s["quantities"]:
        for fmt, d in row["formats"].items():
            assert d["samples"] > 0, (row["predicate"], row["quantity"], fmt)
            assert 0 < d["max_ratio"] <= 1
            if d["max_relative_ratio"] is not None:
                assert d["max_relative_ratio"] <= 1
    for row in s["checks"]:
        for fmt, d in row["formats"].items():
            assert d["evaluated"] > 0, (row["predicate"], row["check"], fmt)
            assert d["violations"] == 0 and d["undecided"] == 0
    assert s["tolerances"] and all(f["max_ratio"] <= 1 and f["same"]
                                   for t in s["tolerances"] for f in t["formats"].values())
    md = A.render_markdown(s)
    assert "Violations: 0" in md and "3D tetrahedron_vertex" in md


def _shrunk(name, factor):
    base = fperr.bounds

    def bound_fn(q):
        b = base(q)
        if q.name == name and b.valid:
            return dataclasses.replace(b, E=b.E * factor)
        return b
    return bound_fn


def test_audit_detects_a_bound_that_is_too_small():
    """E[a_P] planted 30 times too small: the measured error must exceed it."""
    spec = A.PredicateSpec(predicates.d2.edge_edge, bound_fn=_shrunk("a_P", Fraction(1, 30)))
    a = A.Audit([spec], formats=("binary64",), samples=40, search_steps=5, seed=2,
                audit_tolerances=False).run()
    s = a.summary()
    bad = [v for v in s["violations"] if v["type"] == "quantity"]
    assert bad and {v["quantity"] for v in bad} == {"a_P"}
    assert all(v["ratio"] > 1 for v in bad)
    # the record reproduces the violation
    v = bad[0]
    spec2, cfg, ctx, out = A.replay(v)
    err = ctx.quantities["a_P"].error()
    bound = spec.quantities["a_P"].E1["binary64"] * cfg.info.L ** 2
    assert err > bound


def test_audit_detects_a_bracket_that_is_too_narrow():
    """κ− and κ+ planted within 1/16 εL² of κ = 21εL² (the rounding error of a_P is up to
    9εL²): the working decision must disagree with an exact bracket somewhere near κ."""
    br = (("kappa", Fraction(21) - Fraction(1, 16), Fraction(21) + Fraction(1, 16)),)
    bad = []
    for seed in (3, 4, 5):  # the search is random; any of a few seeds must find one
        a = A.Audit([predicates.d2.triangle_vertex], formats=("binary64", "mp17"),
                    samples=60, search_steps=30, zone_pairs=2, seed=seed, brackets=br,
                    audit_tolerances=False).run()
        bad = [v for v in a.summary()["violations"] if v["type"] == "decision"]
        if bad:
            break
    assert bad, "a too-narrow bracket went unnoticed"
    assert all("kappa" in v["label"] for v in bad)
    v = bad[0]
    assert v["config"]["brackets"]
    _, _, _, out = A.replay(v)
    assert any(x["type"] == "decision" for x in out.violations)


def test_cli_json_and_exit_status(capsys, monkeypatch):
    rc = cli_main(["audit", "--samples", "6", "--search-steps", "1", "--dims", "2",
                   "--predicates", "vertex_vertex", "--formats", "binary64", "--format", "json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["violation_count"] == 0
    assert out["quantities"][0]["quantity"] == "d2"
    # a wrong bound makes the command fail
    real = fperr.bounds
    monkeypatch.setattr(fperr, "bounds", _shrunk("d2", Fraction(1, 1000)))
    A.spec_for.cache_clear()  # specs are cached with the bounds they were built with
    try:
        rc = cli_main(["audit", "--samples", "30", "--search-steps", "2", "--dims", "2",
                       "--predicates", "vertex_vertex", "--formats", "binary64"])
    finally:
        monkeypatch.setattr(fperr, "bounds", real)
        A.spec_for.cache_clear()
    assert rc == 1
    assert "Violations:" in capsys.readouterr().out


# --------------------------------------------------------------------------------------
# bad arguments are argparse errors, before any work
# --------------------------------------------------------------------------------------
ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def _fperr(args, cwd):
    import os
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args, msg", [
    (["--dims", "4"], "argument --dims: dimension 4 is not supported"),
    (["--dims", "2,x"], "argument --dims"),
    (["-o", "/missing/x"], "argument -o/--output: directory /missing does not exist"),
    (["--formats", "binary16"], "unknown format 'binary16'"),
    (["--dims", "2", "--predicates", "tetrahedron_vertex"],
     "unknown predicate 'tetrahedron_vertex'"),
])
def test_audit_bad_arguments_exit_2_before_any_work(tmp_path, args, msg):
    r = _fperr(["audit", *args], tmp_path)
    assert r.returncode == 2, r.stderr
    assert msg in r.stderr and "usage: fperr audit" in r.stderr
    assert "audited" not in r.stderr and r.stdout == ""  # nothing was run or printed
    assert list(tmp_path.iterdir()) == []


def test_audit_output_is_written_where_asked(tmp_path):
    r = _fperr(["audit", "--samples", "3", "--search-steps", "0", "--dims", "2",
                "--predicates", "vertex_vertex", "--formats", "binary64", "--format", "json",
                "-o", "sub.json"], tmp_path)
    assert r.returncode == 0, r.stderr
    written = json.loads((tmp_path / "sub.json").read_text())
    assert written == json.loads(r.stdout) and written["violation_count"] == 0
    assert [q["predicate"] for q in written["quantities"]] == ["2D vertex_vertex"]


def test_library_audit_rejects_bad_selections():
    with pytest.raises(ValueError, match="unknown dimension 4"):
        A.audit(dims=(4,))
    with pytest.raises(ValueError, match="unknown format 'binary16'"):
        A.audit(formats=("binary16",))
    assert [p.name for p in A.select_predicates((3,), ("edge_edge",))] == ["edge_edge"]
