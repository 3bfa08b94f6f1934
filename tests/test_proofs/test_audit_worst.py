"""The audit's worst-case search (proofs.audit.worst_case, first_order, worst_inputs)
and ``fperr audit --thorough``: against exact references and by construction."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import predicates
from fperr import ulp
from proofs import audit as A
from proofs.audit.fast_error import fast_errors
from proofs.audit.first_order import attainable
from proofs.audit.worst_case import Budget, WorstCaseSearch, slack

ROOT = Path(__file__).resolve().parents[2]
U64 = Fraction(1, 2**53)

#: A 2D vertex-vertex input found by the search (seed 4): d2 = (ax−bx)² + (ay−by)² in
#: binary64 errs by 7.9999996 ε·L², the derived bound being (8 + 16ε) ε·L².
WITNESS = (("0x1.00000052c5996p-1", "0x1.0000004c91ddep-1"),
           ("-0x1.00000007bce05p-1", "-0x1.000000503292dp-1"))


def _half_ulp(y: Fraction) -> Fraction:
    return ulp(y, 53) / 2 if y else Fraction(0)


def test_witness_attains_the_d2_bound_computed_independently():
    """By construction: plain float arithmetic against Fractions, L the largest box edge
    or twice the largest |coordinate| (rule K's premise: the box lies in [−L/2, L/2]²). The error is 1 − 5e-8 of the
    bound: the bound of d2 is attained, so no search can report more than ratio 1."""
    (ax, ay), (bx, by) = [[float.fromhex(c) for c in p] for p in WITNESS]
    got = (ax - bx) * (ax - bx) + (ay - by) * (ay - by)
    fa, fb = [Fraction(v) for v in (ax, ay)], [Fraction(v) for v in (bx, by)]
    exact = (fa[0] - fb[0]) ** 2 + (fa[1] - fb[1]) ** 2
    edge = max(abs(fa[0] - fb[0]), abs(fa[1] - fb[1]))
    L = max(edge, 2 * max(abs(c) for c in fa + fb))   # the box must lie in [−L/2, L/2]²
    assert L - edge < edge / 10**7                       # (almost) the box edge itself
    units = abs(Fraction(got) - exact) / (U64 * L**2)
    assert Fraction(79999, 10000) < units <= 8 + 16 * U64
    cfg = A.Config(2, "binary64", (0.5, 0.5), (tuple(fa), tuple(fb)))
    spec = A.spec_for(predicates.d2.vertex_vertex)
    spec.bound_coefficients("binary64")
    u, ratio, Lm = A.units_of(spec, cfg)["d2"]
    assert u == pytest.approx(float(units), rel=1e-12) and Lm == float(L)
    assert 0.9999 < ratio <= 1


def test_first_order_attainable_error_matches_the_sum_over_operations():
    """A = Σ|∂d2/∂y_k|·½ulp(y_k) over the operations that round, written out by hand for
    d2 = w0² + w1² (two differences, two squares, the sum) with exact Fractions at the
    working values, on random inputs; an input whose operations are all exact has A = 0."""
    rng = np.random.default_rng(5)
    X = rng.uniform(-0.6, 0.6, (50, 2, 2))
    X[0] = [[0.5, 0.5], [-0.5, -0.25]]        # 1, 0.75, 1, 0.5625, 1.5625: all exact
    got = attainable(predicates.d2.vertex_vertex, X, 53, {"sigma": np.zeros(50)})["d2"]
    assert got[0][0] == 0

    def rounded(exact: Fraction, working: float) -> Fraction:
        return _half_ulp(Fraction(working)) if Fraction(working) != exact else Fraction(0)

    for k in range(1, 50):
        (ax, ay), (bx, by) = [[float(v) for v in p] for p in X[k]]
        w0, w1 = ax - bx, ay - by
        s0, s1 = w0 * w0, w1 * w1
        F = Fraction
        want = (2 * abs(F(w0)) * rounded(F(ax) - F(bx), w0)
                + 2 * abs(F(w1)) * rounded(F(ay) - F(by), w1)
                + rounded(F(w0) ** 2, s0) + rounded(F(w1) ** 2, s1)
                + rounded(F(s0) + F(s1), s0 + s1))
        assert got[1][k] and float(got[0][k]) == pytest.approx(float(want), rel=1e-9)


@pytest.mark.parametrize("fmt", ["binary64", "binary32", "mp17"])
def test_fast_lane_error_matches_the_exact_shadow_run(fmt):
    """The climb's guide: on the audit's random and adversarial inputs it takes the same
    path as the real code and its error is within 0.01 ε·L^p of the exact one."""
    import random
    pred = predicates.d3.edge_edge
    spec = A.spec_for(pred)
    gen = A.Generator(spec, fmt, random.Random(7))
    bits = A.FORMATS[fmt].bits
    compared = 0
    for _ in range(60):
        cfg = gen.sample()
        X = np.array([[[float(c) for c in p] for p in cfg.points]])
        tol = {k: np.array([float(v)]) for k, v in cfg.info.real.values.items()}
        fast = fast_errors(pred, X, bits, tol)
        exact = A.run_shadow(spec, cfg).quantities
        assert {n for n, (_, m) in fast.items() if m[0]} == set(exact)
        for n, sh in exact.items():
            unit = Fraction(1, 2**bits) * cfg.info.L ** spec.quantities[n].power
            assert abs(fast[n][0][0] - float(sh.error())) <= 0.01 * float(unit)
            compared += 1
    assert compared > 100


def test_first_order_respects_reachability():
    """2D edge-vertex: a_hat is computed only where P is within τ of line AB."""
    X = np.array([[[-0.5, 0.0], [0.5, 0.0], [0.1, 0.0]],      # P on AB: reached
                  [[-0.5, 0.0], [0.5, 0.0], [0.1, 0.3]]])     # P far from AB: not
    tol = {k: np.full(2, v) for k, v in
           A.tolerance_info(2, "binary64", 0.5, 0.5).floats.items()}
    q = attainable(predicates.d2.edge_vertex, X, 53, tol)
    assert list(q["d"][1]) == [True, True] and list(q["a_hat"][1]) == [True, False]


@pytest.mark.parametrize("fmt", ["binary64", "mp17"])
def test_search_finds_the_worst_case_of_d2(fmt):
    """2D vertex-vertex d2, where the worst case is known: the first-order attainable
    maximum is exactly the bound's first-order term 8 ε·L² (each difference ≤ L rounds
    by ≤ ε·L near a binade edge, ...), and the witness above attains the bound itself.
    The search (a small count budget, three seeds, deterministic) must find A ≥ 7.8 on
    every seed (the configurations where every operation rounds approach 8 only in the
    limit; seeds 0-5 found 7.84-8.0), a measured error ≥ 0.75 of the bound on every seed (the audit before this
    search reached 0.76 in a looser reading of L) and ≥ 0.95 on the best (seeds 0-5
    measured 0.98-0.9999 in binary64, 0.56-0.99 in mp17)."""
    spec = A.spec_for(predicates.d2.vertex_vertex)
    best = 0.0
    for seed in range(3):
        w = WorstCaseSearch(spec, fmt, Budget(rounds=4, lanes=128, climb=80, sweep=4),
                            seed=seed).run()
        assert not w.violations
        wc = w.found["d2"]
        assert wc.first_order >= 7.8 and 0.75 <= wc.ratio <= 1
        best = max(best, wc.ratio)
    assert best >= 0.95


def test_slack_is_attributed_to_the_rules_or_the_search():
    assert slack(6.0, 8.0, 8.0) is None
    assert slack(3.0, 8.0, 4.0).startswith("rules: ")    # search got most of A
    assert slack(1.0, 8.0, 6.0).startswith("search: ")   # A is there, not aligned
    assert slack(-1.0, 8.0, 0.0).startswith("not reached")


RECORD_KEYS = {"dim", "algorithm", "quantity", "format", "worst_error_units",
               "bound_units", "ratio", "first_order_units", "slack", "config"}


def test_records_are_sound_and_replay():
    """Every record: the keys, ratio = worst/bound ≤ 1, the names of fperr tables, and
    its configuration re-measures to the same error."""
    s = A.audit(dims=(2, 3), formats=("binary32", "mp17"), names=("edge_vertex",),
                samples=8, search_steps=1)
    recs = s["worst_cases"]
    assert s["violation_count"] == 0 and len(recs) == 2 * 2 * 4
    assert {(r["dim"], r["quantity"]) for r in recs} == {
        (2, "m"), (2, "d"), (2, "a_hat"), (2, "a_bar"),
        (3, "m"), (3, "d2"), (3, "a_hat"), (3, "a_bar")}
    for r in recs:
        assert RECORD_KEYS <= set(r) and r["algorithm"] == "edge_vertex"
        assert 0 < r["ratio"] <= 1
        assert r["ratio"] == pytest.approx(r["worst_error_units"] / r["bound_units"], rel=1e-6)
        assert (r["slack"] is None) == (r["ratio"] >= 0.5)
        pred = getattr(predicates, f"d{r['dim']}").edge_vertex
        cfg = A.Config.from_json(r["dim"], r["config"])
        assert A.units_of(A.spec_for(pred), cfg)[r["quantity"]][0] == r["worst_error_units"]
    md = A.render_markdown(s)
    assert "## Worst cases per quantity" in md and "| 3D | edge_vertex | d2 | mp17 |" in md


def test_a_bound_too_small_is_a_loud_worst_case_violation():
    """E[d2] planted at 0.6 of the derived bound: the search must exceed it (the true
    worst is ~1.0 of the real bound) and report the ratio > 1, not hide it."""
    import dataclasses

    import fperr

    def bound_fn(q):
        b = fperr.bounds(q)
        return dataclasses.replace(b, E=b.E * Fraction(3, 5)) if q.name == "d2" else b
    spec = A.PredicateSpec(predicates.d2.vertex_vertex, bound_fn=bound_fn)
    a = A.Audit([spec], formats=("binary64",), samples=5, search_steps=0, zone_pairs=0,
                audit_tolerances=False,
                worst_budget=Budget(rounds=4, lanes=128, climb=80, sweep=4)).run()
    bad = [v for v in a.summary()["violations"] if v["type"] == "worst-case"]
    assert bad and all(v["ratio"] > 1 and v["quantity"] == "d2" for v in bad)
    rec = a.summary()["worst_cases"][0]
    assert rec["ratio"] > 1


def _fperr(args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_cli_thorough_runs_within_its_budget(tmp_path):
    r = _fperr(["audit", "--thorough", "--budget", "0.2", "--dim", "2", "--dtype", "float64",
                "--predicates", "vertex_vertex,edge_edge", "--samples", "4",
                "--search-steps", "0", "--format", "json", "-o", "t.json", "--quiet"],
               tmp_path)
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "t.json").read_text())
    assert s["worst_budget"]["seconds"] == 0.2
    recs = s["worst_cases"]
    assert [(x["algorithm"], x["quantity"]) for x in recs] == [
        ("vertex_vertex", "d2"), ("edge_edge", "a_P"), ("edge_edge", "a_Q"),
        ("edge_edge", "a_A"), ("edge_edge", "a_B")]
    for x in recs:
        assert RECORD_KEYS <= set(x) and x["format"] == "binary64"
        assert x["seconds"] < 0.2 + 0.15 and x["shadow_runs"] > 0 and 0 < x["ratio"] <= 1


@pytest.mark.parametrize("args, msg", [
    (["--budget", "1"], "argument --budget: only with --thorough"),
    (["--thorough", "--budget", "-2"], "the budget must be a positive number of seconds"),
    (["--thorough", "--budget", "x"], "'x' is not a number of seconds"),
])
def test_cli_budget_errors_exit_2(tmp_path, args, msg):
    r = _fperr(["audit", *args], tmp_path)
    assert r.returncode == 2 and msg in r.stderr and r.stdout == ""
