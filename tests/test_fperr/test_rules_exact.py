"""Rules A–K and composed expressions against exact arithmetic (issue "fperr core").

For every expression below, fperr's state is derived once (``fperr.coord``/``const``/
Tracked operators); then, for many random and adversarial exactly-representable inputs,
the same expression — same operation order — is computed in binary64, binary32
(numpy.float32) and 17-bit mpmath, and compared with the exact value (Fractions, or a
300-bit interval enclosure when a square root is involved). The test asserts, exactly:

* |x| <= c·L^p (the state's magnitude claim; for rule G's bare quotient, whose c = 1 is
  a normalisation *premise*, the E check is skipped where the premise fails),
* |F[x] − x| <= E = c·L^p·(aε + bε²) at the format's ε, with L = 2·max|coord| (rule K:
  |coord| <= L/2, the tightest admissible L),
* |F[x] − x| <= R·|x| = (aε + bε²)·|x| when r holds.

See ``tests/support/exact_eval.py`` for the machinery; ``test_checker_*`` show that it fails
when it should.
"""
from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy
from mpmath import libmp
from hypothesis import assume, given, reject, settings
from hypothesis import strategies as st

import fperr
from exact_eval import (BINARY32, BINARY64, FORMATS, MP17, TRACKED, BoundViolation, Expr,
                        OutOfRange, check, check_bounds, coordinates, eps_of, tracked)
from exact_vectors import (X, cross2, cross3, dot, guarded, names, nonzero, norm, normalise,
                           pts, sq, sub)
from fperr import round_fraction as round_to_bits
from fperr.ops import BY_RULE

_T = Fraction(1, 2 ** 12)


# ---------------------------------------------------------------------------------
# one or more expressions per rule; ``rule`` is the rule fperr must apply at the top

