"""Users' own predicates and tolerances (issue 14, part 3): the worked example of
docs/custom-predicates.md (docs/examples/incircle2d.py) verifies through ``fperr verify
--predicates``, its synthesized table is current and verifies, a broken table fails and
names its constraints (CLI and the pytest helper), the generated constraints are the
paper's generator's, and the tolerance model they prove holds against exact arithmetic."""
from __future__ import annotations

import json
import math
import os
import pathlib
import random
import re
import subprocess
import sys
import textwrap
from fractions import Fraction

import pytest
import sympy

import fperr
from proofs.testing import assert_tolerances_hold
from proofs.user_predicates import DeclarationError, Fact, PredicateTolerances, load

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "docs" / "examples"
SYNTH = EXAMPLES / "incircle2d_synth.toml"
BROKEN = textwrap.dedent('''
    from incircle2d import FPERR_TOLERANCES as GOOD, incircle, orient2d
    from proofs.user_predicates import PredicateTolerances
    # omega's T+ (200) is below its T (300): no upper window for det <= omega
    FPERR_TOLERANCES = PredicateTolerances(
        dim=2, predicates=[orient2d, incircle],
        tolerances=dict(GOOD.base, omega=("150*eps*L^4", "300*eps*L^4", "200*eps*L^4")))
''')


@pytest.fixture(autouse=True)
def _examples_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))


def _cli(*args, extra=()):
    path = os.pathsep.join([str(ROOT), str(EXAMPLES), *map(str, extra)])
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": path}, capture_output=True,
                          text=True, timeout=300)


def _example():
    return load("incircle2d")[0]


# -- the worked example through the CLI ------------------------------------------------

def test_cli_verifies_the_example_text_and_json():
    r = _cli("verify", "--predicates", "incircle2d", "--quiet")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2D constraints (orient2d, incircle: the table declared in incircle2d)" in r.stdout
    assert "  pass  2D.incircle.window.omega[det]" in r.stdout
    assert "  pass  2D.incircle.geometric.omega+<=alpha-*power-" in r.stdout
    assert "2D: 7 constraints, 7 hold, 0 fail" in r.stdout
    j = _cli("verify", "--predicates", "incircle2d", "--format", "json", "--quiet")
    doc = json.loads(j.stdout)
    assert j.returncode == 0 and doc["ok"] and doc["dims"]["2"]["fail"] == 0
    assert {c["name"] for c in doc["dims"]["2"]["constraints"]} >= {
        "2D.orient2d.window.alpha[area2]", "2D.incircle.window.alpha[area2]"}


def test_broken_user_table_fails_and_names_its_constraints(tmp_path):
    (tmp_path / "broken_incircle.py").write_text(BROKEN)
    r = _cli("verify", "--predicates", "broken_incircle", "--quiet", extra=[tmp_path])
    assert r.returncode == 1, r.stdout + r.stderr
    assert "  FAIL  2D.tolerances.bracket.omega" in r.stdout
    assert "  FAIL  2D.incircle.window.omega[det]" in r.stdout
    assert ("2D FAILED: 2D.tolerances.bracket.omega, 2D.incircle.window.omega[det]"
            in r.stdout)
    # nothing to synthesize from: exit 1, naming the first failing constraint
    r = _cli("synthesize", "--predicates", "broken_incircle", extra=[tmp_path])
    assert r.returncode == 1 and "does not verify (2D.tolerances.bracket.omega)" in r.stderr
    # the same table as an override file of the example
    bad = tmp_path / "bad.toml"
    bad.write_text("[2.omega]\nhi = 200\n")
    r = _cli("verify", "--predicates", "incircle2d", "--tolerances", str(bad), "--quiet")
    assert r.returncode == 1 and "  FAIL  2D.incircle.window.omega[det]" in r.stdout


def _doc_commands():
    """(command, expected stdout lines, exit status) of the console blocks of the
    user-tolerances section of docs/custom-predicates.md."""
    text = (ROOT / "docs" / "custom-predicates.md").read_text()
    section = text.split("## Your own tolerances", 1)[1].split("\n## ", 1)[0]
    out = []
    for block in re.findall(r"```console\n(.*?)```", section, re.S):
        for chunk in re.split(r"^\$ ", block, flags=re.M)[1:]:
            cmd, *lines = chunk.rstrip("\n").split("\n")
            out.append((cmd, lines, 1 if any("FAILED" in x for x in lines) else 0))
    return out


