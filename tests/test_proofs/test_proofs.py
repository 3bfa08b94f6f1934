"""Tests of proofs/: the verifier passes on the paper's tolerances for every ε ≤ 1e-5,
fails (naming the constraint) when a tolerance or a predicate moves outside a window,
decides by proof rather than sampling, and the generated report is up to date."""
from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
import sympy

import predicates
from fperr import bounds
from fperr.symbols import L, eps
from predicates.core import predicate
from predicates.vector import cross2, cross3, dot, scale, sub
from proofs import decide as D
from proofs import tables
from proofs.cli import main as fperr_main
from proofs.verify import instrument, verify

ROOT = Path(__file__).resolve().parents[2]
R = sympy.Rational


@pytest.fixture(scope="module")
def rep2():
    return verify(2)


@pytest.fixture(scope="module")
def rep3():
    return verify(3)


# -- the paper's tolerances ---------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_verify_passes_on_paper_tolerances_for_all_eps(dim, rep2, rep3):
    rep = rep2 if dim == 2 else rep3
    assert rep.ok, [(o.id, o.reason) for o in rep.failures]
    for o in rep.outcomes:
        assert o.constraint.error is None, o.id
        # every inequality that counts is proven on the whole range (0, 1e-5]
        for d in o.decisions:
            assert d.holds and not d.fails_on, o.id
        if o.arguments:
            arg = [a for a in o.arguments if a[0].name == o.established_by]
            assert arg and arg[0][2], o.id
            assert all(d.holds for st in arg[0][1] for d in st)
        t = o.tightest()
        if t is not None:  # margins at binary64 / binary32 are reported and positive
            assert t.at64[0] >= 0 and t.at32[0] >= 0, o.id


def test_every_algorithm_has_its_constraints(rep2, rep3):
    ids = [o.id for o in rep2.outcomes + rep3.outcomes]
    expected = [
        "2D.vertex_vertex.window.sigma[d2]",
        "2D.edge_vertex.window.sigma_hat[m]", "2D.edge_vertex.window.tau[d]",
        "2D.edge_vertex.sign[a_hat]", "2D.edge_vertex.sign[a_bar]",
        "2D.edge_vertex.nonzero[m]", "2D.edge_vertex.geometric.tau+<sqrt3/2*sigma-",
        "2D.edge_vertex.geometric.sigma_hat+<=sigma-",
        "2D.edge_edge.geometric.kappa+<=2tau-^2",
        "2D.edge_edge.window.kappa[a_P,a_Q,a_A,a_B]", "2D.edge_edge.sign[a_P,a_Q,a_A,a_B]",
        "2D.triangle_vertex.window.kappa[a_A,a_B,a_C]", "2D.triangle_vertex.sign[a_A,a_B,a_C]",
        "3D.vertex_vertex.window.sigma[d2]", "3D.edge_vertex.window.tau[d2]",
        "3D.edge_edge.geometric.lam+<=16(tau-^2-gamma+^2)^2",
        "3D.edge_edge.geometric.phi+<=8(tau-^2-gamma+^2)^2",
        "3D.edge_edge.window.lam[m2]", "3D.edge_edge.window.phi[a_hat,b_hat]",
        "3D.edge_edge.window.phi[a_bar,b_bar]", "3D.edge_edge.special.line14.gamma^2m^2",
        "3D.triangle_vertex.geometric.nu+<=108(tau-^2-delta+^2)^2",
        "3D.triangle_vertex.geometric.zeta+<=12sqrt3(tau-^2-delta+^2)^2",
        "3D.triangle_vertex.window.zeta[a_hat]", "3D.triangle_vertex.window.zeta[b_hat,c_hat]",
        "3D.triangle_vertex.special.line14.delta^2m^2",
        "3D.triangle_edge.geometric.mu+<=4gamma-^2min(gamma-,delta-)",
        "3D.triangle_edge.geometric.xi+<=6sqrt3gamma-^2min(gamma-,delta-)",
        "3D.triangle_edge.sign[v_A,v_B,v_C]", "3D.triangle_edge.sign[v_P,v_Q]",
        "3D.tetrahedron_vertex.geometric.rho+<=6sqrt3delta-^3",
        "3D.tetrahedron_vertex.sign[v_A,v_B,v_C,v_D]",
        "3D.tetrahedron_vertex.window.rho[v_A,v_B,v_C,v_D]",
    ]
    for cid in expected:
        assert cid in ids, cid


