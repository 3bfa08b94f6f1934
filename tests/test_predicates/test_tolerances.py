"""Tolerances (Algorithms 1 and 6): L bounds L̂, L^p is exact, every T is within its
derived relative error of the exact C·ε^q·L^p and strictly inside (T−, T+), and the
instrumented run of the same code gives R[T] ≤ 4ε (Figures 1 and 5).

Exact references: Fractions (L, L̂, T⁴ against T±⁴) and mpmath at 300 bits (T itself,
irrational in 3D). Formats: binary64 (numpy float64 and Python floats), binary32 and
mpmath at 17 bits.
"""
from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import sympy
from hypothesis import example, given, settings
from hypothesis import strategies as st

import fperr
import predicates
from geometry_exact import frac, round_bits, significand_bits, threshold4
from predicates import d2, d3
from predicates.tolerance_table import L_ROOT, L_SIGMA_PLUS, TABLES

NAMES = {2: ("sigma", "tau", "sigma_hat", "kappa"),
         3: ("sigma", "tau", "delta", "gamma", "sigma_hat", "lam", "phi", "nu", "zeta",
             "mu", "xi", "rho")}

#: dtype -> (significand bits, type of the returned values)
FORMATS = {"float64": (np.float64, 53, np.float64), "float": (float, 53, float),
           "float32": (np.float32, 24, np.float32), "mp17": ("mp17", 17, mpmath.mpf)}


def L_hat_ok(L: Fraction, S: Fraction, eps: Fraction, dim: int) -> bool:
    """Exactly: L ≥ L̂ = S/(1 − 7ε^g), g = 1/2 (2D) or 1/4 (3D).

    L(1 − 7ε^g) ≥ S  ⇔  (L − S)/(7L) ≥ ε^g  ⇔  ((L − S)/(7L))^(1/g) ≥ ε  (L ≥ S)."""
    k = int(1 / L_ROOT[dim])
    x = (L - S) / (L_SIGMA_PLUS * L)
    return x >= 0 and x**k >= eps


def L_hat_mp(S: Fraction, eps: Fraction, dim: int):
    with mpmath.workprec(300):
        g = mpmath.mpf(1) / int(1 / L_ROOT[dim])
        e = mpmath.mpf(eps.numerator) / eps.denominator
        return (mpmath.mpf(S.numerator) / S.denominator) / (1 - L_SIGMA_PLUS * e**g)


#: exponent range of L_a, L_b per significand width: where every tolerance and every
#: quantity of the predicates (up to degree 6) is a normal number (the paper's "no
#: underflow or overflow"; see test_scale_outside_the_formats_range_is_refused_clearly),
#: inside predicates.tolerances.safe_scale_range for both dimensions with room for L/L_a
SAFE_RANGE = {53: (2.0**-150, 2.0**150), 24: (2.0**-16, 2.0**18), 17: (2.0**-300, 2.0**300)}


def _lengths(bits):
    """L_a, L_b over the safe exponent range: exact in the format, or any binary64 value
    (rounded *up* into the format by tolerances(): L̂ is checked against the values
    given), zero for one of them."""
    lo, hi = SAFE_RANGE[bits]
    mag = st.one_of(st.floats(lo, hi).map(lambda x: float(round_bits(x, bits))),
                    st.floats(lo, hi))
    return st.tuples(mag, st.one_of(st.just(0.0), mag))