RULES = [
    # A: x = −x1
    Expr("A:-x0", X(1), lambda x, K: -x[0], "A"),
    Expr("A:-(x0-x1)", X(2), lambda x, K: -(x[0] - x[1]), "A"),
    Expr("A:-(x0*x1-x2*x3)", X(4), lambda x, K: -(x[0] * x[1] - x[2] * x[3]), "A"),
    Expr("A:-sqrt(x0^2+x1^2)", X(2), lambda x, K: -K.sqrt(sq(x[0]) + sq(x[1])), "A",
         sqrt=True),
    # B: x = x1 + x2 (mixed signs, or operands without relative error)
    Expr("B:x0+x1", X(2), lambda x, K: x[0] + x[1], "B"),
    Expr("B:x0*x1+x2*x3", X(4), lambda x, K: x[0] * x[1] + x[2] * x[3], "B"),
    Expr("B:(x0-x1)+(x2-x3)", X(4), lambda x, K: (x[0] - x[1]) + (x[2] - x[3]), "B"),
    Expr("B:(x0-x1)^2+x2*x3", X(4), lambda x, K: sq(x[0] - x[1]) + x[2] * x[3], "B"),
    Expr("B:(x0*x1+x2*x3)+x4*x5", X(6),
         lambda x, K: (x[0] * x[1] + x[2] * x[3]) + x[4] * x[5], "B"),
    Expr("B:x0^2+((x1-x2)-(x3-x4))^2", X(5),  # both n, but the second has r = 0
         lambda x, K: sq(x[0]) + sq((x[1] - x[2]) - (x[3] - x[4])), "B"),
    # C: x = x1 + x2, both non-negative with relative error
    Expr("C:x0^2+x1^2", X(2), lambda x, K: sq(x[0]) + sq(x[1]), "C"),
    Expr("C:(x0-x1)^2+(x2-x3)^2", X(4), lambda x, K: sq(x[0] - x[1]) + sq(x[2] - x[3]), "C"),
    Expr("C:3 squares", X(6),
         lambda x, K: (sq(x[0] - x[1]) + sq(x[2] - x[3])) + sq(x[4] - x[5]), "C"),
    Expr("C:|x0-x1|+|x2-x3|", X(4), lambda x, K: abs(x[0] - x[1]) + abs(x[2] - x[3]), "C"),
    Expr("C:sqrt+sqrt", X(4),
         lambda x, K: K.sqrt(sq(x[0]) + sq(x[1])) + K.sqrt(sq(x[2]) + sq(x[3])), "C",
         sqrt=True),
    # D: x = x1 − x2 of inexact operands
    Expr("D:x0*x1-x2*x3", X(4), lambda x, K: x[0] * x[1] - x[2] * x[3], "D"),
    Expr("D:(x0-x1)-(x2-x3)", X(4), lambda x, K: (x[0] - x[1]) - (x[2] - x[3]), "D"),
    Expr("D:(x0-x1)*(x2-x3)-x4*x5", X(6),
         lambda x, K: (x[0] - x[1]) * (x[2] - x[3]) - x[4] * x[5], "D"),
    Expr("D:sqrt(x0^2+x1^2)-x2", X(3), lambda x, K: K.sqrt(sq(x[0]) + sq(x[1])) - x[2], "D",
         sqrt=True),
    # E: x = x1 − x2 of two exact quantities
    Expr("E:x0-x1", X(2), lambda x, K: x[0] - x[1], "E"),
    Expr("E:x0-(-x1)", X(2), lambda x, K: x[0] - (-x[1]), "E"),
    # F: x = x1·x2
    Expr("F:x0*x1", X(2), lambda x, K: x[0] * x[1], "F"),
    Expr("F:(x0-x1)*(x2-x3)", X(4), lambda x, K: (x[0] - x[1]) * (x[2] - x[3]), "F"),
    Expr("F:(x0-x1)**2", X(2), lambda x, K: (x[0] - x[1]) ** 2, "F"),
    Expr("F:(x0*x1-x2*x3)*(x4-x5)", X(6),
         lambda x, K: (x[0] * x[1] - x[2] * x[3]) * (x[4] - x[5]), "F"),
    Expr("F:(x0*x1+x2*x3)^2", X(4), lambda x, K: sq(x[0] * x[1] + x[2] * x[3]), "F"),
    Expr("F:x0*x1*x2", X(3), lambda x, K: x[0] * x[1] * x[2], "F"),
    Expr("F:sqrt(x0^2+x1^2)*(x2-x3)", X(4),
         lambda x, K: K.sqrt(sq(x[0]) + sq(x[1])) * (x[2] - x[3]), "F", sqrt=True),
    # G: x = x1/x2 (c = 1*: normalisation)
    Expr("G:u.x=(A.x-B.x)*(1/m) 2D", names("A B", 2),
         lambda x, K: normalise(sub(*pts(x, 2, 2)), K)[0], "F", sqrt=True,
         pre=nonzero((0, 2), (1, 3))),
    Expr("G:u.z=(A.z-B.z)*(1/m) 3D", names("A B", 3),
         lambda x, K: normalise(sub(*pts(x, 3, 2)), K)[2], "F", sqrt=True,
         pre=nonzero((0, 3), (1, 4), (2, 5))),
    Expr("G:(A.x-B.x)/m 2D", names("A B", 2),
         lambda x, K: (x[0] - x[2]) / norm(sub(*pts(x, 2, 2)), K), "G", sqrt=True,
         pre=nonzero((0, 2), (1, 3))),
    Expr("G:1/m 2D", names("A B", 2),
         lambda x, K: K.const(1) / norm(sub(*pts(x, 2, 2)), K), "G", sqrt=True,
         pre=nonzero((0, 2), (1, 3))),
    Expr("G:weight (P.x-A.x)/(B.x-A.x)", ("A.x", "B.x", "P.x"),
         lambda x, K: (x[2] - x[0]) / (x[1] - x[0]), "G",
         pre=lambda x: x[1] != x[0] and 0 <= (x[2] - x[0]) / (x[1] - x[0]) <= 1),
    Expr("G:(x0*x1)/(x2*x3)", X(4), lambda x, K: (x[0] * x[1]) / (x[2] * x[3]), "G",
         pre=lambda x: x[2] * x[3] != 0),
    # S, SD: more exact scalings (rule S's negative factor on the left, ÷2^−2)
    Expr("SD:(x0^2+x1^2)/2", X(2), lambda x, K: (sq(x[0]) + sq(x[1])) / K.const(2), "SD"),
    Expr("SD:(x0-x1)/0.25", X(2), lambda x, K: (x[0] - x[1]) / K.const(0.25), "SD"),
    # H: x = sqrt(x1)
    Expr("H:sqrt(x0^2+x1^2)", X(2), lambda x, K: K.sqrt(sq(x[0]) + sq(x[1])), "H", sqrt=True),
    Expr("H:m 2D", names("A B", 2), lambda x, K: norm(sub(*pts(x, 2, 2)), K), "H", sqrt=True),
    Expr("H:m 3D", names("A B", 3), lambda x, K: norm(sub(*pts(x, 3, 2)), K), "H", sqrt=True),
    Expr("H:sqrt(x0*x0)", X(1), lambda x, K: K.sqrt(x[0] * x[0]), "H", sqrt=True),
    Expr("H:sqrt(m*m) (a1=7>4)", names("A B", 2),
         lambda x, K: K.sqrt(sq(norm(sub(*pts(x, 2, 2)), K))), "H", sqrt=True),
    Expr("H:sqrt(sum of 4th powers)", X(4),
         lambda x, K: K.sqrt(sq(sq(x[0] - x[1])) + sq(sq(x[2] - x[3]))), "H", sqrt=True),
    Expr("H:sqrt(0.1*x0^2)", X(1), lambda x, K: K.sqrt(K.const("0.1") * sq(x[0])), "H",
         sqrt=True),
    # I: x = |x1|
    Expr("I:|x0|", X(1), lambda x, K: abs(x[0]), "I"),
    Expr("I:|x0-x1|", X(2), lambda x, K: abs(x[0] - x[1]), "I"),
    Expr("I:|x0*x1-x2*x3|", X(4), lambda x, K: abs(x[0] * x[1] - x[2] * x[3]), "I"),
    # J: constants, exact and rounded, alone and meeting coordinates
    Expr("J:6.5", (), lambda x, K: K.const(6.5), "J"),
    Expr("J:1215", (), lambda x, K: K.const(1215), "J"),
    Expr("J:0.1", (), lambda x, K: K.const("0.1"), "J"),
    Expr("J:1/3", (), lambda x, K: K.const(Fraction(1, 3)), "J"),
    Expr("J:-1/3", (), lambda x, K: K.const(Fraction(-1, 3)), "J"),
    Expr("J:2^17+1", (), lambda x, K: K.const(2 ** 17 + 1), "J"),
    Expr("J:6.5*x0", X(1), lambda x, K: K.const(6.5) * x[0], "F"),
    Expr("J:0.1*x0", X(1), lambda x, K: K.const("0.1") * x[0], "F"),
    Expr("J:(1/3)*x0*x1", X(2), lambda x, K: K.const(Fraction(1, 3)) * x[0] * x[1], "F"),
    Expr("J:0.1*x0+(1/3)*x1", X(2),
         lambda x, K: K.const("0.1") * x[0] + K.const(Fraction(1, 3)) * x[1], "B"),
    Expr("J:0.1+1/3", (), lambda x, K: K.const("0.1") + K.const(Fraction(1, 3)), "C"),
    # K: a coordinate
    Expr("K:x0", X(1), lambda x, K: x[0], "K"),
    # S, SD: scaling by ±2^k is exact (no rounding)
    Expr("S:(x0*x1-x2*x3)*0.5", X(4), lambda x, K: (x[0] * x[1] - x[2] * x[3]) * K.const(0.5),
         "S"),
    Expr("S:-4*(x0-x1)", X(2), lambda x, K: K.const(-4) * (x[0] - x[1]), "S"),
    Expr("SD:(x0*x1-x2*x3)/2", X(4), lambda x, K: (x[0] * x[1] - x[2] * x[3]) / K.const(2),
         "SD"),
    # GL: a divisor bounded below by a passed check (docs/proofs.md, Quotients and roots)
    Expr("GL:(x0*x1-x2*x3)/(x4-x5), |x4-x5|>T", X(6),
         lambda x, K: (x[0] * x[1] - x[2] * x[3]) / guarded(x[4] - x[5], _T, 1, x, K), "GL"),
    Expr("GL:t=(P-A).(B-A)/|B-A|^2, |B-A|^2>T", names("A B P", 2),
         lambda x, K: (lambda A, B, P: dot(sub(P, A), sub(B, A)) / guarded(
             dot(sub(B, A), sub(B, A)), _T, 2, x, K))(*pts(x, 2, 3)), "GL"),
    Expr("GL:o/(o-o'), |o-o'|>T", X(4),
         lambda x, K: (lambda o, o2: o / guarded(o - o2, _T, 1, x, K))(
             x[0] - x[1], x[2] - x[3]), "GL"),
    # HL: a radicand without relative error, bounded below by a passed check
    Expr("HL:sqrt(n.n), n.n>T", X(6),
         lambda x, K: K.sqrt(guarded(sq((x[0] - x[1]) - (x[2] - x[3])) + sq(x[4] - x[5]),
                                     _T, 2, x, K)),
         "HL", sqrt=True),
]


