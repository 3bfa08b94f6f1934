"""Tolerance tables are data (predicates/coefficients.py): coefficient strings are read by a
small bounded grammar into exact values, never evaluated as Python. References are
independent: Fractions computed from the expression trees the tests build, and sympy's
value of the known-good strings of the shipped tables."""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
import time
from fractions import Fraction

import meshio
import numpy as np
import pytest
import sympy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import predicates
from predicates import coefficients as C
from predicates.registration.examples import example
from proofs import tables
from proofs.synthesize import to_toml

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
SHIPPED = sorted((ROOT / "proofs" / "data").glob("*.toml")) + \
    sorted((ROOT / "docs" / "examples").glob("*.toml"))


def _value(text):
    return C.value(C.parse(text))


def _same(x: C.Monomial, reference: sympy.Expr) -> bool:
    return sympy.simplify(C.to_sympy(x) - reference) == 0


# -- exact values -------------------------------------------------------------------------
@pytest.mark.parametrize("text, ref", [
    ("269/64", Fraction(269, 64)), ("9.5", Fraction(19, 2)), ("0.1", Fraction(1, 10)),
    ("2*(7/2)^2", Fraction(49, 2)), ("2*(7/2)**2", Fraction(49, 2)), ("1e-3", Fraction(1, 1000)),
    ("-3 + 10/4", Fraction(-1, 2)), ("(1/2)^0", Fraction(1)), ("sqrt(9/4)", Fraction(3, 2)),
    ("sqrt(3)*sqrt(12)", Fraction(6)), ("2^3^2", Fraction(2) ** 9), ("1 - -1", Fraction(2)),
])
def test_rational_values_are_exact(text, ref):
    assert _value(text).fraction() == ref


def test_radicals_and_monomials():
    x = _value("31085883*sqrt(3)/16384")
    assert (x.c, x.m, x.is_constant) == (Fraction(31085883, 16384), 3, True)
    assert _value("sqrt(2) + sqrt(8)") == _value("3*sqrt(2)") == _value("sqrt(18)")
    t = _value("24*sqrt(eps)*L^2")
    assert (t.c, t.m, t.q, t.p) == (24, 1, Fraction(1, 2), 2)
    assert _value("eps^(3/4)*L**3") == C.Monomial(Fraction(1), 1, Fraction(3, 4), Fraction(3))


@pytest.mark.parametrize("text, problem", [
    ("__import__(\"os\").system(\"touch x\")", "unexpected character"),
    ("__import__", "unknown name"), ("9**9**9**9", "exponent"), ("2^-1", "exponent"),
    ("2^(1/3)", "exponent"), ("1" * 61, "digits"), ("(" * 41 + "1" + ")" * 41, "nested"),
    ("-" * 50 + "1", "nested"), ("1+" * 400 + "1", "tokens"), ("1" + " " * 2000, "longer"),
    ("(10^60)^64", "bits"), ("1e99", "decimal exponent"), ("1/0", "division by zero"),
    ("sqrt(-2)", "negative"), ("sqrt(sqrt(2))", "irrational"), ("1 + sqrt(2)", "unlike"),
    ("eps + 1", "unlike"), ("", "empty"), ("1 2", "unexpected"), ("(1", "end"),
    ("sqrt(1, 2)", "argument"), ("min(1, 2)", "not allowed"), ("x.y", "unexpected character"),
])
def test_refusals_name_the_problem(text, problem):
    t0 = time.perf_counter()
    with pytest.raises(C.CoefficientError, match=problem):
        _value(text)
    assert time.perf_counter() - t0 < 1.0


# -- round trip: every table the project ships or writes ---------------------------------
def _strings(path):
    import tomllib
    data = tomllib.loads(path.read_text())
    return [(d, n, f, v) for d, tabs in data.items() for n, fs in tabs.items()
            for f, v in fs.items()]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_tables_read_as_sympy_reads_them(path):
    assert SHIPPED, "no shipped tables found"
    entries = _strings(path)
    assert entries
    known = {int(d): {n for _, n, _, _ in entries} for d, _, _, _ in entries}  # (users' names)
    loaded = tables.load_overrides(path, known)
    for d, n, f, v in entries:
        ref = sympy.sympify(v, rational=True)  # the known-good strings: fine in a test
        assert _same(_value(v), ref), (n, f, v)
        assert loaded[int(d)][n][f] == ref, (n, f, v)


