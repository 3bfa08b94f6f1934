"""Each erratum of docs/errata.md, shown with exact arithmetic or the derived bounds."""
import inspect
from fractions import Fraction

import pytest

import fperr
import predicates
from fperr import bounds, const, eps, exact_input, sqrt
from predicates import d2, d3
from predicates.core import predicate
from predicates.tolerance_table import L_SIGMA_PLUS, TABLES
from predicates.vector import cross2, dot, scale, sub


@predicate(dim=2, points="ABP", weights=("a",))
def _edge_vertex_as_printed(ctx, A, B, P, tol):
    """Algorithm 3 exactly as printed: û = A − B."""
    u_hat = sub(A, B)
    m = ctx.sqrt(dot(u_hat, u_hat))
    if ctx.reject(m <= tol.sigma_hat):
        return ctx.miss()
    u = scale(u_hat, 1 / m)
    w = sub(P, A)
    if ctx.reject(abs(cross2(u, w)) > tol.tau):
        return ctx.miss()
    a_hat = dot(u, w)
    a_bar = m - a_hat
    if ctx.reject(ctx.any(a_hat < 0, a_bar < 0)):
        return ctx.miss()
    return ctx.hit((a_hat / m,))


def test_E1_printed_sign_rejects_midpoint():
    tol = predicates.tolerances(2, 1.0, 0.0, float)
    A, B, P = (0.0, 0.0), (1.0, 0.0), (0.5, 0.0)
    assert _edge_vertex_as_printed(A, B, P, tol) == (False, (0.0,))
    assert d2.edge_vertex(A, B, P, tol) == (True, (0.5,))
    assert d3.edge_vertex((0.0, 0, 0), (1.0, 0, 0), (0.25, 0, 0),
                          predicates.tolerances(3, 1.0, 0.0, float)) == (True, (0.25,))


def test_E2_signatures():
    assert d2.edge_edge.points == tuple("ABPQ")
    assert d2.triangle_vertex.points == tuple("ABCP")
    with pytest.raises(TypeError, match="4 arguments|5 arguments"):
        d2.edge_edge((0, 0), (1, 0), (0, 1), predicates.tolerances(2, 1, 1, float))


def test_E3_sigma_plus_is_the_largest_linear_tolerance():
    for dim in (2, 3):
        linear = [s.hi for s in TABLES[dim].values() if s.p == 1]
        assert max(linear) == L_SIGMA_PLUS == TABLES[dim]["sigma"].hi


def test_E4_twice_area_has_no_half():
    A, B, P = (Fraction(0), Fraction(0)), (Fraction(5), Fraction(1)), (Fraction(2), Fraction(3))
    a_C = cross2(sub(B, A), sub(P, A))
    AB2 = dot(sub(B, A), sub(B, A))
    # distance from P to line AB, squared: a_C² / |AB|²; so a_C² = |AB|²·|PR|² exactly.
    PR2 = a_C * a_C / AB2
    assert a_C * a_C == AB2 * PR2
    assert a_C * a_C != AB2 * PR2 / 4


def test_E5_literal_algorithm_6_exceeds_four_eps():
    L = exact_input("L", 1, 1, nonnegative=True)
    s = sqrt(const(eps))
    a = sqrt(s)
    b = s * a
    d = L * L
    e = b * L * d
    f = const(eps) * (d * d)
    assert bounds(24 * e).R_int == 8
    assert bounds(1215 * f).R_int == 6
    derived = predicates.tracked_tolerances(3).values
    assert bounds(derived["mu"]).R_int <= 3 and bounds(derived["lam"]).R_int <= 2


def test_E6_rule_H_b_is_nonnegative():
    x = exact_input("X", 1, 2, nonnegative=True)
    for _ in range(4):  # raise a past 4 with relative-error products
        x = x * x
    assert x.a > 4
    y = sqrt(x)
    assert y.b >= 1
    a1, b1 = x.a, x.b
    assert 1 + b1 / 2 + (a1 / 2 - a1**2 / 8) < y.b  # the bar-less reading is smaller
    assert "1 + b1/2 + |a1/2 − a1²/8|" in inspect.getdoc(fperr.rules)
