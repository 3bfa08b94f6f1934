"""The exact path in dyadic integers (predicates.exact_lanes) against Fractions.

Every value is checked lane by lane against ``fractions.Fraction`` arithmetic on the same
floats: conversion (subnormals, zeros, signs, float32, exponents 2^±1000 in one column),
sums, differences, products, powers and comparisons of values with different exponents;
the classic determinants' exact path equals the lane-by-lane Fraction path and the
independent Laplace determinants; a source that divides falls back to Fractions and is
still exact.
"""
from __future__ import annotations

import operator
from fractions import Fraction

import numpy as np
import pytest
from determinants import exact_signs
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates import classic
from predicates.core import predicate
from predicates.exact_lanes import DyadicLanes, ExactLanesContext, NotDyadic, lanes_of
from predicates.filtered import filtered
from predicates.vector import cross2, sub


def _values(d: DyadicLanes, n: int) -> list[Fraction]:
    return [d.fraction(i) for i in range(n)]


def _column(rng, n, dtype=np.float64):
    """Floats of every kind: wide exponents, subnormals, zeros, both signs."""
    x = np.ldexp(rng.random(n) + 0.5, rng.integers(-1070, 1000, n)) * rng.choice([-1, 1], n)
    x[:: 7] = 0.0
    x[3:: 11] = np.ldexp(rng.integers(1, 1 << 40, len(x[3:: 11])).astype(float), -1074)
    if dtype == np.float32:
        x = np.ldexp(rng.random(n) + 0.5, rng.integers(-140, 120, n)).astype(np.float32)
        x[:: 5] = 0
    return x


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_conversion_is_exact(dtype):
    x = _column(np.random.default_rng(0), 500, dtype)
    assert _values(lanes_of(x), len(x)) == [Fraction(float(v)) for v in x]


_OPS = {"+": operator.add, "-": operator.sub, "*": operator.mul}


@pytest.mark.parametrize("op", sorted(_OPS))
def test_arithmetic_and_comparisons_against_fractions(op):
    rng = np.random.default_rng(1)
    x, y = _column(rng, 400), _column(rng, 400) * 2.0 ** -30  # different exponents
    X, Y = lanes_of(x), lanes_of(y)
    r = _OPS[op](X, Y)
    qx, qy = [Fraction(float(v)) for v in x], [Fraction(float(v)) for v in y]
    assert _values(r, len(x)) == [_OPS[op](a, b) for a, b in zip(qx, qy)]
    for rel in (operator.lt, operator.le, operator.gt, operator.ge):
        assert rel(r, X).tolist() == [rel(_OPS[op](a, b), a) for a, b in zip(qx, qy)]
    # scalars on either side, dyadic constants, powers, negation, absolute value
    z = abs(-(0.5 - X * 3) ** 2 + Fraction(3, 8))
    assert _values(z, len(x)) == [abs(-(Fraction(1, 2) - a * 3) ** 2 + Fraction(3, 8))
                                  for a in qx]


def test_non_dyadic_numbers_are_refused():
    X = lanes_of(np.array([1.0, 2.0]))
    for bad in (lambda: X / X, lambda: 1 / X, lambda: X + Fraction(1, 3),
                lambda: ExactLanesContext(2).sqrt(X)):
        with pytest.raises(NotDyadic):
            bad()
    with pytest.raises(TypeError, match="branch"):
        bool(X)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(sorted(classic.PREDICATES)),
       st.sampled_from([0, 500, -500]))
def test_classic_exact_path_equals_fractions_and_laplace(seed, name, power):
    """Nearly degenerate lanes (the last point an exact affine combination of the first
    ones, rounded), scaled by 2^power: the dyadic exact path, the lane-by-lane Fraction
    path and the Laplace determinant agree on every lane."""
    f = classic.FILTERED[name]
    dim = 2 if name in ("orient2d", "incircle") else 3
    k = {"orient2d": 3, "orient3d": 4, "incircle": 4, "insphere": 5}[name]
    rng = np.random.default_rng(seed)
    P = [rng.random((60, dim)) for _ in range(k - 1)]
    w = rng.integers(-4, 5, (60, k - 1)) / 4.0
    P.append(sum(w[:, [i]] * P[i] for i in range(k - 1)))  # rounded: within ulps
    P = [np.ldexp(p, power) for p in P]
    auto = f.exact(*P)
    assert f._dyadic  # the classic determinants need no quotient
    assert np.array_equal(auto, f.exact(*P, arithmetic="fractions"))
    assert np.array_equal(auto, exact_signs(name, P) > 0)


@predicate(dim=2, points="ABPQ", weights=("t",))
def _crossing(ctx, A, B, P, Q, tol):
    QP = sub(Q, P)
    oA = ctx.name("oA", cross2(sub(A, P), QP))
    oB = ctx.name("oB", cross2(sub(B, P), QP))
    if ctx.reject(ctx.any(abs(oA) <= 0, abs(oB) <= 0, ctx.same_sign(oA, oB)), line=1):
        return ctx.miss()
    return ctx.hit((oA / (oA - oB),))


def test_a_source_that_divides_falls_back_to_fractions():
    rng = np.random.default_rng(3)
    A, B, P, Q = (rng.random((50, 2)) for _ in range(4))
    f = filtered(_crossing)
    got = f.exact(A, B, P, Q)
    assert not f._dyadic  # the quotient sent the run to Fractions
    assert np.array_equal(got, f.exact(A, B, P, Q, arithmetic="fractions"))
    want = []
    for a, b, p, q in zip(*(x.tolist() for x in (A, B, P, Q))):
        a, b, p, q = ([Fraction(v) for v in pt] for pt in (a, b, p, q))
        oa = (a[0] - p[0]) * (q[1] - p[1]) - (a[1] - p[1]) * (q[0] - p[0])
        ob = (b[0] - p[0]) * (q[1] - p[1]) - (b[1] - p[1]) * (q[0] - p[0])
        want.append(oa != 0 and ob != 0 and (oa > 0) != (ob > 0))
    assert got.tolist() == want
