"""Filtered predicates equal the exact sign on every lane; rule K's premise is checked.

Ground truth is independent of the predicate source: each classic determinant is the
determinant of its matrix (Laplace expansion) in Fractions of the floats given. Inputs:
random, near-degenerate (points built exactly on a line / plane / circle / sphere from
rational parameters, then rounded: within an ulp or so of the degenerate set),
translated (offset 2^20, 2^40) and scaled (2^±500 in binary64; binary32 has no such
range, 2^±40 there), float64 and float32, seeded and with hypothesis.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from determinants import exact_det, exact_signs
from hypothesis import given, settings
from hypothesis import strategies as st

import predicates
from predicates import classic
from predicates.core import predicate
from predicates.filtered import FilteredPredicate, filtered
from predicates.premise import PremiseError
from proofs.user_predicates import PredicateTolerances

NAMES = ("orient2d", "orient3d", "incircle", "insphere")




def test_exact_reference_conventions():
    """The reference has Shewchuk's signs: counter-clockwise, below, inside."""
    assert exact_det("orient2d", [(0, 0), (1, 0), (0, 1)]) > 0
    assert exact_det("orient3d", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, -1)]) > 0
    assert exact_det("incircle", [(0, 0), (1, 0), (0, 1), (0.25, 0.25)]) > 0
    tet = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, -1)]
    assert exact_det("insphere", tet + [(0.2, 0.2, -0.2)]) > 0


# -- inputs ----------------------------------------------------------------------------
def _round(q, dtype):
    return dtype(float(q))  # correctly rounded to binary64 (then to binary32)


def _circle_point(t):
    """A rational point on the unit circle: ((1 − t²), 2t)/(1 + t²)."""
    return ((1 - t * t) / (1 + t * t), 2 * t / (1 + t * t))


def _sphere_point(u, v):
    """A rational point on the unit sphere (inverse stereographic projection)."""
    s = 1 + u * u + v * v
    return (2 * u / s, 2 * v / s, (u * u + v * v - 1) / s)


def _rat(rng):
    return Fraction(int(rng.integers(-2**20, 2**20)), 2**19)


def near_degenerate(name, n, rng, dtype, offset=0, scale=1):
    """n lanes of points built exactly on the degenerate set, then rounded once."""
    lanes = []
    for _ in range(n):
        if name == "orient2d":
            A, B = [(_rat(rng), _rat(rng)) for _ in range(2)]
            t = _rat(rng) + Fraction(int(rng.integers(0, 3)), 3 * 2**40)  # not dyadic
            pts = [A, B, tuple(a + t * (b - a) for a, b in zip(A, B))]
        elif name == "orient3d":
            A, B, C = [(_rat(rng), _rat(rng), _rat(rng)) for _ in range(3)]
            s, t = _rat(rng), _rat(rng) + Fraction(int(rng.integers(0, 3)), 3 * 2**40)
            pts = [A, B, C, tuple(a + s * (b - a) + t * (c - a) for a, b, c in zip(A, B, C))]
        elif name == "incircle":
            pts = [_circle_point(_rat(rng)) for _ in range(4)]
        else:
            pts = [_sphere_point(_rat(rng), _rat(rng)) for _ in range(5)]
        lane = [[_round(Fraction(offset) + Fraction(scale) * c, dtype) for c in p]
                for p in pts]
        for _ in range(int(rng.integers(0, 3))):  # and a few ulps off
            lane[-1][0] = np.nextafter(lane[-1][0], dtype(np.inf) * rng.choice([-1, 1]))
        lanes.append(lane)
    return [np.array([lane[k] for lane in lanes], dtype=dtype) for k in range(len(lanes[0]))]


_CIRCLE5 = [(5, 0), (-5, 0), (0, 5), (0, -5)] + [(sx * a, sy * b) for a, b in ((3, 4), (4, 3))
                                                 for sx in (1, -1) for sy in (1, -1)]