_TIME = re.compile(r"\d+\.\d s\b")


@pytest.mark.parametrize("cmd, lines, status", _doc_commands(),
                         ids=[f"{i}-{c.split()[2]}" for i, (c, _, _) in
                              enumerate(_doc_commands())])
def test_doc_console_commands(cmd, lines, status, tmp_path):
    """Each command of the worked example runs as shown: the lines shown appear in
    order (timings aside), the exit status is 1 where the page shows a failure."""
    cmd, _, comment = cmd.partition("   # ")
    m = re.match(r"(\S+): (\[[^\]]+\]) (.*)", comment)
    if m:  # "# bad.toml: [2.omega] lo = 200": the file the command reads
        (tmp_path / m[1]).write_text(f"{m[2]}\n{m[3]}\n")
    words = cmd.split()
    assert words[:2] == ["PYTHONPATH=docs/examples", "fperr"], cmd
    args = [str(tmp_path / w) if m and w == m[1] else w for w in words[2:]]
    synth_out = None
    if "-o" in args:  # write the synthesized table beside, and compare with the cached one
        i = args.index("-o") + 1
        synth_out, args[i] = args[i], str(tmp_path / "synth.toml")
    r = _cli(*args, "--quiet") if args[0] == "verify" else _cli(*args)
    assert r.returncode == status, r.stdout + r.stderr
    got = [_TIME.sub("T", x) for x in r.stdout.splitlines()]
    want = [_TIME.sub("T", x.replace(synth_out or "\0", str(tmp_path / "synth.toml")))
            for x in lines if x != "..."]
    it = iter(got)
    missing = [x for x in want if not any(x == g for g in it)]
    assert not missing, "\n".join(missing) + "\n--- got:\n" + r.stdout
    if synth_out:
        from proofs.synthesize import table_section
        assert table_section((tmp_path / "synth.toml").read_text()) == \
            table_section((ROOT / synth_out).read_text()), "stale: regenerate " + synth_out


def test_synthesized_example_table_verifies_and_is_certified(tmp_path):
    cert = tmp_path / "c.json"
    r = _cli("verify", "--predicates", "incircle2d", "--tolerances", str(SYNTH), "--quiet",
             "--certificate", str(cert))
    assert r.returncode == 0 and "7 hold, 0 fail" in r.stdout, r.stdout + r.stderr
    c = subprocess.run([sys.executable, "-m", "proofs.check_certificate", str(cert)],
                       cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                       capture_output=True, text=True, timeout=300)
    assert c.returncode == 0 and "7 re-established" in c.stdout, c.stdout + c.stderr


def test_synthesized_table_is_smaller_and_keeps_its_fact_equality():
    decl = _example()
    tab = decl.with_table(str(SYNTH)).base
    for n, spec in tab.items():
        assert spec.mid <= decl.base[n].mid and spec.hi <= decl.base[n].hi, n
    assert tab["omega"].hi == tab["alpha"].lo * tab["power"].lo   # ω+ = α−·π−
    # ω's window is the derived E[det] + E[ω] = 128εL⁴ + O(ε²), to within 1 %
    assert 128 < tab["omega"].hi - tab["omega"].mid < Fraction(128 * 101, 100)


@pytest.mark.parametrize("args, message", [
    (("--predicates", "no_such_module_xyz"), "cannot import 'no_such_module_xyz'"),
    (("--predicates", "json"), "module json has no FPERR_TOLERANCES"),
    (("--predicates", "incircle2d", "--dim", "3"), "declares no 3D predicates"),
])
def test_cli_unusable_declaration_exits_2(args, message):
    r = _cli("verify", *args, "--quiet")
    assert r.returncode == 2 and message in r.stderr, r.stderr


# -- the pytest helper ---------------------------------------------------------------------

def test_helper_passes_on_the_example_and_its_synthesized_table():
    reps = assert_tolerances_hold("incircle2d")
    assert reps[2].ok and len(reps[2].outcomes) == 7
    assert assert_tolerances_hold("incircle2d", SYNTH)[2].ok


