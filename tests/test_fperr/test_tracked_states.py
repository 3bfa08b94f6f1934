"""Exact states of Tracked quantities (issue "fperr core").

* hand-checked states and bounds from the paper (‖A−B‖², the 2D and 3D edge-vertex chains),
* rule selection (C over B, E over D), invalid results and their propagation, the error
  raised where a bound is needed,
* comparisons as records, constants, ``**``, the derivation text,
* and the paper's integer reporting rule (:func:`fperr.paper_integer`);
random expression trees against the rule table are ``test_tracked_trees``.
"""
from __future__ import annotations

import re
from fractions import Fraction

import pytest
import sympy
from hypothesis import given
from hypothesis import strategies as st

import fperr
from fperr import L, bounds, const, coord, eps, paper_integer, sqrt
from fperr import rules
from exact_vectors import dot, sub
from tracked_checks import assert_exact, state

# ---------------------------------------------------------------------------------
# helpers


def point(name, d):
    return [coord(f"{name}.{c}") for c in "xyz"[:d]]


def same(x, y) -> bool:
    """Exact equality of two sympy numbers."""
    return sympy.simplify(sympy.sympify(x) - sympy.sympify(y)) == 0


def edge_vertex(d):
    """The paper's edge-vertex quantities (eqs. 5 and 12), u = û·(1/m)."""
    A, B, P = point("A", d), point("B", d), point("P", d)
    uh = sub(A, B)
    m2 = dot(uh, uh)
    m = sqrt(m2)
    inv = 1 / m
    u = [c * inv for c in uh]
    w = sub(P, A)
    ah = dot(u, w)
    out = dict(m2=m2, m=m, inv=inv, u=u, w=w, ah=ah, abar=m - ah)
    if d == 2:
        out["d"] = abs(u[0] * w[1] - u[1] * w[0])
    else:
        cr = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
              u[0] * w[1] - u[1] * w[0]]
        out["d2"] = dot(cr, cr)
    return out


# ---------------------------------------------------------------------------------
# hand-checked states


def test_distance_squared_2d():
    A, B = point("A", 2), point("B", 2)
    d2 = dot(sub(A, B), sub(A, B))
    assert d2.rule == "C"
    assert state(d2) == (2, 2, True, 4, 8, True)
    assert_exact(d2)
    b = bounds(d2)
    assert b.valid and b.relative and b.power == 2
    assert b.R_int == 5 and b.E_int == 9
    assert sympy.expand(b.E - (8 * eps + 16 * eps**2) * L**2) == 0
    assert sympy.expand(b.R - (4 * eps + 8 * eps**2)) == 0
    assert b.text() == "R ≤ 5ε, E ≤ 9εL^2"


def test_distance_squared_3d():
    A, B = point("A", 3), point("B", 3)
    d2 = dot(sub(A, B), sub(A, B))
    assert d2.rule == "C" and d2.n and d2.r
    assert state(d2) == (3, 2, True, 5, 13, True)
    b = bounds(d2)
    assert (b.E_int, b.R_int, b.power) == (16, 6, 2)


def test_edge_vertex_2d_chain():
    q = edge_vertex(2)
    m, inv, u = q["m"], q["inv"], q["u"]
    assert m.rule == "H" and state(m) == (sympy.sqrt(2), 1, True, 3, 5, True)
    assert (bounds(m).R_int, bounds(m).E_int) == (4, 5)
    assert inv.rule == "G" and state(inv) == (1, -1, True, 4, 18, True) and inv.inv
    assert u[0].rule == "F" and state(u[0]) == (1, 0, False, 6, 28, True)
    assert state(q["w"][0]) == (1, 1, False, 1, 0, True)
    d = q["d"]
    assert d.rule == "I" and d.args[0].rule == "D"
    assert state(d)[:3] == (2, 1, True) and state(d)[3:] == (9, Fraction(101, 2), False)
    assert bounds(d).E_int == 19 and bounds(d).R_int is None
    assert q["ah"].rule == "B" and bounds(q["ah"]).E_int == 19
    abar = q["abar"]
    assert abar.rule == "D" and bounds(abar).E_int == 26
    assert same(abar.c, 2 + sympy.sqrt(2))
    assert same(abar.a, 16 - 6 * sympy.sqrt(2))
    for x in (m, inv, u[0], d, q["ah"], abar):
        assert_exact(x)