_SPHERE3 = ([tuple(3 * s if i == k else 0 for i in range(3)) for k in range(3) for s in (1, -1)]
            + [(sx * a, sy * b, sz * c) for a, b, c in ((1, 2, 2), (2, 1, 2), (2, 2, 1))
               for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)])


def exactly_degenerate(name, n, rng, offset):
    """n lanes of integer points exactly on a line / plane / circle / sphere, moved by
    ``offset`` (exact below 2^53): every determinant is 0, only the exact path decides."""
    lanes = []
    for _ in range(n):
        c = rng.integers(-8, 8, size=3)
        if name == "orient2d":
            A, D = rng.integers(-8, 8, size=(2, 2))
            pts = [A + k * D for k in rng.integers(-4, 4, size=3)]
        elif name == "orient3d":
            A, D, E = rng.integers(-8, 8, size=(3, 3))
            pts = [A + j * D + k * E for j, k in rng.integers(-4, 4, size=(4, 2))]
        else:
            pool = _CIRCLE5 if name == "incircle" else _SPHERE3
            pts = [np.array(pool[i]) + c[: len(pool[0])]
                   for i in rng.integers(0, len(pool), size=4 if name == "incircle" else 5)]
        lanes.append(pts)
    return [np.array([lane[k] for lane in lanes], dtype=np.float64) + offset
            for k in range(len(lanes[0]))]


def random_points(name, n, rng, dtype, offset=0.0, scale=1.0):
    pred = classic.PREDICATES[name]
    return [(offset + scale * rng.random((n, pred.dim))).astype(dtype)
            for _ in pred.points]


def check(name, P, mode="semi-static", L=None, running=True):
    f = classic.FILTERED[name] if (mode, running) == ("semi-static", True) else filtered(
        classic.PREDICATES[name], mode=mode, L=L, running=running)
    res = f(*P)
    want = exact_signs(name, P)
    np.testing.assert_array_equal(res.hit, want > 0)
    return res, want


# -- the four filtered predicates equal the exact sign ---------------------------------
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("name", NAMES)
def test_random_inputs_exact_and_mostly_native(name, dtype):
    rng = np.random.default_rng(7)
    res, _ = check(name, random_points(name, 600, rng, dtype))
    assert res.share < 0.02, res.share


@pytest.mark.parametrize("running", [True, False])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("name", NAMES)
def test_near_degenerate_inputs_exact_and_exercise_the_exact_path(name, dtype, running):
    rng = np.random.default_rng(11)
    res, want = check(name, near_degenerate(name, 150, rng, dtype), running=running)
    assert res.share == res.fell_back.mean() > 0  # the exact path decided some lanes,
    assert (res.fell_back & (want != 0)).any()     # nonzero signs among them


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("offset", [2.0**20, 2.0**40])
@pytest.mark.parametrize("name", NAMES)
def test_translated_inputs(name, offset, dtype):
    rng = np.random.default_rng(13)
    check(name, random_points(name, 200, rng, dtype, offset=offset))
    check(name, near_degenerate(name, 60, rng, dtype, offset=int(offset)))
    if dtype is np.float64:  # integers + 2^40 are exact in binary64 only
        res, want = check(name, exactly_degenerate(name, 40, rng, offset))
        assert (want == 0).all() and res.fell_back.all()


@pytest.mark.parametrize("dtype,power", [(np.float64, 500), (np.float64, -500),
                                         (np.float32, 40), (np.float32, -40)])
@pytest.mark.parametrize("name", NAMES)
def test_scaled_inputs(name, dtype, power):
    """Overflow and underflow lanes are detected and decided exactly."""
    rng = np.random.default_rng(17)
    scale = 2.0**power
    check(name, random_points(name, 100, rng, dtype, scale=scale))
    check(name, near_degenerate(name, 40, rng, dtype, scale=Fraction(2)**power))