def test_table_equalities_hold_with_equality(rep3):
    # the paper's T+ identities (κ+ = 2τ−², λ+ = 16(τ−² − γ+²)², ...) are met exactly
    for o in rep3.outcomes:
        if o.constraint.kind == "geometric" and "equality_holds" in o.constraint.info:
            assert o.constraint.info["equality_holds"], o.id


def test_errors_come_from_the_instrumented_run(rep2):
    # the 2D edge-vertex τ window uses E[d] + E[τ] as derived (paper prints 20εL)
    o = rep2.by_id("2D.edge_vertex.window.tau[d]")
    ins = predicates.d2.edge_vertex.instrumented()
    tol = predicates.tracked_tolerances(2)
    expected = sympy.expand(bounds(ins.quantities["d"]).E + bounds(tol.tau).E)
    assert sympy.expand(o.constraint.info["error"] - expected) == 0
    from proofs.report import paper_form
    assert paper_form(expected)[0] == 19  # paper printed 20


def test_section_544_paper_argument_fails_near_1e5_but_constraint_holds(rep3):
    o = rep3.by_id("3D.edge_edge.special.line14.gamma^2m^2")
    assert o.holds and o.established_by == "direct two-sided bound"
    paper_arg = [a for a in o.arguments if a[0].name.startswith("paper")][0]
    assert not paper_arg[2]
    failing = [(st.title, d.fails_on) for st, ds in zip(paper_arg[0].steps, paper_arg[1])
               for d in ds if not d.holds]
    assert len(failing) == 2 and all(t.startswith("g(2/35") for t, _ in failing)
    # accepting side (m ≥ √λ−): fails above ≈ 2.09e-6; rejecting side (5.4.1): ≈ 5.84e-6
    lo = sorted(f[0][0] for _, f in failing)
    assert 2.0e-6 < lo[0] < 2.2e-6 and 5.7e-6 < lo[1] < 6.0e-6
    for _, f in failing:
        assert f[-1][1] == pytest.approx(1e-5)
    # triangle-vertex: ν− is much larger than λ−; the paper's argument holds there
    t = rep3.by_id("3D.triangle_vertex.special.line14.delta^2m^2")
    assert t.holds and t.established_by.startswith("paper")


def test_require_paper_argument_flag():
    rep = verify(3, require_paper_argument=True)
    assert [o.id for o in rep.failures] == ["3D.edge_edge.special.line14.gamma^2m^2"]


# -- tolerances moved outside their windows ------------------------------------------------

def test_kappa_9_5_fails_naming_the_window():
    rep = verify(2, {2: {"kappa": {"mid": 9.5}}})
    failed = [o.id for o in rep.failures]
    assert "2D.edge_edge.window.kappa[a_P,a_Q,a_A,a_B]" in failed
    assert "2D.triangle_vertex.window.kappa[a_A,a_B,a_C]" in failed
    assert "2D.tolerances.bracket.kappa" in failed
    o = rep.by_id("2D.edge_edge.window.kappa[a_P,a_Q,a_A,a_B]")
    low = o.decisions[1]  # κ − κ− > E: fails for every ε
    assert not low.holds and low.fails_on[0][0] == 0.0
    assert o.decisions[0].holds  # κ+ − κ still fine


def test_phi_lo_200_fails_naming_the_window():
    rep = verify(3, {3: {"phi": {"lo": 200}}})
    assert [o.id for o in rep.failures] == ["3D.edge_edge.window.phi[a_bar,b_bar]"]


def test_tolerance_files_via_cli(tmp_path, capsys):
    toml = tmp_path / "k.toml"
    toml.write_text("[2.kappa]\nmid = 9.5\n")
    assert fperr_main(["verify", "--dim", "2", "--tolerances", str(toml)]) == 1
    out = capsys.readouterr().out
    assert "FAIL  2D.edge_edge.window.kappa[a_P,a_Q,a_A,a_B]" in out
    js = tmp_path / "p.json"
    js.write_text(json.dumps({"3": {"phi": {"lo": 200}}}))
    assert fperr_main(["verify", "--dim", "3", "--tolerances", str(js)]) == 1
    out = capsys.readouterr().out
    assert "3D FAILED: 3D.edge_edge.window.phi[a_bar,b_bar]" in out
    ok = tmp_path / "same.json"
    ok.write_text(json.dumps({"3": {"phi": {"lo": 150, "mid": 470}}}))
    assert fperr_main(["verify", "--dim", "3", "--tolerances", str(ok)]) == 0