def _grid_lengths(dim, bits):
    """(L_a, 0) with L_a/(1 − 7ε^g) within a few ulps of a ⌊bits/4⌋-bit number: the
    final rounding up of L then adds no slack, so F[L] ≥ L̂ rests on the (1 + 5ε)."""
    eps = Fraction(1, 2**bits)
    root = mpmath.mpf(eps.numerator) / eps.denominator
    root = mpmath.sqrt(root) if dim == 2 else mpmath.sqrt(mpmath.sqrt(root))
    out = []
    for mant in range(2 ** (bits // 4 - 1), 2 ** (bits // 4), max(1, 2 ** (bits // 4 - 3))):
        for e in (-7, 0, 11):
            G = Fraction(mant) * Fraction(2) ** e
            with mpmath.workprec(300):
                S = mpmath.mpf(G.numerator) / G.denominator * (1 - 7 * root)
            for k in (-2, 0, 2):
                s = round_bits(Fraction(str(S)), bits)
                s += k * Fraction(2) ** (s.numerator.bit_length() - s.denominator.bit_length() - bits)
                out.append((float(round_bits(s, bits)), 0.0))
    return out


@pytest.mark.parametrize("dim", (2, 3))
@pytest.mark.parametrize("fmt", list(FORMATS))
def test_L_bounds_L_hat_and_powers_are_exact(dim, fmt):
    dtype, bits, _ = FORMATS[fmt]
    eps = Fraction(1, 2**bits)

    def check(L_a, L_b):
        tol = predicates.tolerances(dim, L_a, L_b, dtype=dtype)
        L = frac(tol.L)
        S = Fraction(L_a) + Fraction(L_b)
        assert frac(tol.eps) == eps
        assert L_hat_ok(L, S, eps, dim), f"F[L] = {L} < L̂ for L_a={L_a!r}, L_b={L_b!r}"
        # L is rounded up to ⌊prec/4⌋ bits (so L², L³, L⁴ are exact), and no further than
        # one unit of that grid beyond the computed value (1 + 5ε)/(1 − 7ε^g)·(L_a + L_b)
        assert significand_bits(L) <= bits // 4
        for p in (1, 2, 3, 4):
            assert significand_bits(L**p) <= bits, f"L^{p} not exact"
        with mpmath.workprec(300):
            upper = L_hat_mp(S, eps, dim) * (1 + 2 * mpmath.mpf(2) ** (1 - bits // 4)) \
                * (1 + 16 * mpmath.mpf(eps.numerator) / eps.denominator)
            assert mpmath.mpf(L.numerator) / L.denominator <= upper, "L needlessly large"

    cases = _grid_lengths(dim, bits) + [(1.0, 1.0), (1.0, 0.0), (0.0, 3.0),
                                        (0.1, 0.2), (1 / 3, 0.0), (0.0, 1e-3 / 3)]
    for L_a, L_b in cases:
        check(L_a, L_b)

    @settings(max_examples=max(20, settings.default.max_examples // 4))
    @given(_lengths(bits))
    def random_lengths(ab):
        check(*ab)
    random_lengths()


@pytest.mark.parametrize("dim", (2, 3))
@pytest.mark.parametrize("fmt", list(FORMATS))
@settings(max_examples=max(10, settings.default.max_examples // 10))
@given(data=st.data())
@example(data=None)
def test_each_tolerance_within_its_derived_relative_error(dim, fmt, data):
    """|F[T] − C·ε^q·L^p| ≤ R[T]·C·ε^q·L^p, with R[T] from the instrumented run, and
    T− < F[T] < T+ (exact), for every tolerance of Figure 1 / Figure 5."""
    dtype, bits, vtype = FORMATS[fmt]
    if data is None:
        L_a, L_b = 1.0, 1.0
    else:
        L_a, L_b = data.draw(_lengths(bits))
    eps = Fraction(1, 2**bits)
    tol = predicates.tolerances(dim, L_a, L_b, dtype=dtype)
    tracked = predicates.tracked_tolerances(dim)
    assert tol.names() == NAMES[dim] and set(tracked.names()) == set(NAMES[dim])
    L = frac(tol.L)
    for name in NAMES[dim]:
        value = tol.values[name]
        assert type(value) is vtype, f"{name}: {type(value)}"
        assert getattr(tol, name) is value
        T = frac(value)
        R = fperr.bounds(tracked.values[name]).R
        assert R is not None, f"{name}: the tolerance's error must be relative (r)"
        R_eps = R.subs(fperr.eps, sympy.Rational(eps.numerator, eps.denominator))
        with mpmath.workprec(300):
            exact = mpmath.root(_mp(threshold4(dim, name, "mid", eps, L)), 4)
            err = abs(_mp(T) - exact)
            assert err <= _mp(Fraction(str(sympy.N(R_eps, 60)))) * exact * (1 + mpmath.mpf(10)**-50), \
                f"{name}: F[T] = {float(T)!r} off by {float(err / exact):.3g} relative > R[T]"
        T4 = T**4
        assert threshold4(dim, name, "lo", eps, L) < T4 < threshold4(dim, name, "hi", eps, L), \
            f"{name} = {float(T)!r} not strictly inside (T−, T+)"


def _mp(q: Fraction):
    return mpmath.mpf(q.numerator) / q.denominator


@pytest.mark.parametrize("dim", (2, 3))
def test_instrumented_tolerances_relative_error_at_most_four_eps(dim):
    tracked = predicates.tracked_tolerances(dim)
    assert set(tracked.names()) == set(NAMES[dim])
    for name in NAMES[dim]:
        b = fperr.bounds(predicates.tracked_tolerances(dim).values[name])
        assert b.valid and b.relative, name
        assert b.R_int is not None and b.R_int <= 4, f"R[{name}] = {b.R_int}ε > 4ε"
        # its magnitude is the table's: c = coefficient·ε^q, p as in Figure 1/5
        spec = TABLES[dim][name]
        t = tracked.values[name]
        assert sympy.simplify(t.c - spec.mid * fperr.eps**spec.q) == 0, (name, t.c)
        assert t.p == spec.p


# ---------------------------------------------------------------------------------
# clear errors


@pytest.mark.parametrize("L_a, L_b", [(-1.0, 1.0), (1.0, -0.5), (math.nan, 1.0),
                                      (1.0, math.inf), (0.0, 0.0), (-math.inf, 0.0)])
@pytest.mark.parametrize("dim", (2, 3))
def test_bad_lengths_are_refused(dim, L_a, L_b):
    for dtype in (np.float64, np.float32, "mp17", float):
        with pytest.raises(ValueError, match="L_a|L_b"):
            predicates.tolerances(dim, L_a, L_b, dtype=dtype)


@pytest.mark.parametrize("dim", (0, 1, 4))
def test_bad_dimension_is_refused(dim):
    with pytest.raises(ValueError, match="dim"):
        predicates.tolerances(dim, 1.0, 1.0)


def test_float64_tolerances_refused_for_float32_inputs():
    A = np.zeros((3, 2), dtype=np.float32)
    B = np.ones((3, 2), dtype=np.float32)
    for dtype in (np.float64, float):
        tol = predicates.tolerances(2, 1.0, 1.0, dtype=dtype)
        with pytest.raises(ValueError, match="ε|float32|dtype"):
            d2.vertex_vertex(A, B, tol)
    A3 = np.zeros((3, 3), dtype=np.float32)
    tol3 = predicates.tolerances(3, 1.0, 1.0, dtype=np.float64)
    with pytest.raises(ValueError, match="ε"):
        d3.edge_vertex(A3, A3 + 1, A3 + 0.5, tol3)
    # the right ones work, and a coarser (larger-ε) set is accepted by finer arithmetic
    tol32 = predicates.tolerances(2, 1.0, 1.0, dtype=np.float32)
    hit, _ = d2.vertex_vertex(A, B, tol32)
    assert hit.tolist() == [False] * 3
    assert d2.vertex_vertex(A.astype(np.float64), A.astype(np.float64), tol32)[0].all()


def test_float64_tolerances_refused_for_17_bit_arithmetic():
    tol = predicates.tolerances(2, 1.0, 1.0, dtype=float)
    with pytest.raises(ValueError, match="ε"):
        d2.vertex_vertex((0.0, 0.0), (1.0, 0.0), tol, ctx=fperr.MpContext(17))
    tol17 = predicates.tolerances(2, 1.0, 1.0, dtype="mp17")
    assert d2.vertex_vertex((0.0, 0.0), (1.0, 0.0), tol17, ctx=fperr.MpContext(17)) == (False, ())


def test_mixed_up_tolerance_objects_are_refused():
    tol2 = predicates.tolerances(2, 1.0, 1.0, dtype=float)
    with pytest.raises(TypeError, match="3D"):
        d3.vertex_vertex((0.0, 0, 0), (1.0, 0, 0), tol2)
    with pytest.raises(TypeError, match="tracked"):
        d2.vertex_vertex((0.0, 0.0), (1.0, 0.0), predicates.tracked_tolerances(2))
    pts = [tuple(fperr.coord(f"{p}.{a}") for a in "xy") for p in "AB"]
    with pytest.raises(TypeError, match="tracked"):
        d2.vertex_vertex(*pts, tol2)


def test_17_bit_context_refuses_unrepresentable_coordinates():
    tol = predicates.tolerances(2, 1.0, 1.0, dtype="mp17")
    with pytest.raises(ValueError, match="representable"):
        d2.vertex_vertex((0.1, 0.0), (1.0, 0.0), tol, ctx=fperr.MpContext(17))


# Was a bug (subnormal tolerances accepted, OverflowError on huge scales); fixed by
# predicates.tolerances.check_scale.
@pytest.mark.parametrize("dtype, L_a", [(np.float32, 2.0**-30), (np.float32, 2.0**40),
                                        (np.float64, 2.0**-250)],
                         ids=["f32-tiny", "f32-huge", "f64-tiny"])
def test_scale_outside_the_formats_range_is_refused_clearly(dtype, L_a):
    with pytest.raises((ValueError, ArithmeticError), match="(?i)underflow|overflow|range"):
        predicates.tolerances(3, L_a, 0.0, dtype=dtype)


def test_unsupported_dimensions_and_missing_tolerances_say_so():
    """dim=4 and a tolerance the table lacks are clear errors, not a bare KeyError or
    AttributeError (docs/custom-predicates.md)."""
    from predicates.core import predicate
    from predicates.vector import cross2, sub

    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        predicates.tolerances(4, 1.0, 1.0)
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        predicate(dim=4, points="AB")

    @predicate(dim=2, points="ABC")
    def near_line(ctx, A, B, C, tol):
        o = ctx.name("o", cross2(sub(B, A), sub(C, A)))
        if ctx.reject(abs(o) > tol.omega, line=1):
            return ctx.miss()
        return ctx.hit(())

    with pytest.raises(ValueError, match=r"tolerance 'omega' is not in the paper's Figure 1"
                                         r".*near_line.instrumented\("):
        near_line.instrumented()


@settings(max_examples=30, deadline=None)
@given(L_a=st.floats(1e-3, 1e3), L_b=st.floats(0, 1e3), scale=st.floats(0.5, 2))
def test_the_cached_coefficients_give_every_tolerance_bit_for_bit(L_a, L_b, scale):
    """The plain float contexts keep Figure 1/5's coefficients per dimension and format
    (``tolerances._ROOTS``): with them, every tolerance of both dimensions and every
    float format has the bits and type of a computation from the same table given
    explicitly (which is never cached), for the L that filled the cache and another."""
    import sys

    module = sys.modules["predicates.tolerances"]  # (the package's name is the function)
    module._ROOTS.clear()
    for a, b in ((L_a, L_b), (L_a * scale, L_b)):
        for dim in (2, 3):
            for dtype in (np.float64, np.float32, float):
                got = predicates.tolerances(dim, a, b, dtype=dtype)
                fresh = predicates.tolerances(dim, a, b, dtype=dtype, table=TABLES[dim])
                assert got.L == fresh.L and got.values.keys() == fresh.values.keys()
                for name, value in fresh.values.items():
                    assert type(got.values[name]) is type(value)
                    assert np.asarray(got.values[name]).tobytes() == \
                        np.asarray(value).tobytes()
    assert len(module._ROOTS) == 6, "each (dimension, format) keeps its coefficients"