@pytest.mark.parametrize("name", NAMES)
def test_static_filter_is_exact_and_never_better_than_semi_static(name):
    rng = np.random.default_rng(19)
    P = near_degenerate(name, 100, rng, np.float64)
    semi, _ = check(name, P)
    static, _ = check(name, P, mode="static")
    assert static.first_stage.mean() >= semi.first_stage.mean()
    R = random_points(name, 200, rng, np.float64)
    semi, _ = check(name, R)
    tight, _ = check(name, R, mode="static", L=0.25)  # lanes beyond L fall back, still exact
    assert tight.first_stage.mean() > 0.5 > semi.first_stage.mean()
    alone, _ = check(name, R, mode="static", L=0.25, running=False)
    np.testing.assert_array_equal(alone.fell_back, tight.first_stage)
    assert tight.share < alone.share  # the running-error stage decided most of them


@pytest.mark.parametrize("name", NAMES)
def test_running_error_stage_decides_lanes_the_derived_bound_leaves(name):
    """Points at 2^-20..2^-50 from the degenerate set: the per-lane running error bound
    (second stage) decides lanes the derived bound cannot, and stays exact."""
    rng = np.random.default_rng(29)
    P = near_degenerate(name, 200, rng, np.float64)
    step = 2.0 ** -rng.uniform(20, 50, size=P[-1].shape) * rng.choice([-1.0, 1.0], P[-1].shape)
    P[-1] = P[-1] + step
    res, _ = check(name, P)
    assert res.first_stage.any() and res.share < res.first_stage.mean()
    assert not (res.fell_back & ~res.first_stage).any()


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(NAMES), seed=st.integers(0, 2**32 - 1),
       exponent=st.integers(-60, 60), f32=st.booleans(), degenerate=st.booleans(),
       running=st.booleans())
def test_filtered_equals_exact_hypothesis(name, seed, exponent, f32, degenerate, running):
    rng = np.random.default_rng(seed)
    dtype = np.float32 if f32 else np.float64
    offset = int(rng.integers(-2**20, 2**20)) * 2**exponent
    if degenerate:
        P = near_degenerate(name, 8, rng, dtype, offset=offset, scale=Fraction(2)**exponent)
    else:
        P = random_points(name, 8, rng, dtype, offset=float(offset), scale=2.0**exponent)
    check(name, P, running=running)


def test_sign_and_batch_shapes():
    rng = np.random.default_rng(23)
    P = near_degenerate("orient2d", 24, rng, np.float64)
    want = exact_signs("orient2d", P)
    assert (want == 0).any() and (want != 0).any()
    np.testing.assert_array_equal(classic.sign(classic.FILTERED["orient2d"], *P), want)
    shaped = [p.reshape(4, 6, 2) for p in P]
    res = classic.FILTERED["orient2d"](*shaped)
    assert res.hit.shape == res.fell_back.shape == (4, 6)
    np.testing.assert_array_equal(res.hit.ravel(), want > 0)
    single = classic.FILTERED["orient2d"](np.zeros(2), np.array([1.0, 0.0]), P[2][:5])
    assert single.hit.shape == (5,)


def test_bad_inputs_are_refused():
    f = classic.FILTERED["orient2d"]
    a = np.zeros((3, 2))
    with pytest.raises(TypeError, match="float64 or all float32"):
        f(a, a, a.astype(np.float32))
    with pytest.raises(ValueError, match="non-finite"):
        f(a, a, np.full((3, 2), np.inf))
    with pytest.raises(ValueError, match="mode"):
        filtered(classic.orient2d, mode="dynamic")
    with pytest.raises(ValueError, match="mode='static'"):
        FilteredPredicate(classic.orient2d, L=1.0)


# -- rule K's premise ------------------------------------------------------------------
@predicate(dim=2, points="ABC")
def shoelace(ctx, A, B, C, tol):
    """2·signed area by the shoelace formula: raw coordinates, not differences."""
    det = ctx.name("det", A[0] * B[1] - A[1] * B[0] + B[0] * C[1] - B[1] * C[0]
                   + C[0] * A[1] - C[1] * A[0])
    if ctx.reject(det <= tol.kappa, line=1):
        return ctx.miss()
    return ctx.hit(())


SHOELACE = PredicateTolerances(
    dim=2, predicates=[shoelace], name="shoelace",
    tolerances={"kappa": ("10*eps*L^2", "21*eps*L^2", "32*eps*L^2")})


def _exact_shoelace(A, B, C):
    (ax, ay), (bx, by), (cx, cy) = [(Fraction(x), Fraction(y)) for x, y in (A, B, C)]
    return ax * by - ay * bx + bx * cy - by * cx + cx * ay - cy * ax


def test_shoelace_table_verifies():
    assert all(o.holds for o in SHOELACE.verify().outcomes)


@pytest.mark.parametrize("dtype", [float, np.float64, np.float32])
def test_shoelace_off_centre_errs_clearly(dtype):
    """Box edge 1 at offset 2^20: the bounds (for |x| ≤ L/2) do not cover the call."""
    o = 2.0**20
    A, B, C = (o, o), (o + 1, o), (o, o + 1)
    assert _exact_shoelace(A, B, C) == 1  # far above κ+ = 32εL²: the answer is "hit"
    tol = SHOELACE.tolerances(1.0, dtype=dtype)
    args = (A, B, C) if dtype is float else [np.array([p], dtype=dtype) for p in (A, B, C)]
    with pytest.raises(PremiseError, match=r"\|coordinate\| ≤ L/2.*centred at the origin"):
        shoelace(*args, tol)


def test_shoelace_answers_right_when_centred_or_with_a_large_L():
    o = 2.0**20
    A, B, C = (o, o), (o + 1, o), (o, o + 1)
    centre = (o + 0.5, o + 0.5)  # exactly representable: the translation is exact
    moved = [tuple(x - c for x, c in zip(p, centre)) for p in (A, B, C)]
    assert _exact_shoelace(*moved) == _exact_shoelace(A, B, C)
    assert shoelace(*moved, SHOELACE.tolerances(1.0, dtype=float)) == (True, ())
    big = SHOELACE.tolerances(2.0**21 + 2, dtype=float)  # L ≥ 2·max|coordinate|
    assert shoelace(A, B, C, big) == (True, ())
    res = filtered(shoelace)(*[np.array([p]) for p in (A, B, C)],
                             tol=SHOELACE.tolerances(1.0, dtype=np.float64))
    assert res.hit.tolist() == [True]


def test_difference_predicates_check_every_lane():
    """The paper's predicates use differences only: premise |P_i − P_j| ≤ L per lane,
    however far the lanes are from the origin and from each other."""
    tol = predicates.tolerances(2, 1.0, 1.0, dtype=np.float64)
    ev = predicates.d2.edge_vertex
    A = np.array([[1e6, 1e6], [-3e9, 5.0]])
    B, P = A + [0.5, 0.0], A + [0.25, 0.0]
    hit, _ = ev(A, B, P, tol)
    assert hit.tolist() == [True, True]
    far = P.copy()
    far[1] += [2.0**30, 0.0]
    with pytest.raises(PremiseError, match="lane 1: P − A on axis x"):
        ev(A, B, far, tol)
    with pytest.raises(PremiseError, match="difference"):
        ev(tuple(A[1]), tuple(B[1]), tuple(far[1]), predicates.tolerances(2, 1.0, 1.0, float))


def test_premise_checked_in_mpmath_and_exact_runs_unchecked():
    """A rounding number system (mpmath at 17 bits) checks the premise; the exact one
    has no rounding, hence no premise, and answers."""
    import fperr
    ev = predicates.d2.edge_vertex
    A, B, far = (0.0, 0.0), (0.5, 0.0), (2.0**30, 0.0)
    with pytest.raises(PremiseError, match="P − A on axis x"):
        ev(A, B, far, predicates.tolerances(2, 1.0, 1.0, "mp17"), ctx=fperr.MpContext(17))
    hit, _ = ev(A, B, far, predicates.tolerances(2, 1.0, 1.0, float), ctx=fperr.ExactContext())
    assert hit is False