def test_changing_mid_reruns_the_tolerance_computation():
    # a mid that is not a short dyadic costs one more rounding in R[T] (rule J)
    assert tables.is_default(tables.table(2, {2: {"kappa": {"mid": 21.0}}}), 2)
    tab = tables.table(2, {2: {"kappa": {"mid": 21.1}}})
    assert tab["kappa"].mid == R(211, 10) and not tables.is_default(tab, 2)
    default = bounds(predicates.tracked_tolerances(2).kappa).R
    changed = bounds(predicates.tracked_tolerances(2, tab).kappa).R
    assert sympy.expand(changed - default) == eps + eps**2  # one more rounding (rule J)


@pytest.mark.parametrize("content, msg", [
    ('{"2": {"kapa": {"mid": 21}}}', "unknown 2D tolerance 'kapa'"),
    ('{"4": {}}', "unknown dimension"),
    ('{"2": {"kappa": {"middle": 21}}}', "unknown field"),
    ('{"2": {"kappa": {"lo": -1}}}', "positive"),
    ('{"3": {"phi": {"mid": "12*sqrt(3)"}}}', "must be rational"),
    ("not json [", "not valid"),
])
def test_bad_tolerance_files(tmp_path, capsys, content, msg):
    f = tmp_path / "bad.json"
    f.write_text(content)
    assert fperr_main(["verify", "--dim", "2", "--tolerances", str(f)]) == 2
    assert msg in capsys.readouterr().err


# -- predicates changed so their derived error grows past a window ---------------------------

@predicate(dim=2, points="ABP", weights=("a",), algorithm=3)
def edge_vertex(ctx, A, B, P, tol):
    """Test-only 2D edge-vertex: d goes through a needless rescaling chain (×3, ×1/3,
    twenty times: two roundings each, and 1/3 is itself rounded; ×2, ×0.5 would be
    exact, rules S/SD), and w = P − A is computed as (P − B) + (B − A)."""
    u_hat = sub(B, A)
    m = ctx.name("m", ctx.sqrt(dot(u_hat, u_hat)))
    if ctx.reject(m <= tol.sigma_hat, line=7):
        return ctx.miss()
    u = scale(u_hat, 1 / m)
    w = tuple(x + y for x, y in zip(sub(P, B), sub(B, A)))
    c = cross2(u, w)
    for _ in range(20):
        c = c * ctx.const(3) * ctx.const(Fraction(1, 3))
    d = ctx.name("d", abs(c))
    if ctx.reject(d > tol.tau, line=12):
        return ctx.miss()
    a_hat = ctx.name("a_hat", dot(u, w))
    a_bar = ctx.name("a_bar", m - a_hat)
    if ctx.reject(ctx.any(a_hat < 0, a_bar < 0), line=17):
        return ctx.miss()
    return ctx.hit((a_hat / m,))


def test_variant_2d_edge_vertex_error_grows_past_tau_window():
    ins = instrument(edge_vertex)
    assert bounds(ins.quantities["d"]).E_int == 281  # 19 for the real predicate
    rep = verify(2, runs=[edge_vertex])
    assert [o.id for o in rep.failures] == ["2D.edge_vertex.window.tau[d]"]
    o = rep.failures[0]
    # fails near ε = 1e-5 only: binary64 and binary32 would pass a sampled check
    lo, hi = o.decisions[0].fails_on[0]
    assert 3.1e-6 < lo < 3.3e-6 and hi == pytest.approx(1e-5)
    assert o.decisions[0].at64[0] > 0 and o.decisions[0].at32[0] > 0
    # the verifier also accepts the instrumented run itself
    rep_i = verify(2, runs={"edge_vertex": ins})
    assert [o.id for o in rep_i.failures] == ["2D.edge_vertex.window.tau[d]"]