@pytest.mark.parametrize("dim", [2, 3])
def test_figures_and_synthesize_output_round_trip(dim, tmp_path):
    """What ``fperr synthesize`` writes (to_toml, sympy's printed form) for Figures 1/5
    and for synthesized values of both kinds (rational, rational·√3) reads back equal."""
    class R:  # the fields to_toml reads of a Synthesis
        pass
    r = R()
    r.dim = dim
    r.coefficients = {n: {f: getattr(s, f) for f in ("lo", "mid", "hi")}
                      for n, s in tables.TABLES[dim].items()}
    r.coefficients["tau"]["hi"] = sympy.Rational(631769035921, 268435456) * sympy.sqrt(3)
    path = tmp_path / "t.toml"
    path.write_text(to_toml([r]))
    loaded = tables.load_overrides(path)[dim]
    for n, fields in r.coefficients.items():
        for f, v in fields.items():
            assert loaded[n][f] == v, (n, f)
    tol = predicates.tolerances(dim, 1.0, 1.0, table=tables.load_overrides(path))
    for n, spec in tables.TABLES[dim].items():
        assert tol.spec(n).mid == spec.mid and tol.spec(n).q == spec.q


# -- fuzz: trees with an independent Fraction reference ------------------------------------
# A tree is (text, value); value is None when some sub-expression divides by zero or
# exceeds C.MAX_BITS (the parser must then refuse), computed here without the parser.
def _bits(x: Fraction) -> int:
    return max(x.numerator.bit_length(), x.denominator.bit_length())


def _checked(x):
    return None if x is None or _bits(x) > C.MAX_BITS else x


def _trees():
    leaf = st.one_of(st.integers(0, 10**6).map(lambda k: (str(k), Fraction(k))),
                     st.fractions(0, 100, max_denominator=64).map(
                         lambda q: (f"({q.numerator}/{q.denominator})", q)))

    def extend(sub):
        bin_op = st.tuples(sub, st.sampled_from("+-*/"), sub)
        power = st.tuples(sub, st.sampled_from(["^", "**"]), st.integers(0, 4))
        neg = sub.map(lambda t: (f"-({t[0]})", None if t[1] is None else -t[1]))
        return st.one_of(bin_op.map(_binary), power.map(_power), neg)
    return st.recursive(leaf, extend, max_leaves=12)


def _binary(t):
    (a, x), op, (b, y) = t
    text = f"({a}){op}({b})"
    if x is None or y is None or (op == "/" and y == 0):
        return text, None
    ops = {"+": Fraction.__add__, "-": Fraction.__sub__, "*": Fraction.__mul__,
           "/": Fraction.__truediv__}
    return text, _checked(ops[op](x, y))


def _power(t):
    (a, x), op, k = t
    text = f"({a}){op}{k}"
    if x is None or (x != 0 and (_bits(x) - 1) * k > C.MAX_BITS):
        return text, None  # (too large: not computed)
    return text, _checked(x ** k)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_trees())
def test_fuzz_trees_parse_to_their_exact_value_or_a_clear_refusal(tree):
    text, ref = tree
    try:
        got = _value(text)
    except C.CoefficientError as e:
        # refused: a division by zero or a value past the bound (ref None), or the
        # text's own bounds (length, tokens, nesting)
        assert ref is None or len(text) > C.MAX_LENGTH or \
            any(w in str(e) for w in ("tokens", "nested")), (text, e)
        return
    assert ref is not None and got.fraction() == ref, text


_ALPHABET = "0123456789.eE+-*/^()(), sqrtepsLminx_\"';[]\\\n\t#é"


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=_ALPHABET, max_size=80) | st.text(max_size=40))
def test_fuzz_random_text_is_a_value_or_a_clear_refusal(text):
    try:
        x = _value(text)
    except C.CoefficientError:
        return
    assert isinstance(x, C.Monomial) and x.c.denominator > 0


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=200) | st.text(alphabet=_ALPHABET, max_size=60).map(
    lambda s: f'[3.phi]\nmid = {json.dumps(s)}\n'.encode()))
def test_fuzz_table_files_load_or_are_refused_naming_the_file(tmp_path_factory, content):
    path = tmp_path_factory.mktemp("fuzz") / "t.toml"
    path.write_bytes(content)
    try:
        out = tables.load_overrides(path)
    except tables.ToleranceFileError as e:
        assert str(path) in str(e)
        return
    for fields in out.get(3, {}).values():
        for v in fields.values():
            assert v.is_positive and not v.free_symbols