def test_edge_vertex_3d_chain():
    q = edge_vertex(3)
    m = q["m"]
    assert state(m) == (sympy.sqrt(3), 1, True, 1 + Fraction(5, 2), 1 + Fraction(13, 2) +
                        abs(Fraction(5, 2) - Fraction(25, 8)), True)
    assert (bounds(m).R_int, bounds(m).E_int) == (4, 7)
    assert q["d2"].rule == "B" and not q["d2"].r     # squares of rule-D results: r = 0
    assert bounds(q["d2"]).E_int == 261 and bounds(q["d2"]).power == 2
    assert bounds(q["ah"]).E_int == 31
    assert bounds(q["abar"]).E_int == 42


def test_rule_h_uses_the_absolute_value():
    """H's b = 1 + b1/2 + |a1/2 − a1²/8|: for a1 = 7 (m·m) the bars matter."""
    m = edge_vertex(2)["m"]
    mm = m * m
    assert (mm.a, mm.b) == (7, 26)
    r = sqrt(mm)
    assert r.a == 1 + Fraction(7, 2)
    assert r.b == 1 + 13 + abs(Fraction(7, 2) - Fraction(49, 8))
    assert r.b > 0


# ---------------------------------------------------------------------------------
# rule selection


def test_c_over_b_for_nonnegative_relative_operands():
    x0, x1, x2, x3 = (coord(f"x{i}") for i in range(4))
    s1, s2 = (x0 - x1) * (x0 - x1), (x2 - x3) * (x2 - x3)
    s = s1 + s2
    assert s.rule == "C" and s.r and s.n
    assert (s.a, s.b) == (4, 8)
    # B would also apply, and would give a different state: the choice is observable
    b = rules.rule_B(s1.state, s2.state)
    assert (b.a, b.b, b.r) == (4, Fraction(15, 2), False)
    assert (abs(x0 - x1) + abs(x2 - x3)).rule == "C"
    assert (const("0.1") + const(Fraction(1, 3))).rule == "C"


@pytest.mark.parametrize("make", [
    lambda x: x[0] + x[1],                                      # not n
    lambda x: (x[0] - x[1]) * (x[0] - x[1]) + x[2] * x[3],      # one operand not n
    lambda x: x[0] * x[0] + ((x[1] - x[2]) - x[3]) ** 2,        # n, but second not r
    lambda x: (x[0] - x[1]) + (x[2] - x[3]),
], ids=["coords", "square+product", "n-not-r", "diffs"])
def test_b_otherwise(make):
    x = [coord(f"x{i}") for i in range(4)]
    s = make(x)
    assert s.rule == "B" and not s.r
    u, v = s.args
    assert same(s.c, u.c + v.c)
    assert same(s.a, 1 + (u.c * u.a + v.c * v.a) / (u.c + v.c))
    assert same(s.b, (1 + u.c * (u.a + u.b) + v.c * (v.a + v.b)) / (u.c + v.c))
    assert s.n == (u.n and v.n)


def test_e_over_d_for_exact_operands():
    x0, x1, x2 = coord("x0"), coord("x1"), coord("x2")
    e = x0 - x1
    assert e.rule == "E" and state(e) == (1, 1, False, 1, 0, True)
    assert (x0 - (-x1)).rule == "E"
    assert (const(6.5) - const(1215)).rule == "E"
    d = (x0 - x1) - x2
    assert d.rule == "D" and not d.r and d.a == Fraction(5, 3)
    assert (const("0.1") - const(2)).rule == "D"


def test_f_square_is_nonnegative_only_for_equal_strings():
    x0, x1, x2 = coord("x0"), coord("x1"), coord("x2")
    assert ((x0 - x1) * (x0 - x1)).n
    assert ((x0 - x1) * (coord("x0") - coord("x1"))).n      # equal computations, equal s
    assert not ((x0 - x1) * (x0 - x2)).n
    assert not ((x0 - x1) * (x1 - x0)).n
    assert (abs(x0) * abs(x1)).n                             # n1 and n2
    assert not (x0 * x1).n


