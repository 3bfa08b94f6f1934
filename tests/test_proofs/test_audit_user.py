"""``fperr audit --predicates MODULE``: users' predicates audited with their declared
tolerance table (docs/custom-predicates.md, "Auditing your predicates"). A correct module
audits clean; a declaration that is wrong — a sign threshold below the sign bound, a
tolerance window narrower than the rounding error, a bound made too small — is reported
as a violation (exit 1), each violation re-checked here against exact arithmetic; an
unusable module exits 2 and writes nothing."""
from __future__ import annotations

import dataclasses
import json
import os
import pathlib
import subprocess
import sys
import textwrap
from fractions import Fraction

import pytest

import fperr
import proofs.audit as A
from proofs.user_predicates import load

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "docs" / "examples"

ORIENT = '''
from predicates.core import predicate
from predicates.vector import cross2, sub
from proofs.user_predicates import PredicateTolerances


@predicate(dim=2, points="ABC")
def {name}(ctx, A, B, C, tol):
    o = ctx.name("o", cross2(sub(B, A), sub(C, A)))
    if ctx.reject(o <= {rhs}, line=1):
        return ctx.miss()
    return ctx.hit(())


FPERR_TOLERANCES = PredicateTolerances(dim=2, predicates=[{name}], {decl})
'''
#: θ = εL²/1024, far below the sign bound E_sign[o] = 6εL² + O(ε²): wrong on purpose
BAD_THETA = ORIENT.format(name="left_of", rhs="0",
                          decl='sign_filter={left_of: {"o": "eps*L^2/1024"}}')
#: θ derived from the sign bound (the same predicate, declared right)
GOOD_THETA = ORIENT.format(name="left_of", rhs="0", decl="sign_filter=[left_of]")
#: κ's window is ±0.01εL², E[o] + E[κ] ≈ 8εL²: too narrow on purpose
NARROW = ORIENT.format(name="ccw", rhs="tol.kappa", decl='tolerances={"kappa": '
                       '("20.99*eps*L^2", "21*eps*L^2", "21.01*eps*L^2")}')
#: a predicate reading a tolerance its module does not declare
UNDECLARED = ORIENT.format(name="ccw", rhs="tol.kappa", decl="tolerances={}")


def _cli(*args, cwd, extra=()):
    path = os.pathsep.join([str(ROOT), str(EXAMPLES), str(cwd), *map(str, extra)])
    return subprocess.run([sys.executable, "-m", "proofs.cli", "audit", *map(str, args)],
                          cwd=cwd, env={**os.environ, "PYTHONPATH": path},
                          capture_output=True, text=True, timeout=600)


def _module(tmp_path, name, text):
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(text))
    return name


def _points(cfg):
    return [tuple(Fraction(float.fromhex(c)) for c in p) for p in cfg["points"]]


def _orient(A, B, C):
    return (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0])


# -- a correct module ---------------------------------------------------------------------