def test_helper_raises_naming_the_failing_constraint(tmp_path, monkeypatch):
    (tmp_path / "broken_incircle_h.py").write_text(BROKEN)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(AssertionError) as e:
        assert_tolerances_hold("broken_incircle_h")
    msg = str(e.value)
    assert msg.startswith("2 tolerance constraint(s) of broken_incircle_h fail")
    assert "2D.tolerances.bracket.omega" in msg and "2D.incircle.window.omega[det]" in msg
    with pytest.raises(AssertionError, match=r"2D\.incircle\.window\.omega\[det\]"):
        assert_tolerances_hold("incircle2d", {2: {"omega": {"lo": 200}}})


# -- the paper's generator and decision procedure, with the user's declarations ------------

def test_window_error_is_the_instrumented_checks_error():
    decl = _example()
    ins = decl.runs(decl.table())["incircle"]
    chk = next(c for c in ins.checks if c.line == 2)
    c = next(c for c in decl.constraints() if c.id == "2D.incircle.window.omega[det]")
    assert sympy.expand(c.info["error"] - chk.error()) == 0
    E_det = fperr.bounds(ins.quantities["det"]).E
    eps, L = fperr.symbols.eps, fperr.symbols.L
    assert sympy.expand(E_det).coeff(eps, 1) == 128 * L**4   # the doc's 129εL⁴ rounded down


SIGN = textwrap.dedent('''
    from predicates.core import predicate
    from predicates.vector import cross2, sub

    @predicate(dim=2, points="ABC")
    def ccw_sign(ctx, A, B, C, tol):
        """A sign test of the orientation, protected only by a declared bound."""
        a = ctx.name("area2", cross2(sub(B, A), sub(C, A)))
        if ctx.reject(a <= 0, line=1):
            return ctx.miss()
        return ctx.hit(())
''')


def _sign_decl(tmp_path, monkeypatch, **kw):
    (tmp_path / "sign_mod.py").write_text(SIGN)
    monkeypatch.syspath_prepend(str(tmp_path))
    import sign_mod
    return PredicateTolerances(2, [sign_mod.ccw_sign],
                               {"beta": ("8*sqrt(eps)*L^2", "9*sqrt(eps)*L^2",
                                         "10*sqrt(eps)*L^2")}, **kw)


def test_sign_test_needs_a_declared_bound(tmp_path, monkeypatch):
    rep = _sign_decl(tmp_path, monkeypatch).verify()
    bad = [o for o in rep.outcomes if not o.holds]
    assert [o.id for o in bad] == ["2D.ccw_sign.sign[area2]"]
    assert "unprotected sign test" in bad[0].reason
    # a declared lower bound |area2| > β− > E[area2] protects it (the paper's PROTECTED)
    rep = _sign_decl(tmp_path, monkeypatch,
                     protected={"ccw_sign": {"area2": ("beta_lo", "the caller's guarantee")}}
                     ).verify()
    assert rep.ok and rep.by_id("2D.ccw_sign.sign[area2]").holds
    # ... and a bound below the derived error 8εL² does not
    rep = _sign_decl(tmp_path, monkeypatch, protected={"ccw_sign": {"area2": "4*eps*L^2"}}
                     ).verify()
    assert not rep.by_id("2D.ccw_sign.sign[area2]").holds


@pytest.mark.parametrize("kw, message", [
    (dict(tolerances={"t": ("1*eps*L", "2*eps*L^2", "3*eps*L")}), "same eps^q·L^p"),
    (dict(tolerances={"t": ("eps^(1/3)*L",) * 3}), "denominator 1, 2 or 4"),
    (dict(tolerances={"t": ("eps*L^7",) * 3}), "power of L must be an integer from 1 to 6"),
    (dict(tolerances={"t": ("-eps*L", "eps*L", "2*eps*L")}), "constant c > 0"),
    (dict(tolerances={"t_hi": ("eps*L", "2*eps*L", "3*eps*L")}), "does not end in _lo/_hi"),
    (dict(facts=["t_hi <= 2*u_lo"]), "unknown symbol(s) u_lo"),
    (dict(facts=["t_lo = 2*t"]), "an equality fixes a T+"),
    (dict(order=("t", "z")), "order names unknown tolerances: z"),
])
def test_declaration_errors_name_the_problem(kw, message):
    from incircle2d import orient2d
    args = dict(tolerances={"t": ("1*eps*L", "2*eps*L", "3*eps*L")}) | kw
    with pytest.raises(DeclarationError) as e:
        PredicateTolerances(2, [orient2d], **args)
    assert message in str(e.value)