def _edge_edge_variant(extra_rounding: bool, sign_test: bool = False):
    @predicate(dim=3, points="ABPQ", weights=("a", "b"), algorithm=9)
    def edge_edge(ctx, A, B, P, Q, tol):
        u = sub(B, A)
        v = sub(Q, P)
        r = cross3(u, v)
        m2 = ctx.name("m2", dot(r, r))
        if ctx.reject(m2 <= tol.lam, line=9):
            return ctx.miss()
        w = sub(P, A)
        d_hat = ctx.name("d_hat", dot(r, w))
        d_hat2 = ctx.name("d_hat2", d_hat * d_hat)
        if ctx.reject(d_hat2 > (tol.gamma * tol.gamma) * m2, line=14):
            return ctx.miss()
        n = cross3(r, w)
        a_hat = ctx.name("a_hat", dot(n, v))
        b_hat = ctx.name("b_hat", dot(n, u))
        # one more rounding: ×3 (×1 or ×2^k would be exact: rules S/SD)
        a_bar = ctx.name("a_bar", m2 - ((a_hat * ctx.const(3)) * ctx.const(Fraction(1, 3))
                                        if extra_rounding else a_hat))
        b_bar = ctx.name("b_bar", m2 - b_hat)
        phi = tol.phi
        conds = [a_hat <= phi, b_hat <= phi, a_bar <= phi, b_bar <= phi]
        if sign_test:
            conds.append(ctx.same_sign(d_hat, a_hat))  # a sign test nothing protects
        if ctx.reject(ctx.any(*conds), line=22):
            return ctx.miss()
        return ctx.hit((a_hat / m2, b_hat / m2))
    return edge_edge


def test_variant_3d_edge_edge_one_more_rounding_breaks_phi_window():
    rep = verify(3, runs=[_edge_edge_variant(True)])
    assert [o.id for o in rep.failures] == ["3D.edge_edge.window.phi[a_bar]"]
    assert rep.failures[0].decisions[0].fails_on[0][0] == 0.0  # fails for every ε
    same = verify(3, runs=[_edge_edge_variant(False)])
    assert same.ok


def test_unprotected_sign_test_is_reported():
    rep = verify(3, runs=[_edge_edge_variant(False, sign_test=True)])
    ids = [o.id for o in rep.failures]
    assert "3D.edge_edge.sign[d_hat]" in ids
    assert "unprotected" in rep.by_id("3D.edge_edge.sign[d_hat]").reason


def test_invalid_bound_is_a_failure():
    @predicate(dim=2, points="ABP", weights=("a",), algorithm=3)
    def edge_vertex(ctx, A, B, P, tol):
        u_hat = sub(B, A)
        m = ctx.name("m", ctx.sqrt(dot(u_hat, u_hat)))
        if ctx.reject(m <= tol.sigma_hat, line=7):
            return ctx.miss()
        w = sub(P, A)
        # a divisor without relative error and bounded below by no check (m would be:
        # rule GL)
        d = ctx.name("d", abs(cross2(u_hat, w) / dot(u_hat, w)))
        if ctx.reject(d > tol.tau, line=12):
            return ctx.miss()
        return ctx.hit((m,))
    rep = verify(2, runs=[edge_vertex])
    o = rep.by_id("2D.edge_vertex.window.tau[d]")
    assert not o.holds and "no error bound" in o.reason
    # the declared sign protections have nothing to protect; m is still checked
    assert rep.by_id("2D.edge_vertex.nonzero[m]").holds


# -- the decision procedure -----------------------------------------------------------------

SAMPLES = [R(1, 2**53), R(1, 2**24), R(1, 2**17), R(1, 10**5), R(1, 10**6), R(1, 10**7),
           R(1, 10**8), R(3, 10**6), R(7, 10**6)]


def _holds_at_samples(lhs, rhs):
    return all((lhs - rhs).subs({eps: e, L: 1}) > 0 for e in SAMPLES)


def test_decide_rejects_false_inequality_that_holds_at_samples():
    lhs, rhs = (eps - R(5, 10**6)) ** 2, R(1, 10**14)  # fails on (4.9e-6, 5.1e-6)
    assert _holds_at_samples(lhs, rhs)
    d = D.decide(lhs, rhs)
    assert not d.holds
    (lo, hi), = d.fails_on
    assert lo == pytest.approx(4.9e-6, rel=1e-6) and hi == pytest.approx(5.1e-6, rel=1e-6)
    assert lo < d.witness < hi


def test_decide_rejects_root_between_samples_with_radicals():
    # (√3 s − 1/20)(√2 s − 1/25) + 1e-7 with s = ε^(1/4): negative on a sliver near 6.7e-7
    s = eps ** R(1, 4)
    e = (sympy.sqrt(3) * s - R(1, 20)) * (sympy.sqrt(2) * s - R(1, 25)) + R(1, 10**7)
    assert _holds_at_samples(e, 0)
    d = D.decide(e, 0)
    assert not d.holds and 6.4e-7 < d.fails_on[0][0] < d.fails_on[0][1] < 6.9e-7
    # and proves the true variant (+1e-5) although dominance alone does not
    d2 = D.decide(e - R(1, 10**7) + R(1, 10**5), 0)
    assert d2.holds and "root isolation" in d2.method


