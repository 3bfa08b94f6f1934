"""Filtered sign predicates (predicates.filtered, predicates.classic) equal the exact
sign on every lane: random, near-degenerate (points within a few ulps of the line,
plane, circle or sphere, constructed exactly then rounded), translated (2^20, 2^40) and
scaled (2^±500) inputs, in float64 and float32. The reference is an independent exact
determinant (sympy rationals), not the predicate's own source."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy

from predicates import classic
from predicates.filtered import sign_predicate
from predicates.vector import cross2, sub


def _exact_sign(name, pts) -> int:
    P = [[sympy.Rational(Fraction(float(c))) for c in p] for p in pts]
    if name == "orient2d":
        M = [[P[1][0] - P[0][0], P[1][1] - P[0][1]], [P[2][0] - P[0][0], P[2][1] - P[0][1]]]
    elif name == "orient3d":
        M = [[P[i][j] - P[0][j] for j in range(3)] for i in (1, 2, 3)]
    else:  # in-circle / in-sphere: lifted rows relative to the last point
        last = P[-1]
        M = []
        for p in P[:-1]:
            d = [a - b for a, b in zip(p, last)]
            M.append(d + [sum(x * x for x in d)])
        return int(sympy.sign(sympy.Matrix(M).det()))
    return int(sympy.sign(sympy.Matrix(M).det()))


def _on_the_locus(name, rng, n, dtype):
    """n lanes whose last point is on the line/plane/circle/sphere of the others up to
    the rounding of an exact construction, then moved by 0–3 ulps."""
    out = []
    for _ in range(n):
        if name == "orient2d":
            A, B = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
            t = Fraction(int(rng.integers(-8, 9)), 7)
            C = [Fraction(a) + t * (Fraction(b) - Fraction(a)) for a, b in zip(A, B)]
            pts = [A, B, C]
        elif name == "orient3d":
            A, B, C = (rng.uniform(-1, 1, 3) for _ in range(3))
            s, t = Fraction(int(rng.integers(-5, 6)), 3), Fraction(int(rng.integers(-5, 6)), 5)
            D = [Fraction(a) + s * (Fraction(b) - Fraction(a)) + t * (Fraction(c) - Fraction(a))
                 for a, b, c in zip(A, B, C)]
            pts = [A, B, C, D]
        else:
            dim = 2 if name == "incircle" else 3
            centre = [Fraction(float(x)) for x in rng.uniform(-1, 1, dim)]
            r = Fraction(int(rng.integers(1, 9)), 8)
            pts = []
            for _ in range(dim + 2):  # rational points of the circle / sphere
                u = [Fraction(int(rng.integers(-20, 21)), 13) for _ in range(dim - 1)]
                q = sum(x * x for x in u)
                unit = [2 * x / (1 + q) for x in u] + [(q - 1) / (1 + q)]
                pts.append([c + r * x for c, x in zip(centre, unit)])
        rounded = [np.array([float(c) for c in p]).astype(dtype) for p in pts]
        k = int(rng.integers(0, 4)) * int(rng.choice([-1, 1]))
        last = rounded[-1].copy()
        for _ in range(abs(k)):
            last = np.nextafter(last, np.sign(k) * np.inf).astype(dtype)
        rounded[-1] = last
        out.append(rounded)
    return [np.array([lane[i] for lane in out], dtype=dtype) for i in range(len(out[0]))]


PREDICATES = [classic.orient2d, classic.orient3d, classic.incircle, classic.insphere]


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("pred", PREDICATES, ids=lambda p: p.name)
@pytest.mark.parametrize("kind,offset,scale", [("random", 0.0, 0), ("degenerate", 0.0, 0),
                                               ("degenerate", 2.0 ** 20, 0),
                                               ("degenerate", 2.0 ** 40, 0),
                                               ("degenerate", 0.0, 500),
                                               ("degenerate", 0.0, -500)])
def test_filtered_sign_is_the_exact_sign(pred, dtype, kind, offset, scale):
    if dtype == np.float32 and abs(scale) > 100:
        scale = int(np.sign(scale)) * 60  # float32's range: 2^±60 is its far scale
    rng = np.random.default_rng(abs(hash((pred.name, kind, offset, scale))) % 2 ** 32)
    n = 40
    if kind == "random":
        pts = [rng.uniform(-1, 1, (n, pred.dim)).astype(dtype) for _ in pred.points]
    else:
        pts = _on_the_locus(pred.name, rng, n, dtype)
    pts = [np.ldexp(p + dtype(offset), scale).astype(dtype) for p in pts]
    signs, share = pred.decide(*pts)
    want = [_exact_sign(pred.name, [p[i] for p in pts]) for i in range(n)]
    assert signs.tolist() == want
    if kind == "degenerate" and offset == 0 and scale == 0:
        assert share > 0  # the exact path ran
    if kind == "random" and dtype == np.float64:
        assert share == 0


def test_batch_shapes_broadcast_like_numpy():
    A = np.zeros(2)
    B = np.array([1.0, 0.0])
    C = np.random.default_rng(1).uniform(-1, 1, (3, 4, 2))
    s = classic.orient2d(A, B, C)
    assert s.shape == (3, 4) and (s == np.sign(C[..., 1])).all()


def test_the_premise_is_established_not_assumed():
    """A unit triangle at offset 2^20: the static bound for L = 1 would be wrong there;
    the per-lane L of its magnitude decides it right (exact determinant 1, here ±1)."""
    @sign_predicate(dim=2, points="ABC")
    def shoelace(A, B, C):  # the sum of cross products: not translation-invariant
        return (A[0] * B[1] - B[0] * A[1]) + (B[0] * C[1] - C[0] * B[1]) \
            + (C[0] * A[1] - A[0] * C[1])

    o = 2.0 ** 20
    A, B, C = np.array([o, o]), np.array([o + 1, o]), np.array([o, o + 1])
    for per_lane in (True, False):
        sign, _ = shoelace.decide(A, B, C, per_lane=per_lane)
        assert int(sign) == 1
        sign, _ = shoelace.decide(A, C, B, per_lane=per_lane)
        assert int(sign) == -1
    assert shoelace.threshold(2.0 ** 21) > shoelace.threshold(1.0) * 2.0 ** 40


def test_thresholds_are_rounded_up_from_the_exact_bound():
    b = classic.orient3d.bound
    from fperr.symbols import L, eps
    for dtype, bits in ((np.float64, 53), (np.float32, 24)):
        exact = Fraction(str(sympy.nsimplify(b.E.subs({eps: sympy.Rational(1, 2 ** bits), L: 1})
                                             * (1 + sympy.Rational(1, 2 ** bits)))))
        k = Fraction(classic.orient3d.threshold(1.0, dtype))
        assert exact <= k <= exact * (1 + Fraction(1, 2 ** 20))  # up, and barely
        big = Fraction(classic.orient3d.threshold(3.0, dtype))  # K·L^p, every step up
        assert exact * 27 <= big <= exact * 27 * (1 + Fraction(1, 2 ** 20))