def test_correct_module_audits_clean_json_and_markdown(tmp_path):
    r = _cli("--predicates", "incircle2d", "--samples", "40", "--search-steps", "3",
             "--quiet", "--format", "json", "-o", "report.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert json.loads((tmp_path / "report.json").read_text()) == s
    assert s["module"] == "incircle2d" and s["violation_count"] == 0
    got = {(q["predicate"], q["quantity"]) for q in s["quantities"]}
    assert got == {("2D orient2d", "area2"), ("2D incircle", "area2"), ("2D incircle", "det")}
    for q in s["quantities"]:
        for fmt in ("binary64", "binary32", "mp17"):
            f = q["formats"][fmt]
            assert f["samples"] > 0 and 0 <= f["max_ratio"] <= 1, (q["quantity"], fmt, f)
    assert {c["kind"] for c in s["checks"]} == {"bracket"}
    assert {t["tolerance"] for t in s["tolerances"]} == {"omega", "alpha", "power"}
    assert all(f["max_ratio"] <= 1 and f["same"] for t in s["tolerances"]
               for f in t["formats"].values())
    md = _cli("--predicates", "incircle2d", "--samples", "5", "--search-steps", "0",
              "--dtype", "float64", "--quiet", "-o", "report.md", cwd=tmp_path)
    assert md.returncode == 0, md.stderr
    assert "Predicates of incircle2d" in md.stdout and "| 2D incircle | det |" in md.stdout
    assert (tmp_path / "report.md").read_text() + "\n" == md.stdout  # print adds one


def test_sign_filter_module_audits_clean_and_only_selects(tmp_path):
    r = _cli("--predicates", "sign_predicates", "--only", "orient2d,orient3d", "--samples",
             "60", "--quiet", "--format", "json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert [q["predicate"] for q in s["quantities"]] == ["2D orient2d", "3D orient3d"]
    assert {c["kind"] for c in s["checks"]} == {"sign-filter"}
    assert all(0 <= f["max_ratio"] <= 1 for q in s["quantities"]
               for f in q["formats"].values())


# -- wrong declarations ---------------------------------------------------------------------

def test_sign_threshold_below_the_sign_bound_is_a_violation(tmp_path):
    bad = _module(tmp_path, "bad_theta", BAD_THETA)
    r = _cli("--predicates", bad, "--quiet", "--format", "json", "-o", "bad.json",
             cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    s = json.loads(r.stdout)
    signs = [v for v in s["violations"] if v["type"] == "sign"]
    assert signs and s["violation_count"] >= len(signs)
    for v in signs:  # the exact orientation, recomputed: the working sign is wrong
        exact = _orient(*_points(v["config"]))
        assert exact != 0 and (v["F"] > 0) != (exact > 0), v
        assert v["config"]["module"] == bad
        if v["format"] == "binary64":  # and it is what Python's floats compute
            (ax, ay), (bx, by), (cx, cy) = [tuple(map(float, p)) for p in
                                            _points(v["config"])]
            assert (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) == v["F"]
    # declared right (θ derived from the sign bound), the same inputs audit clean
    good = _module(tmp_path, "good_theta", GOOD_THETA)
    r = _cli("--predicates", good, "--quiet", "--format", "json", cwd=tmp_path)
    assert r.returncode == 0 and json.loads(r.stdout)["violation_count"] == 0, r.stdout[-2000:]


def test_window_too_narrow_for_the_rounding_error_is_a_violation(tmp_path, monkeypatch):
    narrow = _module(tmp_path, "narrow", NARROW)
    r = _cli("--predicates", narrow, "--quiet", "--format", "json", cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    bad = [v for v in json.loads(r.stdout)["violations"] if v["type"] == "decision"]
    assert bad
    monkeypatch.syspath_prepend(str(tmp_path))
    decl = load(narrow)[0]
    for v in bad:
        fmt, c = A.FORMATS[v["format"]], v["config"]
        # T− and T+ exactly, at the L the declaration computes its tolerances for
        L = fperr.to_fraction(decl.tolerances(c["L_a"] + c["L_b"], dtype=fmt).L)
        eps = Fraction(1, 2 ** fmt.bits)
        lo, hi = Fraction(2099, 100) * eps * L ** 2, Fraction(2101, 100) * eps * L ** 2
        o = _orient(*_points(v["config"]))
        # "o <= kappa" rejects: it must reject every o <= T− and pass every o > T+
        assert (o <= lo and not v["working"]) or (o > hi and v["working"]), (o, lo, hi, v)


def test_a_bound_made_too_small_is_a_violation_in_process(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    base = fperr.bounds

    def shrunk(q):
        b = base(q)
        return dataclasses.replace(b, E=b.E / 1000) if q.name == "o_ABC" and b.valid else b

    s = A.audit_module(load("segment_crossing"), formats=("binary64",), samples=30,
                       search_steps=2, bound_fn=shrunk)
    bad = [v for v in s["violations"] if v["type"] == "quantity"]
    assert bad and {v["quantity"] for v in bad} == {"o_ABC"}
    assert all(v["ratio"] > 1 for v in bad)
    spec, cfg, ctx, out = A.replay(bad[0])  # the record reproduces the measured error
    assert spec.system is not None and ctx.quantities["o_ABC"].error() > 0


# -- unusable modules and bad arguments: status 2, nothing written ----------------------

@pytest.mark.parametrize("args, message", [
    (("--predicates", "no_such_module_xyz"), "cannot import 'no_such_module_xyz'"),
    (("--predicates", "json"), "module json has no FPERR_TOLERANCES"),
    (("--predicates", "incircle2d", "--dim", "3"), "declares no 3D predicates"),
    (("--predicates", "incircle2d", "--only", "nope"),
     "incircle2d: unknown predicate 'nope' (the module's: orient2d, incircle)"),
    (("--predicates", "undeclared"), "ccw: its instrumented run failed"),
    (("--predicates", "edge_edge,nope"), "'nope' is not a paper predicate"),
    (("--predicates", "edge_edge", "--only", "edge_edge"), "give the names once"),
])
def test_unusable_module_exits_2_writing_nothing(tmp_path, args, message):
    out = tmp_path / "out"
    out.mkdir()
    _module(out, "undeclared", UNDECLARED)
    r = _cli(*args, "-o", "report.json", cwd=out)
    assert r.returncode == 2 and message in r.stderr, r.stderr
    assert r.stdout == "" and "audited" not in r.stderr
    assert {p.name for p in out.iterdir()} <= {"undeclared.py", "__pycache__"}


def test_help_documents_the_grammar(tmp_path):
    r = _cli("--help", cwd=tmp_path)
    assert r.returncode == 0
    for text in ("--predicates MODULE", "--only NAME[,NAME]", "former form", "FPERR_TOLERANCES",
                 "2 bad arguments or an unusable"):
        assert text in r.stdout, text


# -- what protects a sign test: the declaration -------------------------------------------

def _sign_module(**decl):
    from predicates.core import predicate
    from predicates.vector import cross2, sub
    from proofs.user_predicates import PredicateTolerances

    @predicate(dim=2, points="ABC")
    def left(ctx, A, B, C, tol):
        o = ctx.name("o", cross2(sub(B, A), sub(C, A)))
        if ctx.reject(o <= 0, line=1):
            return ctx.miss()
        return ctx.hit(())

    return PredicateTolerances(dim=2, predicates=[left], name="inline",
                               tolerances={"kappa": ("10*eps*L^2", "21*eps*L^2",
                                                     "32*eps*L^2")}, **decl)


def test_protected_sign_test_counts_only_above_its_declared_bound():
    """Declared |o| > κ− (10εL², above E[o] ≈ 8εL²): agreeing wherever it holds, the wrong
    signs the degenerate inputs produce are all below it ("w/o premise")."""
    s = A.audit_module([_sign_module(protected={"left": {"o": "kappa_lo"}})],
                       formats=("binary64", "mp17"), worst_budget=None)
    (row,) = s["checks"]
    assert row["kind"] == "sign-protected" and s["violation_count"] == 0
    assert sum(f["premise_failed"] for f in row["formats"].values()) > 0


def test_unprotected_sign_test_must_be_right_everywhere():
    """Nothing declared (fperr verify refuses it): every wrong sign is a violation, and
    each is one by exact arithmetic."""
    s = A.audit_module([_sign_module()], formats=("binary64", "mp17"), worst_budget=None)
    assert s["checks"][0]["kind"] == "sign-unprotected"
    bad = [v for v in s["violations"] if v["type"] == "sign"]
    assert bad
    for v in bad:
        exact = _orient(*_points(v["config"]))
        assert (v["F"] > 0) != (exact > 0), v


def test_only_selects_paper_predicates_as_the_former_form_did(tmp_path):
    common = ("--samples", "3", "--search-steps", "0", "--dim", "2", "--dtype", "float64",
              "--quiet", "--format", "json")
    new = _cli("--only", "vertex_vertex", *common, cwd=tmp_path)
    old = _cli("--predicates", "vertex_vertex", *common, cwd=tmp_path)
    assert new.returncode == old.returncode == 0, new.stderr + old.stderr
    a, b = json.loads(new.stdout), json.loads(old.stdout)
    for s in (a, b):
        s.pop("elapsed_s")
        for w in s["worst_cases"]:
            w.pop("seconds", None)
    assert a == b and "module" not in a
    assert [q["predicate"] for q in a["quantities"]] == ["2D vertex_vertex"]
