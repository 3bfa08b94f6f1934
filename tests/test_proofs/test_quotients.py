"""Quotients and roots in users' predicates (docs/proofs.md "Quotients and roots",
docs/custom-predicates.md "A quotient"): a divisor bounded below by a passed check gets
a sound bound (checked here against exact rationals), a divisor nothing bounds fails
``fperr verify`` naming it (CLI, exit 1), scaling by 2^k is exact, tolerances of degree
≥ 5 work, and unsupported dims or a missing tolerance table are clear errors."""
from __future__ import annotations

import os
import pathlib
import random
import subprocess
import sys
import textwrap
from fractions import Fraction

import numpy as np
import pytest

import fperr
import predicates
from predicates.core import predicate
from predicates.vector import cross2, sub
from proofs.user_predicates import PredicateTolerances

ROOT = pathlib.Path(__file__).resolve().parents[2]

MODULE = textwrap.dedent('''
    from predicates.core import predicate
    from predicates.vector import cross2, sub
    from proofs.user_predicates import PredicateTolerances

    @predicate(dim=2, points="ABPQ", weights=("t",))
    def crossing(ctx, A, B, P, Q, tol):
        QP = sub(Q, P)
        oA = ctx.name("oA", cross2(sub(A, P), QP))
        oB = ctx.name("oB", cross2(sub(B, P), QP))
        if ctx.reject(ctx.any(abs(oA) <= tol.alpha, abs(oB) <= tol.alpha,
                              GUARD), line=1):
            return ctx.miss()
        return ctx.hit((oA / (oA - oB),))

    FPERR_TOLERANCES = PredicateTolerances(2, [crossing], {
        "alpha": ("20*sqrt(eps)*L^2", "24*sqrt(eps)*L^2", "28*sqrt(eps)*L^2")})
''')
ALPHA = {"alpha": ("20*sqrt(eps)*L^2", "24*sqrt(eps)*L^2", "28*sqrt(eps)*L^2")}


def _verify_cli(tmp_path, name, guard):
    (tmp_path / f"{name}.py").write_text(MODULE.replace("GUARD", guard))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}
    return subprocess.run([sys.executable, "-m", "proofs.cli", "verify", "--predicates",
                           name], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)


def test_cli_guarded_divisor_verifies_and_unguarded_fails_naming_it(tmp_path):
    ok = _verify_cli(tmp_path, "guarded_crossing", "ctx.same_sign(oA, oB)")
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "pass  2D.crossing.divisor[oA-oB]" in ok.stdout
    # differ_sign instead of same_sign: the signs of oA, oB are equal afterwards, so
    # |oA − oB| has no lower bound and may be 0
    bad = _verify_cli(tmp_path, "unguarded_crossing", "ctx.differ_sign(oA, oB)")
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "FAIL  2D.crossing.divisor[oA-oB]" in bad.stdout
    assert "unguarded divisor oA - oB of a returned weight" in bad.stdout


def _crossing():
    @predicate(dim=2, points="ABPQ", weights=("t",))
    def crossing(ctx, A, B, P, Q, tol):
        QP = sub(Q, P)
        oA = ctx.name("oA", cross2(sub(A, P), QP))
        oB = ctx.name("oB", cross2(sub(B, P), QP))
        if ctx.reject(ctx.any(abs(oA) <= tol.alpha, abs(oB) <= tol.alpha,
                              ctx.same_sign(oA, oB)), line=1):
            return ctx.miss()
        return ctx.hit((oA / (oA - oB),))
    return crossing


def _exact_t(A, B, P, Q):
    F = [tuple(Fraction(c) for c in X) for X in (A, B, P, Q)]
    A, B, P, Q = F
    QP = (Q[0] - P[0], Q[1] - P[1])
    oA = (A[0] - P[0]) * QP[1] - (A[1] - P[1]) * QP[0]
    oB = (B[0] - P[0]) * QP[1] - (B[1] - P[1]) * QP[0]
    return oA / (oA - oB)


