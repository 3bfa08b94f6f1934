"""Certificates of ``fperr verify`` and their exact-rational checker (issue 14, part 4).

The certificates are written through the CLI and checked with ``python -m
proofs.check_certificate`` in subprocesses (exit codes 0/1/2); tampered copies are checked
in-process with :func:`proofs.check_certificate.check` (same code path as the CLI).
The checker's Sturm root counts are compared with sympy's ``real_roots`` (exact).
"""
from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
import sympy
from hypothesis import given
from hypothesis import strategies as st

from proofs import check_certificate as C
from proofs.verify import constraints

ROOT = Path(__file__).resolve().parents[2]


def _run(*args):
    return subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})


def _verify(tmp, dim, *extra):
    path = tmp / f"cert{dim}.json"
    r = _run("-m", "proofs.cli", "verify", "--dim", str(dim), "--certificate", str(path),
             *extra)
    return r, path


def _check_file(path):
    return _run("-m", "proofs.check_certificate", str(path))


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("certs")
    out = {}
    for dim in (2, 3):
        r, path = _verify(tmp, dim)
        assert r.returncode == 0, r.stderr
        out[dim] = path
    return out


def _doc(path):
    return json.loads(Path(path).read_text(encoding="utf-8"))


def _failing(doc):
    return {cid for cid, r in C.check(doc).items() if r is not None}


def _first_ineq(doc, method="dominance", radical=False):
    """(constraint id, numerator record) of a holding constraint's first inequality."""
    for c in doc["dims"][0]["constraints"]:
        for i in c["inequalities"]:
            if i["identical"]:
                continue
            num = i["numerator"]
            has_rad = any(isinstance(x, dict) for x in num["coefficients"])
            if num["evidence"]["method"] == method and has_rad == radical:
                return c["id"], num
    raise LookupError(method)


# -- certificates of the paper's tables ----------------------------------------------------

@pytest.mark.parametrize("dim,n", [(2, 30), (3, 67)])  # + the premises of rule GL
def test_certificates_of_paper_tables_check(certs, dim, n):
    r = _check_file(certs[dim])
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"{n} constraints, {n} re-established" in r.stdout
    doc = _doc(certs[dim])
    assert doc["version"] == 1 and len(doc["dims"][0]["constraints"]) == n


def test_recorded_polynomials_are_lhs_minus_rhs(certs):
    """The link the checker trusts: num/den of each record equals (lhs − rhs)(L=1, ε=s⁴)
    of the constraint verify decides (re-derived here with sympy)."""
    from fperr.symbols import L, eps
    s = sympy.Symbol("s", positive=True)
    doc = _doc(certs[2])
    recs = doc["dims"][0]["constraints"]
    cs = constraints(2)
    assert [c.id for c in cs] == [r["id"] for r in recs]

    def poly(p):
        def coef(c):
            if isinstance(c, str):
                return sympy.Rational(c)
            return sum(sympy.Rational(r) * sympy.Mul(*[sympy.Rational(b) ** sympy.Rational(e)
                                                       for b, e in fs])
                       for r, fs in c["terms"])
        return sum(coef(c) * s**i for i, c in enumerate(p["coefficients"]))

    checked = 0
    for c, rec in zip(cs, recs):
        for ineq, ir in zip(c.inequalities, rec["inequalities"]):
            diff = (ineq.lhs - ineq.rhs).subs(L, 1).subs(eps, s**4)
            if ir["identical"]:
                assert sympy.simplify(diff) == 0
                continue
            assert sympy.simplify(poly(ir["numerator"]) / poly(ir["denominator"]) - diff) == 0
            checked += 1
    assert checked >= 25      # every non-identical inequality of 2D (30)


def test_checker_imports_neither_sympy_nor_fperr(certs):
    code = ("import sys, proofs.check_certificate as C;"
            f"rc = C.main([{str(certs[3])!r}]);"
            "bad = [m for m in sys.modules if m.split('.')[0] in "
            "('sympy', 'mpmath', 'fperr', 'predicates', 'numpy') or m in "
            "('proofs.decide', 'proofs.verify', 'proofs.constraints', 'proofs.certificate')];"
            "assert rc == 0 and not bad, (rc, bad)")
    r = _run("-c", code)
    assert r.returncode == 0, r.stderr


# -- tampering -------------------------------------------------------------------------------