def test_fact_directions_and_strictness():
    from incircle2d import orient2d
    d = PredicateTolerances(2, [orient2d], {"alpha": ("eps*L^2", "2*eps*L^2", "3*eps*L^2")},
                            [Fact("alpha_hi < 3/2*alpha", key="up"), "2*alpha_lo >= alpha",
                             "alpha_hi = 3*alpha_lo"])
    by = {c.id.split(".")[-1]: c for c in d.constraints() if c.kind == "geometric"}
    assert by["up"].inequalities[0].strict
    assert not by["2*alpha_lo>=alpha"].inequalities[0].strict
    rep = d.verify()
    assert rep.by_id("2D.tolerances.geometric.2*alpha_lo>=alpha").holds  # 2T− = T: ≥ holds
    assert not rep.by_id("2D.tolerances.geometric.up").holds             # 3/2·T = T+: not <
    assert rep.by_id("2D.tolerances.geometric.alpha_hi=3*alpha_lo").holds
    assert by["alpha_hi=3*alpha_lo"].info["equality_holds"]


# -- the tolerance model the constraints prove, against exact arithmetic ------------------

def _exact(A, B, C, D):
    f = [tuple(Fraction(x) for x in p) for p in (A, B, C, D)]
    (ax, ay), (bx, by), (cx, cy), (dx, dy) = f
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    ad, bd, cd = (ax - dx, ay - dy), (bx - dx, by - dy), (cx - dx, cy - dy)
    cr = lambda u, v: u[0] * v[1] - u[1] * v[0]
    lift = lambda u: u[0] ** 2 + u[1] ** 2
    return area2, lift(ad) * cr(bd, cd) + lift(bd) * cr(cd, ad) + lift(cd) * cr(ad, bd)


def _near_configuration(rng: random.Random):
    """A, B, C in [-1, 1]² (|x| ≤ L/2 for L = 2), D within ~1e-9..1e-15 of their circle
    or C within ~1e-5..1e-8 of line AB: both checks near their thresholds."""
    A, B = [(rng.uniform(-1, 1), rng.uniform(-1, 1)) for _ in range(2)]
    t = rng.uniform(0.2, 0.8)
    off = rng.choice([rng.uniform(-1, 1) * 10 ** -rng.uniform(5, 8), rng.uniform(-0.5, 0.5)])
    n = (-(B[1] - A[1]), B[0] - A[0])
    C = tuple(A[i] + t * (B[i] - A[i]) + off * n[i] for i in range(2))
    if max(map(abs, C)) > 1:
        return None
    (ax, ay), (bx, by), (cx, cy) = A, B, C
    den = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(den) < 1e-3:
        return A, B, C, (rng.uniform(-1, 1), rng.uniform(-1, 1))
    ox = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)) / den
    oy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)) / den
    r = ((ax - ox) ** 2 + (ay - oy) ** 2) ** 0.5
    phi = rng.uniform(0, 2 * math.pi)
    s = r * (1 + rng.uniform(-1, 1) * 10 ** -rng.uniform(9, 15))
    D = (ox + s * math.cos(phi), oy + s * math.sin(phi))
    return None if max(map(abs, D)) > 1 else (A, B, C, D)


@pytest.mark.parametrize("table", [None, SYNTH], ids=["declared", "synthesized"])
def test_tolerance_model_holds_against_exact_arithmetic(table):
    """Section 3's model, which the verified windows guarantee: x ≤ T− ⇒ rejected,
    x > T+ ⇒ passes, for area2 vs α (line 1) and det vs ω (line 2), in binary64."""
    from incircle2d import incircle
    decl = _example() if table is None else _example().with_table(str(table))
    tol = decl.tolerances(2.0)
    Lf, e = Fraction(tol.L), Fraction(1, 2**53)
    spec = decl.base
    om = {f: Fraction(str(getattr(spec["omega"], f))) * e * Lf**4 for f in ("lo", "hi")}
    al2 = {f: Fraction(str(getattr(spec["alpha"], f) ** 2)) * e * Lf**4 for f in ("lo", "hi")}
    above = lambda a, f: a > 0 and a * a > al2[f]          # a > α± (α irrational: squares)
    rng, seen = random.Random(14), {"near_alpha": 0, "near_omega": 0, "hit": 0}
    for _ in range(3000):
        cfg = _near_configuration(rng)
        if cfg is None:
            continue
        area2, det = _exact(*cfg)
        hit, _ = incircle(*cfg, tol)
        if hit:   # passed both checks: x > T− for both
            assert above(area2, "lo") and det > om["lo"], cfg
        elif above(area2, "hi") and det > om["hi"]:
            pytest.fail(f"missed a configuration beyond both T+: {cfg}")
        seen["hit"] += bool(hit)
        seen["near_alpha"] += above(area2, "lo") != above(area2, "hi")
        seen["near_omega"] += om["lo"] < det <= om["hi"]
    assert seen["near_alpha"] > 0 and seen["near_omega"] > 0 and 0 < seen["hit"] < 3000, seen