@pytest.mark.parametrize("dtype, bits", [(float, 53), (np.float32, 24)])
def test_crossing_parameter_within_its_relative_bound(dtype, bits):
    """R[t] (rule GL, the floor of oA − oB through the rejected same_sign) bounds the
    computed t against the exact quotient of the same inputs, near-parallel ones too."""
    crossing = _crossing()
    decl = PredicateTolerances(2, [crossing], ALPHA)
    t = decl.runs(decl.table())["crossing"].weights[0]
    assert t.rule == "GL" and t.r
    R = Fraction(str(fperr.bounds(t).R_at(Fraction(1, 2**bits)).evalf(40)))
    tol = decl.tolerances(2.0, dtype if dtype is float else dtype)  # |x| ≤ 1: L = 2
    rng = random.Random(5)
    hits, worst = 0, Fraction(0)
    for i in range(3000):
        pts = [[rng.uniform(-1, 1) for _ in range(2)] for _ in range(4)]
        if i % 2:  # nearly parallel: B − A close to Q − P
            d = [pts[3][0] - pts[2][0], pts[3][1] - pts[2][1]]
            pts[1] = [pts[0][0] + d[0] * 0.5 + rng.uniform(-1e-6, 1e-6),
                      pts[0][1] + d[1] * 0.5 + rng.uniform(-1e-6, 1e-6)]
            if max(abs(c) for c in pts[1]) > 1:
                continue
        conv = (lambda p: tuple(float(np.float32(c)) for c in p)) if bits == 24 else tuple
        pts = [conv(p) for p in pts]
        args = [np.array(p, dtype=np.float32) for p in pts] if bits == 24 else pts
        hit, w = crossing(*args, tol)
        if not hit:
            continue
        hits += 1
        exact = _exact_t(*pts)
        rel = abs(Fraction(float(w[0])) - exact) / abs(exact)
        worst = max(worst, rel)
    assert hits > 500
    assert 0 < worst <= R, (float(worst), float(R))


def test_scaling_by_a_power_of_two_costs_no_rounding():
    x = [fperr.coord(f"x{i}") for i in range(4)]
    det = x[0] * x[1] - x[2] * x[3]
    for scaled, rule in ((det / 2, "SD"), (det * 0.5, "S"), (fperr.const(-4) * det, "S")):
        assert scaled.rule == rule
        assert scaled.state.a == det.state.a and scaled.state.b == det.state.b
    assert fperr.bounds(det / 2).E * 2 == fperr.bounds(det).E
    # a constant that is not a power of two is still a rounded product (rule F)
    assert (det * 3).rule == "F" and (det * 3).state.a == det.state.a + 1


def test_degree_5_tolerance_verifies_and_computes():
    @predicate(dim=2, points="ABC")
    def deg5(ctx, A, B, C, tol):
        u, v = sub(B, A), sub(C, A)
        q = ctx.name("q", cross2(u, v) * (u[0] * u[0] + u[1] * u[1]) * (v[0] - u[0]))
        if ctx.reject(q <= tol.beta, line=1):
            return ctx.miss()
        return ctx.hit(())
    decl = PredicateTolerances(2, [deg5], {"beta": ("100*eps*L^5", "200*eps*L^5",
                                                    "300*eps*L^5")})
    assert decl.degree() == 5
    q = decl.runs(decl.table())["deg5"].quantities["q"]
    assert fperr.bounds(q).E_int == 97 and fperr.bounds(q).power == 5
    assert decl.verify().ok
    tol = decl.tolerances(1.0)
    L = Fraction(float(tol.L))
    assert Fraction(float(tol.beta)) == 200 * Fraction(1, 2**53) * L**5


def test_unsupported_dim_and_missing_tolerance_are_clear_errors():
    with pytest.raises(ValueError, match=r"dim must be 2 or 3 .*got 4"):
        predicates.tracked_tolerances(4)

    with pytest.raises(ValueError, match=r"dim must be 2 or 3"):
        predicate(dim=4, points="AB")

    @predicate(dim=2, points="AB", weights=("d",))
    def own(ctx, A, B, tol):
        d = A[0] - B[0]
        if ctx.reject(abs(d) <= tol.omega, line=1):
            return ctx.miss()
        return ctx.hit((d,))
    with pytest.raises(ValueError) as e:
        own.instrumented()
    msg = str(e.value)
    assert "tolerance 'omega' is not in the paper's Figure 1" in msg
    assert "own.instrumented({'omega': ToleranceSpec(...)" in msg and "FPERR_TOLERANCES" in msg
    # with its table it runs, and its weight's bound is the rule E subtraction's
    decl = PredicateTolerances(2, [own], {"omega": ("eps*L", "2*eps*L", "3*eps*L")})
    ins = own.instrumented(decl.table())
    assert ins.weights[0].rule == "E"