def test_pow_is_repeated_multiplication():
    x = coord("x0") - coord("x1")
    sq, mul = x ** 2, x * x
    assert sq.s == mul.s and state(sq) == state(mul) and sq.n
    assert state(x ** 3) == state((x * x) * x)
    for bad in (0, -1, 2.0, True):
        with pytest.raises(TypeError):
            x ** bad


# ---------------------------------------------------------------------------------
# invalid results


X = [coord(f"x{i}") for i in range(4)]

INVALID = [
    ("coord+const", lambda: X[0] + const(1), "power"),
    ("coord+1", lambda: X[0] + 1, "power"),
    ("square-coord", lambda: X[0] * X[0] - X[1], "power"),
    ("div by r=0", lambda: (X[0] - X[1]) / (X[0] * X[1] + X[2] * X[3]), "relative"),
    ("div of r=0", lambda: (X[0] * X[1] - X[2] * X[3]) / (X[0] - X[1]), "relative"),
    ("sqrt not n", lambda: sqrt(X[0] - X[1]), "non-negative"),
    ("sqrt not r", lambda: sqrt((X[0] * X[1] + X[2] * X[3]) ** 2), "relative"),
    ("neg quotient", lambda: -(X[0] / X[1]), "quotient"),
    ("quotient plus", lambda: X[0] / X[1] + const(1), "quotient"),
]


@pytest.mark.parametrize("name, make, word", INVALID, ids=[i[0] for i in INVALID])
def test_invalid_results(name, make, word):
    x = make()
    assert not x.v
    assert word in x.why
    b = bounds(x)
    assert not b.valid and b.E is None and b.R is None and b.E_int is None
    with pytest.raises(fperr.InvalidBound, match=word) as ei:
        bounds(x, strict=True)
    assert isinstance(ei.value, ValueError)
    with pytest.raises(fperr.InvalidBound, match=word):
        fperr.error(x)
    with pytest.raises(fperr.InvalidBound):
        x.c
    assert "invalid" in repr(x) and "invalid" in x.derivation()


OPS = [
    ("neg", lambda b, x: -b), ("abs", lambda b, x: abs(b)), ("sqrt", lambda b, x: sqrt(b)),
    ("add", lambda b, x: b + x), ("radd", lambda b, x: x + b),
    ("sub", lambda b, x: b - x), ("rsub", lambda b, x: x - b),
    ("mul", lambda b, x: b * x), ("rmul", lambda b, x: x * b),
    ("div", lambda b, x: b / x), ("rdiv", lambda b, x: x / b),
    ("pow", lambda b, x: b ** 2), ("const*", lambda b, x: 2 * b), ("*const", lambda b, x: b * 0.5),
]


@pytest.mark.parametrize("name, op", OPS, ids=[o[0] for o in OPS])
def test_invalid_propagates(name, op):
    bad = X[0] + const(1)
    assert not bad.v
    y = op(bad, X[1] * X[2] if name in ("add", "radd", "sub", "rsub") else X[1])
    assert not y.v, y
    with pytest.raises(fperr.InvalidBound):
        fperr.error(y)
    z = abs(y) * X[3]                       # and further down the line
    assert not z.v


def test_bool_and_comparisons_decide_nothing():
    x, y = X[0] - X[1], X[2] - X[3]
    with pytest.raises(TypeError):
        bool(x)
    with pytest.raises(TypeError):
        if x:
            pass
    for chk in (x <= y, x < y, x >= y, x > y, x <= 0, 0 <= x):
        assert isinstance(chk, fperr.Check)
        with pytest.raises(TypeError):
            bool(chk)
    c = x <= y
    assert (c.lhs, c.rhs, c.rel) == (x, y, "<=")
    assert (x > y).rel == ">" and (0 <= x).rel == ">=" and (0 <= x).lhs is x