def test_runtime_tolerances_are_the_exact_table_values():
    """T = root_k(C^k·ε^(qk))·L^p in each format (ω: q = 1, exact; α: q = 1/2, one
    correctly rounded square root), L rounded up to ⌊prec/4⌋ bits."""
    import numpy as np
    decl = _example()
    assert decl.degree() == 4
    for dtype, bits in ((np.float64, 53), (np.float32, 24)):
        tol = decl.tolerances(1.5, dtype)
        Lq, e = Fraction(float(tol.L)), Fraction(1, 2**bits)
        assert Lq >= Fraction(3, 2) and tol.omega.dtype == np.dtype(dtype)
        assert Fraction(float(tol.omega)) == 300 * e * Lq**4
        a = Fraction(float(tol.alpha)) / Lq**2   # ≈ 24·√ε, within half an ulp
        assert abs(a * a - 576 * e) <= 576 * e * Fraction(3, 2**bits)
    with pytest.raises(ArithmeticError, match="outside the safe range"):
        decl.tolerances(2.0**60, np.float32)      # L⁴ would overflow binary32


def test_overrides_for_another_dimension_are_not_ignored():
    with pytest.raises(DeclarationError, match="have no entries for the 2D declaration"):
        assert_tolerances_hold("incircle2d", {3: {"omega": {"lo": 1}}})
    with pytest.raises(DeclarationError, match="unknown 2D tolerance 'kappa'"):
        assert_tolerances_hold("incircle2d", {2: {"kappa": {"lo": 1}}})


DEGREE5 = '''
from predicates.core import predicate
from predicates.vector import sub, triple
from proofs.user_predicates import PredicateTolerances


@predicate(dim=3, points="ABCDE")
def inside_sphere(ctx, A, B, C, D, E, tol):
    a, b, c, d = sub(A, E), sub(B, E), sub(C, E), sub(D, E)
    la, lb, lc, ld = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2] for p in (a, b, c, d))
    det = ctx.name("det", (ld * triple(a, b, c) - lc * triple(a, b, d))
                   + (lb * triple(a, c, d) - la * triple(b, c, d)))
    if ctx.reject(det <= tol.omega, line=1):
        return ctx.miss()
    return ctx.hit(())


FPERR_TOLERANCES = PredicateTolerances(
    dim=3, predicates=[inside_sphere],
    tolerances={"omega": ("1100*eps*L^5", "MID*eps*L^5", "HI*eps*L^5")})
'''


@pytest.mark.parametrize("mid,hi,code,text", [(2300, 3500, 0, "2 hold, 0 fail"),
                                              (1500, 2000, 1, "window.omega[det]")])
def test_a_degree_5_tolerance_is_decided(tmp_path, mid, hi, code, text):
    """A tolerance-based insphere: its tolerance is of degree 5 in L (refused before);
    fperr verify decides its window (a too narrow one fails, naming it)."""
    (tmp_path / "insphere5.py").write_text(
        DEGREE5.replace("MID", str(mid)).replace("HI", str(hi)))
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{ROOT}"}
    r = subprocess.run([sys.executable, "-m", "fperr", "verify", "--predicates", "insphere5"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == code, r.stderr
    assert text in r.stdout + r.stderr
    if code == 0:  # and it runs natively: L rounded so that L^5 is exact
        import importlib.util

        spec = importlib.util.spec_from_file_location("insphere5", tmp_path / "insphere5.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        tol = mod.FPERR_TOLERANCES.tolerances(2.0)   # the points span 2 (rule K)
        pts = [(1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0), (-1.0, 0, 0)]
        assert mod.inside_sphere(*pts, (0.0, 0, 0), tol)[0]
        assert not mod.inside_sphere(*pts, (0.9, 0.9, 0.9), tol)[0]
