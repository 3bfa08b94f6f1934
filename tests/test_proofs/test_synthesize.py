"""fperr synthesize (issue 14, part 1): the cached synthesized tables verify (through
`fperr verify --tolerances` by subprocess and the certificate checker), are tight (each
free coefficient lowered by 1 %, or T to the next grid value, fails: the staleness
check CI can afford), run through predicates.tolerances / intersect / fperr intersect,
and pass the exact-consistency oracle; the 2D search is re-run and must reproduce the
cached table (the 3D search, minutes long, is `fperr synthesize --dim 3 --check`)."""
from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from proofs import tables
from proofs.synthesize import (ORDER, _Probe, _fact_equalities, _frac, admissible_mid,
                               table_section)
from proofs.tables import TABLES
from shared_cases import check_exact

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "proofs" / "data"
SYNTH = {2: DATA / "synth_2d.toml", 3: DATA / "synth_3d.toml"}
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def _cli(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "proofs.cli", *args], cwd=ROOT, env=ENV,
                          capture_output=True, text=True, timeout=timeout)


def _table(dim):
    return tables.load_overrides(SYNTH[dim])


# -- the grid of admissible T ------------------------------------------------------------------
def _nearest_on_grid(k, c):
    """Brute force over every a·2^j in [c/2, 2c] with a odd, a^k < 2^17: the least ≥ c and
    the greatest ≤ c. Integers throughout (x = n/d against c = p/q by n·q against p·d):
    the grid for k = 1 has ~131 k members in that range."""
    import math
    p, q = c.numerator, c.denominator
    up = down = None  # (n, d) pairs
    a, fc = 1, float(c)
    while a**k < 2**17:
        j0 = math.floor(math.log2(fc / (2 * a)))  # ±1 off at worst: the range covers it
        for j in range(j0 - 1, j0 + 5):
            n, d = (a << j, 1) if j >= 0 else (a, 1 << -j)
            if not (p * d <= 2 * n * q and n * q <= 2 * p * d):  # outside [c/2, 2c]
                continue
            if n * q >= p * d and (up is None or n * up[1] < up[0] * d):
                up = (n, d)
            if n * q <= p * d and (down is None or n * down[1] > down[0] * d):
                down = (n, d)
        a += 2
    return Fraction(*up), Fraction(*down)


@pytest.mark.parametrize("k", [1, 2, 4])
def test_admissible_mid_is_the_nearest_grid_value(k):
    rng = random.Random(k)
    for _ in range(40 if k > 1 else 5):
        c = Fraction(rng.randrange(1, 10**6), rng.randrange(1, 10**4))
        up, down = admissible_mid(c, k), admissible_mid(c, k, up=False)
        assert (up, down) == _nearest_on_grid(k, c)


def test_paper_mids_are_admissible():
    for dim in (2, 3):
        for spec in TABLES[dim].values():
            m = _frac(spec.mid)
            assert admissible_mid(m, int(spec.q.q)) == m, spec.name


# -- the cached tables verify --------------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_synthesized_table_verifies_and_is_certified(dim, tmp_path):
    cert = tmp_path / f"cert{dim}.json"
    r = _cli("verify", "--dim", str(dim), "--tolerances", str(SYNTH[dim]),
             "--certificate", str(cert))
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr
    assert f"{dim}D: " in r.stdout and " 0 fail" in r.stdout
    c = subprocess.run([sys.executable, "-m", "proofs.check_certificate", str(cert)],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=300)
    assert c.returncode == 0, c.stdout[-2000:]
    data = json.loads(cert.read_text())
    spec = data["dims"][0]["tolerances"]
    assert set(spec) == set(TABLES[dim])


@pytest.mark.parametrize("dim", [2, 3])
def test_synthesized_sigma_and_tau_are_below_the_paper(dim):
    tab = tables.table(dim, _table(dim))
    for n in ("sigma", "tau"):
        for f in ("lo", "mid", "hi"):
            assert getattr(tab[n], f) <= getattr(TABLES[dim][n], f), (n, f)
    assert tab["sigma"].mid < TABLES[dim]["sigma"].mid


def _tightness_failures(dim, names):
    """Coefficients of ``names`` that can be lowered (hi by 1 %; mid to the grid value
    at or below 99 % of it) or raised (lo by 1 %, towards T) and still verify."""
    probe = _Probe(dim)
    base = {n: {f: v for f, v in d.items()} for n, d in _table(dim)[dim].items()}
    fixed = _fact_equalities(dim, base)
    loose = []
    for n in names:
        k = int(TABLES[dim][n].q.q)
        cur = {f: _frac(base[n][f]) for f in ("lo", "mid")}
        trials = {"lo up": cur["lo"] * Fraction(101, 100),
                  "mid down": admissible_mid(cur["mid"] * Fraction(99, 100), k, False)}
        if n not in fixed:  # a T+ fixed by a fact equality is deliberately not minimal
            trials["hi down"] = _frac(base[n]["hi"]) * Fraction(99, 100)
        for what, x in trials.items():
            f = what.split()[0]
            trial = {m: dict(d) for m, d in base.items()}
            trial[n][f] = str(x)
            if probe({m: {g: tables._coefficient(v, "t") for g, v in d.items()}
                      for m, d in trial.items()}):
                loose.append(f"{n}.{what}")
    return loose