def _chain2(x, K):
    A, B, P = pts(x, 2, 3)
    uh = sub(A, B)
    m = norm(uh, K)
    u = normalise(uh, K)
    w = sub(P, A)
    ah = dot(u, w)
    return dict(m=m, d=abs(cross2(u, w)), ah=ah, abar=m - ah)


def _chain3(x, K):
    A, B, P = pts(x, 3, 3)
    uh = sub(A, B)
    m = norm(uh, K)
    u = normalise(uh, K)
    w = sub(P, A)
    ah = dot(u, w)
    c = cross3(u, w)
    return dict(m=m, d2=dot(c, c), ah=ah, abar=m - ah)


AB2, AB3 = nonzero((0, 2), (1, 3)), nonzero((0, 3), (1, 4), (2, 5))

COMPOSED = [
    Expr("dot2 A.B", names("A B", 2), lambda x, K: dot(*pts(x, 2, 2)), "B"),
    Expr("dot3 A.B", names("A B", 3), lambda x, K: dot(*pts(x, 3, 2)), "B"),
    Expr("dot2 (A-B).(P-A)", names("A B P", 2),
         lambda x, K: (lambda A, B, P: dot(sub(A, B), sub(P, A)))(*pts(x, 2, 3)), "B"),
    Expr("dot3 (A-B).(P-A)", names("A B P", 3),
         lambda x, K: (lambda A, B, P: dot(sub(A, B), sub(P, A)))(*pts(x, 3, 3)), "B"),
    Expr("cross2 (A-B)x(P-A)", names("A B P", 2),
         lambda x, K: (lambda A, B, P: cross2(sub(A, B), sub(P, A)))(*pts(x, 2, 3)), "D"),
    *[Expr(f"cross3[{i}] (A-B)x(P-A)", names("A B P", 3),
           lambda x, K, i=i: (lambda A, B, P: cross3(sub(A, B), sub(P, A))[i])(*pts(x, 3, 3)),
           "D") for i in range(3)],
    Expr("triple (B-A).((C-A)x(D-A))", names("A B C D", 3),
         lambda x, K: (lambda A, B, C, D: dot(sub(B, A), cross3(sub(C, A), sub(D, A))))(
             *pts(x, 3, 4)), "B"),
    Expr("|A-B|^2 2D", names("A B", 2),
         lambda x, K: (lambda A, B: dot(sub(A, B), sub(A, B)))(*pts(x, 2, 2)), "C"),
    Expr("|A-B|^2 3D", names("A B", 3),
         lambda x, K: (lambda A, B: dot(sub(A, B), sub(A, B)))(*pts(x, 3, 2)), "C"),
    *[Expr(f"u[{i}] 2D", names("A B", 2),
           lambda x, K, i=i: normalise(sub(*pts(x, 2, 2)), K)[i], "F", sqrt=True, pre=AB2)
      for i in range(2)],
    *[Expr(f"u[{i}] 3D", names("A B", 3),
           lambda x, K, i=i: normalise(sub(*pts(x, 3, 2)), K)[i], "F", sqrt=True, pre=AB3)
      for i in range(3)],
    *[Expr(f"edge-vertex 2D {k}", names("A B P", 2), lambda x, K, k=k: _chain2(x, K)[k],
           None, sqrt=True, pre=AB2) for k in ("m", "d", "ah", "abar")],
    *[Expr(f"edge-vertex 3D {k}", names("A B P", 3), lambda x, K, k=k: _chain3(x, K)[k],
           None, sqrt=True, pre=AB3) for k in ("m", "d2", "ah", "abar")],
]


