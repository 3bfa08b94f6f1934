"""The cut's exact signs and row ids against independent references: ``polytri.det_sign``
and ``search._exact_sign`` (floats as power-of-two-scaled integers) against ``Fraction``
determinants, on near-degenerate and exactly degenerate inputs spanning many binades;
``levels.complex.row_ids`` and ``single_rows`` against ``np.unique(axis=0)``'s inverse map
and counts."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from predicates.registration.levels.complex import row_ids, single_rows
from predicates.registration.split.polytri import det_sign, dyadic_integers
from predicates.registration.split.search import _exact_sign

_FLOATS = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)


def _det3(a, b, c) -> int:
    A, B, C = ([Fraction(x) for x in r] for r in (a, b, c))
    e = (A[0] * (B[1] * C[2] - B[2] * C[1]) - A[1] * (B[0] * C[2] - B[2] * C[0])
         + A[2] * (B[0] * C[1] - B[1] * C[0]))
    return (e > 0) - (e < 0)


def _near_plane(rng, scale_a, scale_b):
    """Rows a, b and c = s·a + t·b: exact (small integers times powers of two, dyadic
    s and t: the determinant is exactly 0) or rounded and nudged by an ulp."""
    if rng.random() < 0.5:
        a = rng.integers(-64, 65, 3) * scale_a
        b = rng.integers(-64, 65, 3) * scale_b
        s, t = rng.integers(-8, 9) / 8, rng.integers(-8, 9) / 4
    else:
        a, b = rng.uniform(-1, 1, 3) * scale_a, rng.uniform(-1, 1, 3) * scale_b
        s, t = rng.random(), rng.random()
    c = a * s + b * t
    if rng.random() < 0.3:
        c = c * (1 + rng.choice([0.0, 2.0 ** -52, -2.0 ** -52]))
    return a.tolist(), b.tolist(), c.tolist()


def test_det_sign_is_the_exact_sign_near_and_on_degeneracy():
    rng = np.random.default_rng(11)
    zeros = 0
    for _ in range(4000):
        a, b, c = _near_plane(rng, 2.0 ** rng.integers(-20, 20), 2.0 ** rng.integers(-20, 20))
        want = _det3(a, b, c)
        zeros += want == 0
        assert det_sign(a, b, c) == want
    assert zeros > 50  # the exact path ran on exact zeros, not only the filter


def test_det_sign_collinear_weights_are_zero():
    # weights of points on one edge of the frame: 0 on the opposite corner
    a, b, c = [0.25, 0.75, 0.0], [0.1, 0.9, 0.0], [0.0, 0.0, 1.0]
    assert det_sign(a, b, [0.3, 0.7, 0.0]) == 0
    assert det_sign(a, b, c) == _det3(a, b, c) != 0


@settings(max_examples=300, deadline=None)
@given(st.lists(_FLOATS, min_size=9, max_size=9))
def test_det_sign_matches_fractions_on_any_rows(v):
    a, b, c = v[0:3], v[3:6], v[6:9]
    assert det_sign(a, b, c) == _det3(a, b, c)


def test_dyadic_integers_are_the_floats_times_one_power_of_two():
    vals = [3.0, 0.5, -2.0 ** -60, 1e300, 0.0, 2.0 ** -1074]
    z = dyadic_integers(vals)
    k = Fraction(z[0]) / Fraction(vals[0])
    assert k.denominator == 1 and (k.numerator & (k.numerator - 1)) == 0  # a power of two
    assert all(Fraction(zi) == Fraction(x) * k for zi, x in zip(z, vals))


def test_tetrahedron_exact_sign_matches_fractions():
    rng = np.random.default_rng(12)
    signs = set()
    for _ in range(3000):
        k = 2.0 ** rng.integers(-40, 40)
        if rng.random() < 0.5:  # D in the plane of A, B, C: exactly (dyadic) or rounded
            T = rng.integers(-64, 65, (4, 3)) * k
            T[3] = T[0] + (T[1] - T[0]) * 0.5 + (T[2] - T[0]) * 0.25
        else:
            T = rng.uniform(-1, 1, (4, 3)) * k
            T[3] = T[0] + (T[1] - T[0]) * rng.random() + (T[2] - T[0]) * rng.random()
        E = [[Fraction(float(x)) - Fraction(float(y)) for x, y in zip(p, T[0])] for p in T[1:]]
        want = _det3(*E)
        signs.add(want)
        assert _exact_sign(T) == want
    assert signs == {-1, 0, 1}


def test_row_ids_is_numpys_unique_inverse():
    rng = np.random.default_rng(13)
    for n, m, w in ((4, 50, 3), (1000, 20000, 3), (3_000_000, 5000, 3), (30, 500, 2)):
        rows = rng.integers(0, n, size=(m, w))
        want = np.unique(rows, axis=0, return_inverse=True)[1].ravel()
        assert np.array_equal(row_ids(rows), want)
        cnt = np.unique(rows, axis=0, return_inverse=True, return_counts=True)[2]
        assert np.array_equal(single_rows(rows), cnt[want] == 1)
    assert row_ids(np.zeros((0, 3), dtype=np.int64)).shape == (0,)
    assert single_rows(np.zeros((0, 3), dtype=np.int64)).shape == (0,)