def test_2d_table_is_tight():
    """The staleness check: a table the current rules would make smaller fails here."""
    assert _tightness_failures(2, ORDER[2]) == []


def test_3d_table_is_tight_in_sigma_and_tau():
    assert _tightness_failures(3, ("sigma", "tau")) == []


def test_2d_fact_equalities_hold_in_the_table():
    base = _table(2)[2]
    eq = _fact_equalities(2, base)
    assert eq["kappa"] == base["kappa"]["hi"] == 2 * base["tau"]["lo"] ** 2
    assert eq["sigma_hat"] == base["sigma_hat"]["hi"] == base["sigma"]["lo"]


# the cached 2D table's staleness check (a fresh synthesis, --check) runs once, with its
# JSON output: tests/test_proofs/test_cli_contract.py::test_synthesize_json_is_read_by_verify…


def test_table_section_detects_a_changed_coefficient():
    text = SYNTH[2].read_text()
    assert table_section(text) == table_section("# other header\n" + text)
    mid = text[text.index('mid = "'):text.index('"', text.index('mid = "') + 7) + 1]
    assert table_section(text) != table_section(text.replace(mid, 'mid = "1/3"', 1))


# -- running with the table ----------------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_tolerances_with_table_are_the_table_values(dim):
    tab = _table(dim)
    tol = predicates.tolerances(dim, 0.75, 0.5, table=tab)
    mpmath.mp.prec = 200
    L = mpmath.mpf(float(tol.L))  # exact: a binary64 value
    eps = mpmath.mpf(2) ** -53
    for n, spec in tables.table(dim, tab).items():
        exact = (mpmath.mpf(spec.mid.p) / spec.mid.q * eps ** (mpmath.mpf(spec.q.p) / spec.q.q)
                 * L ** spec.p)
        assert abs(mpmath.mpf(float(tol.values[n])) / exact - 1) < 4 * eps, n
        assert tol.spec(n) == spec


def test_inadmissible_mid_is_refused_in_float32():
    with pytest.raises(ValueError, match="not admissible"):
        predicates.tolerances(3, 1.0, 1.0, dtype=np.float32,
                              table={3: {"sigma": {"mid": "8191/1024"}}})
    with pytest.raises(ValueError, match="unknown 2D tolerance"):
        predicates.tolerances(2, 1.0, 1.0, table={"sigmaa": {"mid": 6}})


CASES = {2: [("circle", 6, {"segments": 24}), ("zigzag", 8, {"dx": 2, "dy": 6}),
             ("diagonal", 6, {"step": 3})],
         3: [("sphere", 3, {"subdivisions": 1}), ("plane", 3, {}), ("plane_offset", 4, {"k": 1})]}


@pytest.mark.parametrize("dim,case", [(d, c) for d in (2, 3) for c in CASES[d]],
                         ids=lambda x: x if isinstance(x, int) else x[0])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_oracle_with_synthesized_table(dim, case, dtype):
    from shared_cases import transformed
    name, n, kw = case
    ex = example(name, n, **kw)
    res = predicates.intersect(*ex["sim"], *ex["cut"], dtype=dtype, tolerances=_table(dim))
    assert res.tolerances.table is not None
    assert check_exact(res)["registered"] == res.total
    rng = np.random.default_rng([dim, n])
    args = transformed(ex, rng, (0.1, 2.0), 1.0)  # pairs straddling the tolerances
    check_exact(predicates.intersect(*args, tolerances=_table(dim)))


def test_cli_intersect_with_tolerances(tmp_path):
    import meshio
    ex = example("zigzag", 8, dx=2, dy=6)
    sim, cut = tmp_path / "sim.vtu", tmp_path / "cut.vtu"
    meshio.Mesh(ex["sim"][0], [("triangle", ex["sim"][1])]).write(sim)
    meshio.Mesh(ex["cut"][0], [("line", ex["cut"][1])]).write(cut)
    want = predicates.intersect(*ex["sim"], *ex["cut"], tolerances=_table(2))
    r = _cli("intersect", str(sim), str(cut), "--quiet", "--tolerances", str(SYNTH[2]))
    assert r.returncode == 0, r.stderr
    for kind, count in want.counts.items():
        assert f"{kind}" in r.stdout
    sigma = want.tolerances_input_units()["sigma"]
    assert f"{sigma:.3g}" in r.stdout or f"{sigma:.4g}" in r.stdout
    bad = tmp_path / "bad.toml"
    bad.write_text('[2.sigmaa]\nmid = 6\n')
    r = _cli("intersect", str(sim), str(cut), "--quiet", "--tolerances", str(bad))
    assert r.returncode == 2 and "sigmaa" in r.stderr