def test_coefficient_sign_flip_is_rejected(certs):
    doc = _doc(certs[2])
    cid, num = _first_ineq(doc)
    k = next(i for i, b in enumerate(num["bound"]) if b != "0")
    # the coefficient alone: the rational bound no longer lies below it
    t = copy.deepcopy(doc)
    _, tnum = _first_ineq(t)
    tnum["coefficients"][k] = str(-Fraction(num["coefficients"][k]))
    assert cid in _failing(t)
    # coefficient and bound together: the dominance argument fails
    _, tnum = _first_ineq(doc)
    tnum["coefficients"][k] = tnum["bound"][k] = str(-Fraction(num["bound"][k]))
    res = C.check(doc)
    assert res[cid] and "dominance fails" in res[cid]


def test_radical_coefficient_bound_above_it_is_rejected(certs):
    doc = _doc(certs[3])
    cid, num = _first_ineq(doc, radical=True)
    i = next(j for j, c in enumerate(num["coefficients"]) if isinstance(c, dict))
    lo, hi = C.coefficient_enclosure(num["coefficients"][i], 300, "t")
    assert Fraction(num["bound"][i]) <= lo
    num["bound"][i] = str(hi + Fraction(1, 2**200))
    assert "exceeds the coefficient" in C.check(doc)[cid]


def _isolation(doc):
    """Replace a holding record's dominance evidence by the (valid) isolation evidence
    'one gap (0, s_max), no roots, positive at its midpoint'."""
    cid, num = _first_ineq(doc)
    s_max = Fraction(doc["s_max"])
    num["evidence"] = {"method": "isolation", "pieces": [
        {"kind": "gap", "lo": "0", "hi": str(s_max), "sample": str(s_max / 2), "sign": 1}]}
    return cid, num


def test_piece_tampering_is_rejected(certs):
    doc = _doc(certs[2])
    cid, num = _isolation(doc)
    assert C.check(doc)[cid] is None          # positive control: valid evidence
    num["evidence"]["pieces"][0]["sign"] = -1
    assert "sign at sample" in C.check(doc)[cid]
    # a root interval moved into a range where there is no root
    s_max = Fraction(doc["s_max"])
    a, b = s_max / 4, s_max / 3
    num["evidence"]["pieces"] = [
        {"kind": "gap", "lo": "0", "hi": str(a), "sample": str(a / 2), "sign": 1},
        {"kind": "root", "lo": str(a), "hi": str(b)},
        {"kind": "gap", "lo": str(b), "hi": str(s_max), "sample": str((b + s_max) / 2),
         "sign": 1}]
    assert "holds 0 roots" in C.check(doc)[cid]
    # pieces that stop short of S
    num["evidence"]["pieces"] = [
        {"kind": "gap", "lo": "0", "hi": str(a), "sample": str(a / 2), "sign": 1}]
    assert "< S" in C.check(doc)[cid]


def test_root_interval_moved_past_S_is_rejected(tmp_path):
    """The paper's 5.4.4 argument fails (a root of one step's polynomial at ε ≈ 2.09e-6):
    required with --require-paper-argument, the certificate does not certify it; moving
    that root's isolating interval beyond S is caught by the Sturm count of the gap."""
    r, path = _verify(tmp_path, 3, "--require-paper-argument")
    assert r.returncode == 1
    cid = "3D.edge_edge.special.line14.gamma^2m^2"
    res = _check_file(path)
    assert res.returncode == 1 and f"FAIL  {cid}" in res.stdout
    assert "ε ∈ (2.093e-06" in res.stdout
    doc = _doc(path)
    c = next(c for c in doc["dims"][0]["constraints"] if c["id"] == cid)
    num = next(i["numerator"] for a in c["arguments"] for st in a["steps"]
               for i in st["inequalities"] if i["numerator"]["evidence"]["method"]
               == "isolation")
    s_max = Fraction(doc["s_max"])
    a, b = s_max * 2, s_max * 3
    num["evidence"]["pieces"] = [
        {"kind": "gap", "lo": "0", "hi": str(a), "sample": str(s_max / 2), "sign": 1},
        {"kind": "root", "lo": str(a), "hi": str(b)}]
    msg = C.check(doc)[cid]
    assert msg and "contains 1 root" in msg


def test_removed_constraint_and_missing_field(certs, tmp_path):
    doc = _doc(certs[2])
    removed = doc["dims"][0]["constraints"].pop(3)["id"]
    p = tmp_path / "removed.json"
    p.write_text(json.dumps(doc))
    r = _check_file(p)
    assert r.returncode == 1 and f"FAIL  {removed}: listed in constraint_ids" in r.stdout
    assert "NOT CERTIFIED: " + removed in r.stdout

    doc = _doc(certs[2])
    cid, num = _first_ineq(doc)
    del num["bound"]
    p.write_text(json.dumps(doc))
    r = _check_file(p)
    assert r.returncode == 2 and cid in r.stderr and "missing field 'bound'" in r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.parametrize("content,msg", [
    ("{not json", "malformed"),
    ('{"format": "fperr-certificate", "version": 9}', "version 9"),
    ('{"format": "fperr-certificate", "version": 1, "eps_max": "0.00001"}', "not a rational"),
    ('[]', "expected an object"),
])
def test_malformed_files_exit_2(tmp_path, content, msg):
    p = tmp_path / "bad.json"
    p.write_text(content)
    r = _check_file(p)
    assert r.returncode == 2 and msg in r.stderr and "Traceback" not in r.stderr


# -- broken tolerance tables ------------------------------------------------------------------

@pytest.mark.parametrize("dim,override,expected", [
    (2, {"2": {"kappa": {"mid": 9.5}}},
     {"2D.edge_edge.window.kappa[a_P,a_Q,a_A,a_B]",
      "2D.triangle_vertex.window.kappa[a_A,a_B,a_C]", "2D.tolerances.bracket.kappa",
      # |a_A − a_B| > 2κ(1 − R)(1 − ε) no longer exceeds its error: a weight's divisor
      # may be 0 (rule GL's premise)
      "2D.edge_edge.divisor[a_A-a_B]", "2D.edge_edge.divisor[a_P-a_Q]",
      "2D.triangle_vertex.divisor[a_A+a_B+a_C]"}),
    (3, {"3": {"phi": {"lo": 200}}}, {"3D.edge_edge.window.phi[a_bar,b_bar]"}),
])
def test_broken_table_is_not_certified(tmp_path, dim, override, expected):
    tol = tmp_path / "tol.json"
    tol.write_text(json.dumps(override))
    r, path = _verify(tmp_path, dim, "--tolerances", str(tol))
    assert r.returncode == 1
    res = _check_file(path)
    assert res.returncode == 1
    failed = {line.split()[1].rstrip(":") for line in res.stdout.splitlines()
              if line.startswith("FAIL")}
    assert failed == expected


# -- the checker's arithmetic against exact references ---------------------------------------

_small = st.integers(-6, 6)


@given(st.lists(st.tuples(_small, st.integers(1, 4)), min_size=1, max_size=4),
       st.lists(st.integers(-20, 20), min_size=1, max_size=5),
       st.fractions(-8, 8, max_denominator=16), st.fractions(-8, 8, max_denominator=16))
def test_sturm_counts_agree_with_sympy_real_roots(roots, extra, lo, hi):
    """Distinct real roots in (lo, hi): Sturm (checker) vs sympy.real_roots (exact),
    on integer polynomials with repeated rational roots times a random factor."""
    x = sympy.Symbol("x")
    p = sympy.Poly(sympy.Mul(*[(x - r) ** m for r, m in roots])
                   * sympy.Poly(list(reversed(extra)) or [1], x).as_expr(), x)
    if p.is_zero or lo >= hi:
        return
    slo, shi = sympy.Rational(lo.numerator, lo.denominator), \
        sympy.Rational(hi.numerator, hi.denominator)
    if p.eval(slo) == 0 or p.eval(shi) == 0:
        return
    coeffs = [Fraction(int(c)) for c in reversed(p.all_coeffs())]
    expected = len({r for r in sympy.real_roots(p) if slo < r < shi})
    assert C.count_roots(C.sturm_sequence(coeffs), lo, hi) == expected


@given(st.lists(st.fractions(-100, 100, max_denominator=1000), min_size=1, max_size=8),
       st.fractions(-3, 3, max_denominator=10**6))
def test_exact_sign_evaluation(coeffs, x):
    v = sum((c * x**i for i, c in enumerate(coeffs)), Fraction(0))
    assert C.sign_at(coeffs, x) == (v > 0) - (v < 0)


@given(st.integers(1, 10**6), st.integers(1, 10**4), st.sampled_from(["1/2", "1/4", "-1/2",
                                                                       "3/2", "1/3"]))
def test_radical_enclosures_are_exact_bounds(p, q, e):
    b, ex = Fraction(p, q), Fraction(e)
    lo, hi = C.coefficient_enclosure({"terms": [["1", [[str(b), e]]]]}, 64, "t")
    # lo ≤ b^(m/n) ≤ hi  ⇔  lo^n ≤ b^m ≤ hi^n (all positive)
    n, m = ex.denominator, ex.numerator
    assert 0 <= lo < hi and lo**n <= b**m <= hi**n and hi - lo <= Fraction(1, 2**64)


def test_unwritable_certificate_path_exits_2(tmp_path):
    r, _ = _verify(tmp_path / "no" / "such" / "dir", 2)
    # refused by argparse before any constraint is decided
    assert r.returncode == 2 and "--certificate" in r.stderr and "does not exist" in r.stderr
    assert "Traceback" not in r.stderr and "constraints" not in r.stdout