#: The expression × format grid below has ~240 cases: each runs a quarter of the
#: profile's examples (50 by default, 1250 with FPERR_LONG=1; see conftest.py).
GRID = settings(max_examples=max(10, settings().max_examples // 4))


def _run(expr: Expr, fmt, data):
    coords = data.draw(coordinates(fmt, expr.arity), label="coords")
    if expr.pre is not None:
        assume(expr.pre(coords))
    try:
        check(expr, fmt, coords)
    except OutOfRange:
        reject()


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
@pytest.mark.parametrize("expr", RULES, ids=str)
@GRID
@given(data=st.data())
def test_rule_bound_holds(expr, fmt, data):
    _run(expr, fmt, data)


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
@pytest.mark.parametrize("expr", COMPOSED, ids=str)
@GRID
@given(data=st.data())
def test_composed_bound_holds(expr, fmt, data):
    _run(expr, fmt, data)


@pytest.mark.parametrize("expr", RULES + COMPOSED, ids=str)
def test_expression_is_valid_and_uses_rule(expr):
    x = tracked(expr)
    assert x.v, x.why
    if expr.rule is not None:
        assert x.rule == expr.rule, x.derivation()


def test_every_rule_is_exercised():
    used = set()
    for e in RULES:
        used |= {y.rule for y in tracked(e).walk()}
    every = set(BY_RULE) | {"J", "K"}     # the operator table's rules and the two leaves
    assert every == set("ABCDEFGHIJK") | {"S", "SD", "GL", "HL"}
    assert used >= every
    assert {e.rule for e in RULES} >= every


# ---------------------------------------------------------------------------------
# hand-picked adversarial inputs, in every format (deterministic, always run)

EDGE_CASES = [
    # (expression name, coordinates as multiples of a power of two chosen per format)
    ("E:x0-x1", lambda t: [t, -t]),                        # |x0 − x1| = L = c·L^p exactly
    ("E:x0-x1", lambda t: [t, t - 1]),                     # catastrophic cancellation
    ("D:x0*x1-x2*x3", lambda t: [t, t, t - 1, t + 1]),     # t² − (t² − 1): exact result 1
    ("C:(x0-x1)^2+(x2-x3)^2", lambda t: [t, -t, -t, t]),   # at the bound 2·L²
    ("H:m 2D", lambda t: [t, t, -t, -t]),                  # m = √2·L exactly at c·L^p
    ("H:m 3D", lambda t: [t, t, t, -t, -t, -t]),           # m = √3·L
    ("G:u.x=(A.x-B.x)*(1/m) 2D", lambda t: [t, t - 1, 0, 0]),
    ("G:1/m 2D", lambda t: [t, t, -t, -t]),
    ("cross2 (A-B)x(P-A)", lambda t: [0, 0, t, t - 1, 2 * t - 1, 2 * t - 3]),
    ("triple (B-A).((C-A)x(D-A))",
     lambda t: [0, 0, 0, t, 1, 0, 0, t, 1, 1, 1, t]),
    ("edge-vertex 2D abar", lambda t: [0, 0, t, t - 1, t - 1, t - 2]),
    ("edge-vertex 3D abar", lambda t: [0, 0, 0, t, t - 1, 1, t - 1, t - 2, 1]),
]
BY_NAME = {e.name: e for e in RULES + COMPOSED}


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
@pytest.mark.parametrize("case", range(len(EDGE_CASES)))
def test_adversarial_edge_cases(case, fmt):
    name, make = EDGE_CASES[case]
    t = 2 ** (fmt.bits - 1) - 1          # 2t − 1 still fits the significand
    coords = [Fraction(v) for v in make(t)]
    check(BY_NAME[name], fmt, coords)


# ---------------------------------------------------------------------------------
# rule J: constants rounded into each format are within their bound

CONSTS = [Fraction(13, 2), Fraction(1215), Fraction(1, 10), Fraction(1, 3), Fraction(-1, 3),
          Fraction(2 ** 17 + 1), Fraction(2 ** 17 - 1), Fraction(2 ** 40), Fraction(5, 7)]


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
@pytest.mark.parametrize("q", CONSTS, ids=str)
def test_constant_rounding_within_bound(q, fmt):
    t = fperr.const(q)
    b = fperr.bounds(t, strict=True)
    rounded = fmt.to_fraction(fmt.const(q))
    assert rounded == round_to_bits(q, fmt.bits)
    err = abs(rounded - q)
    E = b.E_at(eps_of(fmt))
    assert sympy.Rational(err.numerator, err.denominator) <= E
    if err:                       # a constant that rounds must be marked inexact
        assert t.a == 1


@pytest.mark.parametrize("fmt", FORMATS, ids=str)
def test_native_constant_conversion_is_correctly_rounded(fmt):
    """The formats' own conversions of 0.1 and 1/3 agree with the reference rounding
    (so the J checks above describe what the formats really do)."""
    for q in (Fraction(1, 10), Fraction(1, 3)):
        if fmt is BINARY64:
            native = Fraction(float(q))
        elif fmt is BINARY32:
            native = Fraction(float(np.float32(1) / np.float32(10 if q.denominator == 10 else 3)))
        else:
            with MP17.session():
                native = MP17.to_fraction(mpmath.mpf(1) / q.denominator)
        assert native == round_to_bits(q, fmt.bits)


@given(st.fractions(min_value=-10 ** 6, max_value=10 ** 6, max_denominator=10 ** 6))
def test_inexact_constants_carry_one_rounding(q):
    t = fperr.const(q)
    assert t.rule == "J" and t.p == 0 and t.b == 0 and t.r
    assert t.c == sympy.Rational(abs(q).numerator, abs(q).denominator)
    assert t.n == (q >= 0)
    exact17 = q.denominator & (q.denominator - 1) == 0 and round_to_bits(q, 17) == q
    assert t.a == (0 if exact17 else 1)
    for fmt in FORMATS:
        err = abs(round_to_bits(q, fmt.bits) - q)
        assert err <= abs(q) * t.a * eps_of(fmt)


# ---------------------------------------------------------------------------------
# the checker itself can fail


class _Lying(fperr.MpContext):
    """Claims a 17-bit ε but computes with 12 bits: every bound must catch it."""

    def __init__(self):
        super().__init__(17)
        self.format = "lying12"

    def session(self):
        return mpmath.workprec(12)

    def const(self, x):
        q = fperr.to_fraction(x)
        return mpmath.mp.make_mpf(libmp.from_rational(q.numerator, q.denominator, 12, "n"))


@pytest.mark.parametrize("name, coords", [
    ("F:x0*x1", [92681, 70001]),
    ("E:x0-x1", [92681, -70001]),
    ("H:m 2D", [92681, 70001, 0, 0]),
    ("G:u.x=(A.x-B.x)*(1/m) 2D", [92681, 70001, 0, 0]),
    ("J:1/3", []),
])
def test_checker_catches_a_sloppier_format(name, coords):
    with pytest.raises(BoundViolation):
        check_bounds(BY_NAME[name], _Lying(), [Fraction(v) for v in coords])


def test_checker_catches_a_wrong_magnitude():
    lie = Expr("lie", X(1), lambda x, K: x[0] if K is TRACKED else 3 * x[0])
    with pytest.raises(BoundViolation, match="c·L"):
        check_bounds(lie, BINARY64, [Fraction(5)])


def test_checker_catches_a_wrong_value():
    lie = Expr("lie2", X(2), lambda x, K: x[0] - x[1] if K is not BINARY64
               else x[0] - x[1] + 2 ** -40)
    with pytest.raises(BoundViolation, match="exceeds"):
        check_bounds(lie, BINARY64, [Fraction(1), Fraction(1, 3 * 2 ** 10) * 3])


# ---------------------------------------------------------------------------------
# rule G's c = 1* outside its normalisation premise (fperr bug, see the report)

# Rule G's c = 1* once applied to any product with a quotient and to the bare quotient
# (found by this suite); fperr now gives c = 1 only to v_i·(1/‖v‖) and no E to a quotient.


def test_product_of_other_vector_with_quotient_is_not_normalised():
    """w.x·(1/m) with w = P − A and m = |A − B|: fperr gives c = 1, p = 0, so E <= 7ε,
    but with A = (0, 0), B = (1, 1), P = (1001, 0) (L = 2002) w.x/m = 1001/√2 ≈ 708 and
    the binary64 error is ≈ 737ε (the relative bound R <= 7ε still holds)."""
    e = Expr("w.x*(1/m)", names("A B P", 2),
             lambda x, K: (x[4] - x[0]) * (K.const(1) / norm(sub(*pts(x, 2, 2)), K)),
             sqrt=True)
    t = tracked(e)
    assert not t.v and "normalises" in t.why   # no magnitude bound: refused, not wrong
    # whereas a component of the normalised vector keeps c = 1 and its bound holds:
    u = Expr("u.x", names("A B", 2),
             lambda x, K: (x[0] - x[2]) * (K.const(1) / norm(sub(*pts(x, 2, 2)), K)),
             sqrt=True)
    assert tracked(u).v and tracked(u).c == 1
    check_bounds(u, BINARY64, [Fraction(v) for v in (0, 0, 1, 1)])


def test_bare_quotient_E_is_a_bound():
    """bounds(1/m).E = (4ε + 18ε²)/L claims |F[1/m] − 1/m| <= 4ε/L (c = 1: |1/m| <= 1/L);
    with A = (1000, 1000), B = (1001, 1001): L = 2002, m = √2, and the binary64 error of
    1/√2 is ≈ 0.56ε, while 4ε/L ≈ 0.002ε."""
    A, B = (1000, 1000), (1001, 1001)
    q = fperr.const(1) / fperr.sqrt((fperr.coord("A.x") - fperr.coord("B.x")) ** 2
                                    + (fperr.coord("A.y") - fperr.coord("B.y")) ** 2)
    b = fperr.bounds(q)
    assert b.valid and b.E is None and b.E_int is None   # no absolute bound is claimed
    with pytest.raises(fperr.InvalidBound, match="quotient"):
        fperr.bounds(q, strict=True)
    computed = 1.0 / math.sqrt(float((A[0] - B[0]) ** 2 + (A[1] - B[1]) ** 2))
    c = Fraction(computed)
    err = abs(sympy.Rational(c.numerator, c.denominator) - 1 / sympy.sqrt(2))
    assert err <= b.R_at(eps_of(BINARY64)) / sympy.sqrt(2)   # the relative bound holds