# -- through the command line: refused with exit 2, nothing run, nothing written ----------
BAD = {
    "inject": '"__import__(\\"os\\").system(\\"touch {target}\\")"',
    "bomb": '"9**9**9**9"',
    "literal": '"' + "9" * 5000 + '"',
    "nesting": '"' + "(" * 5000 + "1" + ")" * 5000 + '"',
    "long": '"' + "1+" * 50000 + '1"',
}


def _fperr(*args, cwd):
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "fperr", *map(str, args)], cwd=cwd, env=ENV,
                       capture_output=True, text=True, timeout=120)
    return r, time.perf_counter() - t0


def _bad_table(tmp_path, kind, dim):
    target = tmp_path / "touched"
    path = tmp_path / f"{kind}.toml"
    name = "phi" if dim == 3 else "kappa"
    path.write_text(f"[{dim}.{name}]\nmid = {BAD[kind].format(target=target)}\n")
    return path, target, name


def _refused(r, elapsed, path, name, target):
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert str(path) in lines[0] and f"{name}.mid" in lines[0], lines[0]
    assert not target.exists()
    assert elapsed < 5.0, elapsed  # refused at once, no hang (interpreter start included)


@pytest.mark.parametrize("kind", sorted(BAD))
def test_verify_refuses_bad_tables(tmp_path, kind):
    path, target, name = _bad_table(tmp_path, kind, 3)
    r, elapsed = _fperr("verify", "--dim", "3", "--tolerances", path, cwd=tmp_path)
    _refused(r, elapsed, path, name, target)


@pytest.mark.parametrize("kind", sorted(BAD))
def test_intersect_refuses_bad_tables(tmp_path, kind):
    ex = example("circle", 4, segments=12)
    pad = (lambda p: np.column_stack([p, np.zeros(len(p))]))  # a 2D mesh in the plane z = 0
    meshio.Mesh(pad(ex["sim"][0]), [("triangle", ex["sim"][1])]).write(tmp_path / "sim.vtu")
    meshio.Mesh(pad(ex["cut"][0]), [("line", ex["cut"][1])]).write(tmp_path / "cut.vtu")
    path, target, name = _bad_table(tmp_path, kind, 2)
    out = tmp_path / "out.vtu"
    r, elapsed = _fperr("intersect", "sim.vtu", "cut.vtu", "-o", out, "--tolerances", path,
                        cwd=tmp_path)
    _refused(r, elapsed, path, name, target)
    assert not out.exists()


def test_library_refuses_bad_tables_without_running_them(tmp_path):
    target = tmp_path / "touched"
    for text in (f'__import__("os").system("touch {target}")', "9**9**9**9"):
        t0 = time.perf_counter()
        with pytest.raises(ValueError, match="kappa.mid"):
            predicates.tolerances(2, 1.0, 1.0, table={"kappa": {"mid": text}})
        assert time.perf_counter() - t0 < 1.0 and not target.exists()


# -- import predicates does not load sympy ---------------------------------------------------
def test_float_and_numpy_paths_do_not_load_sympy():
    code = """if True:
        import sys
        import numpy as np
        import predicates
        from predicates import d2, d3
        tol = predicates.tolerances(3, 1.0, 1.0, float)
        hit, w = d3.triangle_edge((0, 0, 0), (1, 0, 0), (0, 1, 0), (.2, .2, -1), (.2, .2, 1), tol)
        assert hit and abs(w[0] - 0.6) < 1e-15
        A, B, P, Q = (np.array([[0., 0.]]), np.array([[1., 1.]]), np.array([[0., 1.]]),
                      np.array([[1., 0.]]))
        hit, w = d2.edge_edge(A, B, P, Q, predicates.tolerances(2, 1.0, 1.0))
        assert hit.tolist() == [True] and w.tolist() == [[0.5, 0.5]]
        pts = np.array([[0, 0], [1, 0], [0, 1.]])
        res = predicates.intersect(pts, np.array([[0, 1, 2]]), np.array([[-1, .3], [2, .3]]),
                                   np.array([[0, 1]]))
        assert res.total > 0
        assert "sympy" not in sys.modules, "sympy was imported"
        import fperr.checks  # loads the submodule fperr.bounds: fperr.bounds stays the function
        import fperr
        x = fperr.coord("A.x") - fperr.coord("B.x")
        assert fperr.bounds(x).text() == "R ≤ 1ε, E ≤ 1εL" and "sympy" in sys.modules
        assert d3.triangle_edge.instrumented().quantities["v_A"] is not None
        print("ok")
    """
    r = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr
