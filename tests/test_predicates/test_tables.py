"""`fperr tables` reproduces every "Floating point:" figure of sections 4 and 5.

The expectations below are typed in from the paper (it is the test oracle); the library
derives its figures by running each predicate instrumented.
"""
import json

import pytest

from predicates.tables import records, render
from proofs.cli import main

# (dim, algorithm, quantity, kind) -> coefficient, power; from the paper's
# "Floating point:" lines (sections 4.2-4.5, 5.2-5.7).
PAPER = {
    (2, "vertex_vertex", "d2", "R"): (5, 0), (2, "vertex_vertex", "d2", "E"): (9, 2),
    (2, "edge_vertex", "m", "R"): (4, 0), (2, "edge_vertex", "m", "E"): (5, 1),
    (2, "edge_vertex", "d", "E"): (19, 1), (2, "edge_vertex", "a_hat", "E"): (19, 1),
    (2, "edge_vertex", "a_bar", "E"): (26, 1),
    **{(2, "edge_edge", q, "E"): (9, 2) for q in ("a_P", "a_Q", "a_A", "a_B")},
    **{(2, "triangle_vertex", q, "E"): (9, 2) for q in ("a_A", "a_B", "a_C")},
    (3, "vertex_vertex", "d2", "R"): (6, 0), (3, "vertex_vertex", "d2", "E"): (16, 2),
    (3, "edge_vertex", "m", "R"): (4, 0), (3, "edge_vertex", "m", "E"): (7, 1),
    (3, "edge_vertex", "d2", "E"): (261, 2), (3, "edge_vertex", "a_hat", "E"): (31, 1),
    (3, "edge_vertex", "a_bar", "E"): (42, 1),
    (3, "edge_edge", "m2", "E"): (129, 4), (3, "edge_edge", "d_hat", "E"): (47, 3),
    (3, "edge_edge", "d_hat2", "E"): (589, 6), (3, "edge_edge", "a_hat", "E"): (129, 4),
    (3, "edge_edge", "b_hat", "E"): (129, 4), (3, "edge_edge", "a_bar", "E"): (281, 4),
    (3, "edge_edge", "b_bar", "E"): (281, 4), (3, "edge_edge", "m2", "M"): (12, 4),
    (3, "triangle_vertex", "m2", "E"): (129, 4), (3, "triangle_vertex", "d_hat", "E"): (47, 3),
    (3, "triangle_vertex", "a_hat", "E"): (445, 4),
    (3, "triangle_vertex", "b_hat", "E"): (129, 4),
    (3, "triangle_vertex", "c_hat", "E"): (129, 4),
    **{(3, "triangle_edge", q, "E"): (47, 3) for q in ("v_A", "v_B", "v_C", "v_P", "v_Q")},
    **{(3, "tetrahedron_vertex", q, "E"): (47, 3) for q in ("v_A", "v_B", "v_C", "v_D")},
}
# Figures 1 and 5: R[T] <= 4 eps for every tolerance.
TOLERANCES = {2: ("sigma", "tau", "sigma_hat", "kappa"),
              3: ("sigma", "tau", "delta", "gamma", "sigma_hat", "lam", "phi", "nu",
                  "zeta", "mu", "xi", "rho")}


@pytest.fixture(scope="module")
def derived():
    recs = json.loads(render(records(), "json"))
    table = {}
    for r in recs:
        key = (r["dim"], r["algorithm"], r["quantity"], r["kind"])
        assert key not in table, f"duplicate record {key}"
        table[key] = r
    return table


@pytest.mark.parametrize("key", sorted(PAPER), ids=lambda k: "-".join(map(str, k)))
def test_paper_floating_point_figure(derived, key):
    coef, power = PAPER[key]
    assert key in derived, f"no derived record for {key}"
    assert (derived[key]["coefficient"], derived[key]["power"]) == (coef, power)


@pytest.mark.parametrize("dim", (2, 3))
def test_tolerances_relative_error_within_four_eps(derived, dim):
    for name in TOLERANCES[dim]:
        r = derived[(dim, "tolerances", name, "R")]
        assert r["coefficient"] <= 4, (name, r)


def test_every_named_quantity_has_a_valid_bound(derived):
    """Every quantity in the JSON schema's list that an algorithm computes gets E."""
    for (dim, alg, q, kind) in PAPER:
        assert (dim, alg, q, "E") in derived


def test_json_record_schema(derived):
    rec = derived[(2, "edge_vertex", "a_hat", "E")]
    assert rec == {"dim": 2, "algorithm": "edge_vertex", "quantity": "a_hat", "kind": "E",
                   "coefficient": 19, "power": 1, "exact": rec["exact"]}
    assert "eps" in rec["exact"]


@pytest.mark.parametrize("fmt", ("md", "latex", "json"))
def test_cli_formats(capsys, fmt):
    assert main(["tables", "--dim", "2", "--format", fmt]) == 0
    out = capsys.readouterr().out
    assert ("19" in out) and ("a_hat" in out or r"\hat{a}" in out)


def test_notation_is_shared_by_tables_and_report():
    """L^p, ε^q and the Greek names are spelled once (fperr.notation)."""
    import sympy

    import predicates.tables as T
    import proofs.report as R
    from fperr import notation as N
    assert (N.lpow(0), N.lpow(1), N.lpow(4), N.lpow(sympy.Rational(3, 2))) == \
        ("", "L", "L⁴", "L^(3/2)")
    assert (N.lpow(2, superscript=False), N.lpow(1.5, superscript=False)) == ("L^2", "L^1.5")
    assert (N.epow(1), N.epow(sympy.Rational(1, 2)), N.epow(sympy.Rational(3, 4))) == \
        ("ε", "√ε", "ε^(3/4)")
    assert N.greek("lam", "hi") == "λ+" and N.greek("sigma_hat", "lo") == "σ̂−"
    assert R.lpow is N.lpow and R.epow is N.epow and R.GREEK is N.GREEK
    assert T.LATEX_GREEK is N.LATEX_GREEK and T._latex_name("lam") == r"\lambda"


def test_latex_names_and_expressions(capsys):
    """Quantities named with a trailing 2 are squares (d2 = d², m2 = m², d_hat2 = d̂²), and
    the exact column is the LaTeX of the record's expression read as data (not sympified)."""
    import sympy

    from predicates.coefficients import CoefficientError
    from predicates.tables import _latex_expr, _latex_name
    assert (_latex_name("d2"), _latex_name("m2"), _latex_name("d_hat2")) == \
        ("{d}^{2}", "{m}^{2}", r"{\hat{d}}^{2}")
    assert main(["tables", "--format", "latex"]) == 0
    rows = [line.split(" & ") for line in capsys.readouterr().out.splitlines() if " & " in line]
    names = {r[2] for r in rows[1:]}
    assert not {"$d2$", "$m2$", "$d_{hat2}$"} & names and "${d}^{2}$" in names
    recs = {(r["dim"], r["algorithm"], r["quantity"], r["kind"]): r for r in records()}
    exact = recs[(2, "vertex_vertex", "d2", "E")]["exact"]
    eps, L = sympy.symbols("eps L", positive=True)
    assert _latex_expr(exact) == sympy.latex(sympy.sympify(exact, locals={"eps": eps, "L": L}),
                                             symbol_names={eps: r"\epsilon"})
    with pytest.raises(CoefficientError):
        _latex_expr('__import__("os").getcwd()')