def test_decide_proves_and_refutes_at_the_range_end():
    s = eps ** R(1, 4)
    assert D.decide(5 * s**3, 100 * eps).fails_on[0][0] == pytest.approx(6.25e-6)
    assert D.decide(5 * s**3, 88 * eps).holds  # 88·ε^(1/4) < 5 on the whole range
    assert not D.decide(eps, sympy.sqrt(eps)).holds
    assert not D.decide(2 * eps, 2 * eps).holds
    assert D.decide(2 * eps, 2 * eps, strict=False).holds


def test_decide_refuses_inhomogeneous_in_L():
    with pytest.raises(D.NotHomogeneous):
        D.decide(L * eps, L**2 * eps)


def test_interval_evaluation_is_an_enclosure():
    import mpmath
    x = D.interval(sympy.sqrt(910) * D.s, {D.s: (D.S_LO, D.S_HI)})
    with mpmath.workdps(80):
        exact = mpmath.sqrt(910) * mpmath.mpf(10) ** mpmath.mpf(-1.25)
        assert x.a <= exact <= x.b and x.b - x.a < mpmath.mpf(10) ** -40
    assert D.S_LO**4 <= R(1, 10**5) <= D.S_HI**4


# -- CLI, report, separation of printed figures ---------------------------------------------

def test_cli_passes_both_dims(capsys):
    assert fperr_main(["verify", "--dim", "2"]) == 0
    out = capsys.readouterr().out
    assert "2D: 30 constraints, 30 hold, 0 fail" in out  # 21 + 9 divisors, numerators (rule GL)
    assert fperr_main(["verify", "--dim", "3"]) == 0
    assert "0 fail" in capsys.readouterr().out


def test_report_is_up_to_date():
    from proofs.report import render
    committed = (ROOT / "docs" / "error-bounds.md").read_text(encoding="utf-8")
    assert render() == committed, "docs/error-bounds.md is stale: run python -m proofs.report"


def test_verifier_never_reads_the_paper_printed_figures():
    code = ("import sys, proofs.verify, proofs.constraints, proofs.decide, proofs.tables;"
            "proofs.verify.verify(2);"
            "assert 'proofs.paper_printed' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)


def _fperr_subprocess(args, cwd, module="proofs.cli"):
    import os
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_library_modules_of_proofs_do_not_use_argparse():
    """Argument parsing lives in the proofs.cli package only (issue 9, item 5)."""
    sources = [p for p in (ROOT / "proofs").rglob("*.py") if "cli" not in p.parts]
    assert len(sources) > 10
    for p in sources:
        assert "argparse" not in p.read_text(encoding="utf-8"), p
    code = ("import sys, proofs.verify, proofs.report, proofs.audit, proofs.constraints;"
            "assert 'argparse' not in sys.modules, 'argparse imported'")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)


def test_verify_report_writes_relative_to_the_current_directory(tmp_path):
    # no docs/ here: an argparse error before the constraints are decided
    r = _fperr_subprocess(["verify", "--dim", "2", "--report"], tmp_path)
    assert r.returncode == 2 and "argument --report: directory docs does not exist" in r.stderr
    assert r.stdout == "" and list(tmp_path.iterdir()) == []
    (tmp_path / "docs").mkdir()
    r = _fperr_subprocess(["verify", "--dim", "2", "--report"], tmp_path)
    assert r.returncode == 0, r.stderr
    written = (tmp_path / "docs" / "error-bounds.md").read_text(encoding="utf-8")
    assert written == (ROOT / "docs" / "error-bounds.md").read_text(encoding="utf-8")
    r = _fperr_subprocess(["--check"], tmp_path, module="proofs.report")
    assert r.returncode == 0 and "up to date" in r.stdout
    (tmp_path / "docs" / "error-bounds.md").write_text("stale\n", encoding="utf-8")
    r = _fperr_subprocess(["--check"], tmp_path, module="proofs.report")
    assert r.returncode == 1 and "is stale" in r.stderr


def test_report_bad_output_is_an_argument_error(tmp_path):
    r = _fperr_subprocess(["-o", str(tmp_path / "missing" / "x.md")], tmp_path,
                          module="proofs.report")
    assert r.returncode == 2 and "does not exist" in r.stderr
    assert list(tmp_path.iterdir()) == []