def test_check_error_is_sum_of_side_errors():
    q = edge_vertex(2)
    x, y = X[0] - X[1], X[2] - X[3]
    assert sympy.expand((x <= y).error() - 2 * eps * L) == 0
    chk = q["d"] <= const(sympy.Rational(9, 2) * sympy.sqrt(eps)) * coord("L")
    assert sympy.expand(chk.error() - (fperr.error(chk.lhs) + fperr.error(chk.rhs))) == 0
    sign = q["abar"] > 0
    assert sign.is_sign_test
    # a sign test is decided with the sign bound: E without the last rounding, here the
    # sum of the last difference's operand errors (docs/proofs.md, "Sign tests")
    last = q["abar"]
    assert last.rule in ("B", "D")
    assert sympy.expand(sign.error() - sum(fperr.error(a) for a in last.args)) == 0
    assert sympy.expand(sign.error() - fperr.bounds(last, sign=True).E) == 0
    assert (fperr.error(last) - sign.error()).subs({eps: sympy.Rational(1, 10**5), L: 1}) > 0
    with pytest.raises(fperr.InvalidBound):        # L^1 against L^0, not a sign test
        (x <= const(1)).error()
    with pytest.raises(fperr.InvalidBound):
        (x <= X[0] + const(1)).error()


# ---------------------------------------------------------------------------------
# constants (rule J)


def test_constants():
    for v in (6.5, 1215, Fraction(13, 2), "6.5", -6.5, 2 ** 17 - 1, 2 ** 40, 2.0 ** -30):
        t = const(v, exact=True)
        assert t.rule == "J" and t.a == 0 and t.b == 0 and t.r and t.p == 0
        assert t.n == (Fraction(str(v)) >= 0 if not isinstance(v, float) else v >= 0)
    for v in (0.1, "0.1", Fraction(1, 3), 2 ** 17 + 1, 1 / 3):
        with pytest.raises(ValueError):
            const(v, exact=True)
        t = const(v)
        assert t.a == 1 and t.b == 0 and t.r
    assert const(Fraction(-1, 3)).c == sympy.Rational(1, 3) and not const(Fraction(-1, 3)).n
    assert const(6.5, exact=False).a == 1            # forced rounding
    assert (0.1 * X[0]).args[0].a == 1               # a float meeting a Tracked is rule J
    assert (6.5 * X[0]).args[0].a == 0


# ---------------------------------------------------------------------------------
# derivation and repr


def test_derivation_names_every_rule():
    q = edge_vertex(2)
    abar = q["abar"]
    text = abar.derivation()
    lines = text.splitlines()
    steps = list(abar.walk())
    assert len(lines) == len(steps)
    named = [re.findall(r"\[([A-K])\]", line) for line in lines]
    assert all(len(ids) == 1 for ids in named), text
    assert [ids[0] for ids in named] == [x.rule for x in steps]     # in walk order
    assert {ids[0] for ids in named} == set("KEFCHJGBD")
    assert "rule D" in repr(abar) and "rule C" in repr(q["m2"])


# ---------------------------------------------------------------------------------
# the paper's integer


def test_paper_integer_examples():
    assert paper_integer(sympy.Integer(9)) == 9                 # c·a integer, b = 0
    assert paper_integer(sympy.Integer(8), sympy.Integer(0)) == 8
    assert paper_integer(sympy.Integer(8), sympy.Integer(16)) == 9   # b > 0 pushes it up
    assert paper_integer(sympy.Integer(0), sympy.Integer(100000)) == 1   # = 1 at ε = 1e-5
    assert paper_integer(sympy.Integer(0), sympy.Integer(100001)) == 2
    assert paper_integer(3 * sympy.sqrt(2), 5 * sympy.sqrt(2)) == 5
    assert paper_integer(eps, sympy.Integer(0)) is None
    e = coord("x0") - coord("x1")                               # c = 1, a = 1, b = 0
    assert bounds(e).E_int == 1 and bounds(e).R_int == 1
    assert bounds(coord("x0")).E_int == 0


@given(st.fractions(min_value=0, max_value=10 ** 4), st.fractions(min_value=0, max_value=10 ** 6))
def test_paper_integer_is_smallest(ca, cb):
    K = paper_integer(sympy.Rational(ca.numerator, ca.denominator),
                      sympy.Rational(cb.numerator, cb.denominator))
    worst = ca + cb * Fraction(1, 10 ** 5)
    assert K >= worst and K - 1 < worst
