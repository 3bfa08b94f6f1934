"""The context protocol (fperr.contexts): the factory, correct rounding against
independent references, exact round trips, and the format facts predicates rely on."""
from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from mpmath import libmp

import fperr
from fperr import ROUNDING, round_fraction

NAMES = {
    "binary64": (fperr.FloatContext, 53), float: (fperr.FloatContext, 53),
    None: (fperr.FloatContext, 53), "binary32": (fperr.NumpyContext, 24),
    "numpy.float32": (fperr.NumpyContext, 24), "float32": (fperr.NumpyContext, 24),
    np.float32: (fperr.NumpyContext, 24), np.dtype(np.float64): (fperr.NumpyContext, 53),
    "numpy.float64": (fperr.NumpyContext, 53), "mp17": (fperr.MpContext, 17),
    17: (fperr.MpContext, 17), "mp300": (fperr.MpContext, 300),
    "exact": (fperr.ExactContext, None), Fraction: (fperr.ExactContext, None),
    "tracked": (fperr.TrackedContext, None),
}


@pytest.mark.parametrize("spec", list(NAMES), ids=str)
def test_factory_returns_the_named_context(spec):
    cls, bits = NAMES[spec]
    ctx = fperr.context(spec)
    assert type(ctx) is cls and ctx.bits == bits
    assert type(fperr.context(ctx.format)) is cls          # the name round-trips
    assert fperr.context(ctx) is ctx
    if bits is not None:
        assert fperr.to_fraction(ctx.eps) == Fraction(1, 2**bits)


@pytest.mark.parametrize("spec", ["binary16", "mp1", "float16", True, "nonsense"])
def test_factory_refuses_unknown_systems(spec):
    with pytest.raises((ValueError, TypeError)):
        fperr.context(spec)


# --------------------------------------------------------------------------------------
# independent references: the platform's conversions and neighbours, decided exactly
# --------------------------------------------------------------------------------------
def _ieee_reference(q: Fraction, rounding: str, dtype) -> Fraction | float:
    """Correct rounding into a numpy/IEEE format from the format's own neighbours."""
    t = np.dtype(dtype).type
    try:
        f = float(q)
    except OverflowError:  # beyond binary64: infinity of q's sign
        f = np.inf if q > 0 else -np.inf
    with np.errstate(over="ignore"):
        c = t(f)
        cands = [np.nextafter(c, t(-np.inf)), c, np.nextafter(c, t(np.inf))]
    fin = sorted({Fraction(float(v)) for v in cands if np.isfinite(v)})
    below = [v for v in fin if v <= q]
    above = [v for v in fin if v >= q]
    fi = np.finfo(dtype)
    big = Fraction(float(fi.max))
    if rounding == "up":
        return above[0] if above else np.inf
    if rounding == "down":
        return below[-1] if below else -np.inf
    if rounding == "zero":
        return (below[-1] if below else -big) if q > 0 else (above[0] if above else big)
    lo, hi = (below[-1] if below else None), (above[0] if above else None)
    if lo is None or hi is None:
        return float(c)
    if lo == hi:  # representable
        return lo
    if q - lo != hi - q:
        return lo if q - lo < hi - q else hi
    bits = {np.float64: np.int64, np.float32: np.int32}[dtype]
    even = [v for v in (lo, hi) if not int(np.array(float(v), dtype).view(bits)) & 1]
    return even[0]


_MP_MODE = {"nearest": "n", "up": "c", "down": "f", "zero": "d"}


def _check_against_reference(ctx, dtype, q):
    for mode in ROUNDING:
        w = ctx.from_fraction(q, mode)
        if dtype is None:  # mpmath's own correct rounding
            want = fperr.to_fraction(mpmath.mp.make_mpf(
                libmp.from_rational(q.numerator, q.denominator, ctx.bits, _MP_MODE[mode])))
            assert ctx.to_fraction(w) == want, (q, mode)
            continue
        want = _ieee_reference(q, mode, dtype)
        if isinstance(want, float):  # overflow
            assert float(w) == want, (q, mode)
        else:
            assert ctx.to_fraction(w) == want, (q, mode, w)
        if np.isfinite(float(w)):
            assert ctx.from_fraction(ctx.to_fraction(w), mode) == w   # round trip


FORMATS = [("binary64", np.float64), ("binary32", np.float32), ("mp17", None)]


def _fractions(bits, emin, emax):
    mant = st.integers(-(2 ** (bits + 3)), 2 ** (bits + 3))
    return st.builds(lambda m, e, d: Fraction(m) * Fraction(2) ** e / d, mant,
                     st.integers(emin, emax), st.sampled_from([1, 3, 5, 7, 10]))


@pytest.mark.parametrize("name, dtype", FORMATS)
@given(data=st.data())
def test_from_fraction_is_correctly_rounded(name, dtype, data):
    ctx = fperr.context(name)
    if dtype is None:
        q = data.draw(_fractions(ctx.bits, -200, 200))
    else:
        fi = np.finfo(dtype)
        q = data.draw(_fractions(ctx.bits, fi.minexp - ctx.bits - 8, fi.maxexp - ctx.bits))
    _check_against_reference(ctx, dtype, q)


@pytest.mark.parametrize("name, dtype", FORMATS)
def test_from_fraction_ties_and_boundaries(name, dtype):
    ctx = fperr.context(name)
    p = ctx.bits
    one_ulp = Fraction(1, 2 ** (p - 1))
    cases = [Fraction(0), 1 + one_ulp / 2, 1 + 3 * one_ulp / 2, -(1 + one_ulp / 2),
             Fraction(1, 3), Fraction(-1, 10), 2 - one_ulp / 4, (2 ** p + 1) * Fraction(1, 2)]
    for q in cases:
        _check_against_reference(ctx, dtype, q)
    # ties go to even: 1 + ulp/2 -> 1, 1 + 3ulp/2 -> 1 + 2ulp
    assert ctx.to_fraction(ctx.from_fraction(1 + one_ulp / 2)) == 1
    assert ctx.to_fraction(ctx.from_fraction(1 + 3 * one_ulp / 2)) == 1 + 2 * one_ulp
    if dtype is None:
        return
    tiny = ctx.min_normal / 2 ** (p - 1)  # the smallest subnormal
    assert fperr.to_fraction(dtype(np.finfo(dtype).smallest_subnormal)) == tiny
    for q in (tiny / 2, 3 * tiny / 2, tiny / 3, ctx.min_normal - tiny / 2,
              ctx.min_normal + tiny / 2, -tiny / 2, ctx.max_finite * (1 + one_ulp / 4),
              ctx.max_finite * (1 + one_ulp / 2), -ctx.max_finite * 2):
        _check_against_reference(ctx, dtype, q)
    assert ctx.to_fraction(ctx.from_fraction(tiny / 2)) == 0            # tie to even (0)
    assert ctx.to_fraction(ctx.from_fraction(3 * tiny / 2)) == 2 * tiny
    assert ctx.to_fraction(ctx.from_fraction(tiny / 3, "up")) == tiny
    assert float(ctx.from_fraction(ctx.max_finite * 2, "zero")) == float(ctx.max_finite)


@pytest.mark.parametrize("name", ["binary64", "binary32", "mp17", "exact"])
@given(m=st.integers(-(2**17), 2**17), e=st.integers(-60, 60))
def test_round_trip_and_convert(name, m, e):
    ctx = fperr.context(name)
    q = Fraction(m) * Fraction(2) ** e   # 17 bits: every format holds it
    w = ctx.convert(q)
    assert ctx.to_fraction(w) == q and ctx.from_fraction(q) == w


@pytest.mark.parametrize("name, bad", [("binary64", Fraction(1, 3)), ("binary32", 0.1),
                                       ("mp17", 2**17 + 1), ("binary32", 1e39)])
def test_convert_refuses_what_the_format_cannot_hold(name, bad):
    with pytest.raises(ValueError, match="not representable"):
        fperr.context(name).convert(bad)


def test_to_fraction_refuses_numbers_of_another_type():
    with pytest.raises(TypeError):
        fperr.context("binary32").to_fraction(np.float64(1.0))   # a silent promotion
    with pytest.raises(TypeError):
        fperr.context("mp17").to_fraction(1.0)
    with pytest.raises(TypeError):
        fperr.context("binary64").convert(fperr.coord("x"))
    with pytest.raises(TypeError, match="tracked_tolerances"):
        fperr.context("tracked").convert(0.5)


def test_round_fraction_modes():
    q = Fraction(-7, 3)  # -2.333..: 4 bits give spacing 1/4
    assert [round_fraction(q, 4, m) for m in ROUNDING] == [
        Fraction(-9, 4), Fraction(-9, 4), Fraction(-5, 2), Fraction(-9, 4)]
    with pytest.raises(ValueError, match="rounding"):
        round_fraction(q, 4, "z")


def test_eps_multiple_is_the_exact_constant():
    for name in ("binary64", "binary32", "mp17"):
        ctx = fperr.context(name)
        with ctx.session():
            v = ctx.eps_multiple(Fraction(21), 2)
        assert ctx.to_fraction(v) == 21 * Fraction(1, 2**ctx.bits) ** 2
    t = fperr.context("tracked").eps_multiple(Fraction(21), 2)
    assert t.rule == "J" and t.a == 0 and str(t.s) == "[21*eps**2]"


def test_exact_context_square_roots():
    from fractions import Fraction
    assert fperr.ExactContext().sqrt(Fraction(9, 4)) == Fraction(3, 2)   # rational: exact
    r = fperr.ExactContext(sqrt_bits=64).sqrt(Fraction(2))                # else truncated
    assert r * r <= 2 < (r + Fraction(1, 2**60)) ** 2
    with pytest.raises(ValueError, match="irrational"):
        fperr.ExactContext(sqrt_bits=None).sqrt(Fraction(2))
    with pytest.raises(ValueError, match="negative"):
        fperr.ExactContext().sqrt(Fraction(-1))
