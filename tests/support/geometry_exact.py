"""Exact reference geometry for the predicate tests (no floating point in the verdicts).

* **numbers** — :func:`frac` (the exact value of a float / numpy scalar / mpf),
  :func:`round_bits` (correct rounding to a ``bits``-bit significand, ties to even);
* **thresholds** — :func:`threshold4`: T⁴ for T = T−, T or T+ of Figures 1 and 5
  (exact: T itself is irrational in 3D, ε^¼, but T⁴ is rational), so "distance ≤ T"
  is decided as (distance²)² ≤ T⁴;
* **exact predicates** — :func:`exact_eval`: every quantity the paper names, evaluated
  exactly (Python integers after scaling the dyadic coordinates to a common
  denominator), the exact weights, and the exact "inside" test of each predicate with a
  given bracket (T− or T+);
* **weight accuracy** — :func:`weight_error_bounds`: the guaranteed error of each
  returned weight, from the derived bounds E of its numerator and denominator (see that
  function's docstring for the derivation);
* **degenerate sub-pairs** — ``predicates.catalogue.sub_pairs``: the lower-level pairs the registration
  layer checks before a pair (only pairs *across* the two meshes: an edge's own two
  endpoints are never a vertex-vertex pair);
* **adversarial constructions** — :func:`construct`: near-degenerate configurations,
  placed in tolerance units (points within 0.1–10 tolerances of edges, faces and each
  other, on the T−/T+ band edges, coplanar and collinear, tiny elements just above σ̂,
  long ones spanning L), driven by a :class:`Source` of random parameters (a numpy
  generator or hypothesis' ``data``).

Everything here is exact or only *places* points: the coordinates a test uses are the
rounded ones, and every verdict is computed from those exact values.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction

import mpmath
from mpmath.libmp import to_float
import numpy as np
import sympy

import fperr
import predicates
from fperr import round_fraction, to_fraction
from predicates.portable import norm as _norm  # fixed order, not BLAS
from proofs.tables import TABLES


# -- machine-independent arithmetic for the constructions (docs/design.md, "The same
# answer on every machine"): sums in a fixed order, correctly rounded transcendentals
def _rounded(f, x: float) -> float:
    with mpmath.workprec(128):
        return to_float(f(mpmath.mpf(float(x)))._mpf_, rnd="n")


def _cos(x): return _rounded(mpmath.cos, x)  # noqa: E704
def _sin(x): return _rounded(mpmath.sin, x)  # noqa: E704
def _exp(x): return _rounded(mpmath.exp, x)  # noqa: E704
def _log(x): return _rounded(mpmath.log, x)  # noqa: E704


# ---------------------------------------------------------------------------------
# numbers


#: The exact value of a Python float/int, numpy scalar, mpmath mpf or Fraction.
frac = to_fraction


def round_bits(q, bits: int) -> Fraction:
    """``q`` correctly rounded (nearest, ties to even) to a ``bits``-bit significand
    (unbounded exponent: the formats' ranges are never approached here)."""
    return round_fraction(frac(q), bits)


def significand_bits(q: Fraction) -> int:
    """Bits of the odd part of a dyadic rational."""
    q = frac(q)
    assert q.denominator & (q.denominator - 1) == 0, f"{q} is not dyadic"
    n = abs(q.numerator)
    if n == 0:
        return 0
    return (n >> ((n & -n).bit_length() - 1)).bit_length()


def sqrt_lo(q: Fraction, bits: int = 256) -> Fraction:
    """A rational lower bound of √q (q ≥ 0), within 2^-bits relative."""
    q = frac(q)
    if q <= 0:
        return Fraction(0)
    shift = 2 * bits - (q.numerator.bit_length() - q.denominator.bit_length())
    shift += shift % 2
    if shift >= 0:
        n = (q.numerator << shift) // q.denominator
    else:
        n = q.numerator // (q.denominator << -shift)
    return Fraction(math.isqrt(n)) * Fraction(2) ** (-(shift // 2))


# ---------------------------------------------------------------------------------
# thresholds T−, T, T+ (Figures 1 and 5), exactly


def _rat(x) -> Fraction:
    x = sympy.nsimplify(x)
    assert x.is_Rational, x
    return Fraction(int(x.p), int(x.q))


@functools.lru_cache(maxsize=None)
def _coef4(dim: int, name: str, which: str) -> Fraction:
    spec = TABLES[dim][name]
    c = {"lo": spec.lo, "mid": spec.mid, "hi": spec.hi}[which]
    return _rat(sympy.expand(c**4))  # rational even for the √3 entries (ζ+, ξ+, ρ+)


def threshold4(dim: int, name: str, which: str, eps: Fraction, L: Fraction) -> Fraction:
    """T⁴ exactly, T = coefficient·ε^q·L^p with ``which`` ∈ {"lo", "mid", "hi"}
    (T−, T, T+) and L the value the tolerance object holds (``tol.L``)."""
    spec = TABLES[dim][name]
    q4 = spec.q * 4
    assert q4 == int(q4)
    return _coef4(dim, name, which) * Fraction(eps) ** int(q4) * Fraction(L) ** (4 * spec.p)


def threshold_mp(dim: int, name: str, which: str, eps: Fraction, L: Fraction):
    """T as an mpmath number at 300 bits (for the tolerance tests)."""
    with mpmath.workprec(300):
        t4 = threshold4(dim, name, which, eps, L)
        return mpmath.root(mpmath.mpf(t4.numerator) / t4.denominator, 4)


def le_T(x_sq: Fraction, T4: Fraction) -> bool:
    """√x_sq ≤ T, given x_sq ≥ 0 and T⁴."""
    return x_sq * x_sq <= T4


# ---------------------------------------------------------------------------------
# exact quantities of each predicate


def _ints(points):
    """Scale dyadic coordinates to integers: (integer points, common denominator)."""
    den = 1
    for p in points:
        for c in p:
            den = max(den, c.denominator)
    return [tuple(c.numerator * (den // c.denominator) for c in p) for p in points], den


def _sub(p, q):
    return tuple(a - b for a, b in zip(p, q))


def _dot(p, q):
    return sum(a * b for a, b in zip(p, q))


def _cross2(p, q):
    return p[0] * q[1] - p[1] * q[0]


def _cross3(p, q):
    return (p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0])


def _triple(p, q, r):
    return _dot(_cross3(p, q), r)


def _sgn(x):
    return (x > 0) - (x < 0)


@dataclass
class Exact:
    """The exact evaluation of one predicate on one configuration.

    ``q``: the paper's named quantities (Fractions, true scale); ``weights``: the exact
    weights (None where undefined); ``inside(which)``: the predicate's exact
    intersection criterion with the bracket ``which`` ("lo" = T−, "hi" = T+).
    ``denominators``: for each weight, (numerator name(s), denominator description)
    used by :func:`weight_error_bounds`.
    """

    dim: int
    name: str
    q: dict
    weights: tuple | None
    eps: Fraction
    L: Fraction
    _inside: object = None

    def inside(self, which: str) -> bool:
        return self._inside(which)


def exact_eval(dim: int, name: str, points, eps, L) -> Exact:
    """Exact quantities, weights and inside-test of predicate ``name`` (paper's names).

    ``points``: tuple of points with Fraction coordinates (the exact inputs)."""
    pts = [tuple(frac(c) for c in p) for p in points]
    ip, den = _ints(pts)
    eps, L = Fraction(eps), Fraction(L)
    T4 = functools.partial(threshold4, dim)
    s = Fraction(1, den)
    q = {}

    def F(v, deg):
        return Fraction(v) * s**deg

    if name == "vertex_vertex":
        A, B = ip
        d2 = F(_dot(_sub(A, B), _sub(A, B)), 2)
        q["d2"] = d2
        return Exact(dim, name, q, (), eps, L,
                     lambda w: le_T(d2, T4("sigma", w, eps, L)))

    if name == "edge_vertex":
        A, B, P = ip
        u, w = _sub(B, A), _sub(P, A)
        m2 = _dot(u, u)
        uw = _dot(u, w)  # = â·m
        if dim == 2:
            c2 = _cross2(u, w) ** 2
        else:
            c = _cross3(u, w)
            c2 = _dot(c, c)
        q.update(m2=F(m2, 2), uw=F(uw, 2))
        if m2 == 0:
            return Exact(dim, name, q, None, eps, L, lambda w_: False)
        d2 = F(c2, 4) / F(m2, 2)  # |û × w|²/|û|²
        q["d2"] = d2
        weights = (Fraction(uw, m2),)

        def inside(which):
            return le_T(d2, T4("tau", which, eps, L)) and 0 < uw < m2
        return Exact(dim, name, q, weights, eps, L, inside)

    if name == "edge_edge" and dim == 2:
        A, B, P, Q = ip
        BA, QP = _sub(B, A), _sub(Q, P)
        aP, aQ = _cross2(_sub(P, A), BA), _cross2(_sub(Q, A), BA)
        aA, aB = _cross2(_sub(A, P), QP), _cross2(_sub(B, P), QP)
        q.update(a_P=F(aP, 2), a_Q=F(aQ, 2), a_A=F(aA, 2), a_B=F(aB, 2))
        proper = _sgn(aP) * _sgn(aQ) == -1 and _sgn(aA) * _sgn(aB) == -1
        weights = (Fraction(aA, aA - aB), Fraction(aP, aP - aQ)) if proper else None
        return Exact(dim, name, q, weights, eps, L, lambda w_: proper)

    if name == "triangle_vertex" and dim == 2:
        A, B, C, P = ip
        aA = _cross2(_sub(B, P), _sub(C, P))
        aB = _cross2(_sub(P, A), _sub(C, A))
        aC = _cross2(_sub(B, A), _sub(P, A))
        q.update(a_A=F(aA, 2), a_B=F(aB, 2), a_C=F(aC, 2))
        inside = aA != 0 and _sgn(aA) == _sgn(aB) == _sgn(aC)
        tot = aA + aB + aC
        weights = tuple(Fraction(x, tot) for x in (aA, aB, aC)) if inside else None
        return Exact(dim, name, q, weights, eps, L, lambda w_: inside)

    if name in ("edge_edge", "triangle_vertex"):  # 3D: same algebra, eqs. (13)-(16)
        if name == "edge_edge":
            A, B, P, Q = ip
            u, v, w = _sub(B, A), _sub(Q, P), _sub(P, A)
        else:
            A, B, C, P = ip
            u, v, w = _sub(B, A), _sub(C, A), _sub(P, A)
        r = _cross3(u, v)
        m2 = _dot(r, r)
        dh = _dot(r, w)
        n = _cross3(r, w)
        q.update(m2=F(m2, 4), d_hat=F(dh, 3))
        if name == "edge_edge":
            ah, bh = _dot(n, v), _dot(n, u)
            q.update(a_hat=F(ah, 4), b_hat=F(bh, 4), a_bar=F(m2 - ah, 4), b_bar=F(m2 - bh, 4))
            weights = (Fraction(ah, m2), Fraction(bh, m2)) if m2 else None
            signs_ok = m2 > 0 and 0 < ah < m2 and 0 < bh < m2
            tname = "gamma"
        else:
            bh, ch = _dot(n, v), -_dot(n, u)
            ah = m2 - bh - ch
            q.update(a_hat=F(ah, 4), b_hat=F(bh, 4), c_hat=F(ch, 4))
            weights = tuple(Fraction(x, m2) for x in (ah, bh, ch)) if m2 else None
            signs_ok = m2 > 0 and ah > 0 and bh > 0 and ch > 0
            tname = "delta"
        # distance² = d̂²/m² (true scale: d̂ has degree 3, m² degree 4)
        dist2 = F(dh * dh, 6) / F(m2, 4) if m2 else None
        q["dist2"] = dist2

        def inside(which):
            return signs_ok and le_T(dist2, T4(tname, which, eps, L))
        return Exact(dim, name, q, weights, eps, L, inside)

    if name == "triangle_edge":
        A, B, C, P, Q = ip
        PQ = _sub(P, Q)
        AQ, BQ, CQ = _sub(A, Q), _sub(B, Q), _sub(C, Q)
        vA, vB, vC = _triple(BQ, CQ, PQ), _triple(CQ, AQ, PQ), _triple(AQ, BQ, PQ)
        vP = _triple(_sub(A, P), _sub(B, P), _sub(C, P))
        vQ = _triple(AQ, BQ, CQ)
        q.update(v_A=F(vA, 3), v_B=F(vB, 3), v_C=F(vC, 3), v_P=F(vP, 3), v_Q=F(vQ, 3))
        proper = (vA != 0 and _sgn(vA) == _sgn(vB) == _sgn(vC)
                  and _sgn(vP) * _sgn(vQ) == -1)
        tot = vA + vB + vC
        weights = ((Fraction(vA, tot), Fraction(vB, tot), Fraction(vC, tot),
                    Fraction(vP, vP - vQ)) if proper else None)
        return Exact(dim, name, q, weights, eps, L, lambda w_: proper)

    if name == "tetrahedron_vertex":
        A, B, C, D, P = ip
        DA, PA = _sub(D, A), _sub(P, A)
        vA = _triple(_sub(B, P), _sub(C, P), _sub(D, P))
        vB = _triple(PA, _sub(C, A), DA)
        vC = _triple(_sub(B, A), PA, DA)
        vD = _triple(_sub(B, A), _sub(C, A), PA)
        q.update(v_A=F(vA, 3), v_B=F(vB, 3), v_C=F(vC, 3), v_D=F(vD, 3))
        inside = vA != 0 and _sgn(vA) == _sgn(vB) == _sgn(vC) == _sgn(vD)
        tot = vA + vB + vC + vD
        weights = tuple(Fraction(x, tot) for x in (vA, vB, vC, vD)) if inside else None
        return Exact(dim, name, q, weights, eps, L, lambda w_: inside)

    raise KeyError((dim, name))


# ---------------------------------------------------------------------------------
# accuracy of the returned weights


@functools.lru_cache(maxsize=None)
def _E_expr(dim: int, name: str, qname: str):
    pred = getattr(getattr(predicates, f"d{dim}"), name)
    return fperr.bounds(pred.instrumented().quantities[qname], strict=True).E


@functools.lru_cache(maxsize=4096)
def E_value(dim: int, name: str, qname: str, eps: Fraction, L: Fraction) -> Fraction:
    """The derived bound E[qname] of predicate ``name`` (instrumented run), at ε and L."""
    e = _E_expr(dim, name, qname).subs({fperr.eps: sympy.Rational(eps.numerator, eps.denominator),
                                        fperr.L: sympy.Rational(L.numerator, L.denominator)})
    return _rat_up(e)


def _rat_up(x) -> Fraction:
    """A rational upper bound of a positive constant (exact when it is rational; E[m]
    involves √2 and √3 from rule H)."""
    x = sympy.nsimplify(x)
    if x.is_Rational:
        return Fraction(int(x.p), int(x.q))
    v = Fraction(str(sympy.N(x, 80)))
    return v * (1 + Fraction(1, 10**60))


def _sum_error(values, errors, eps):
    """Bound on |F[x1 + x2 + …] − (x1 + x2 + …)| for a left-to-right sum of computed
    terms F[xi] with |F[xi] − xi| ≤ errors[i] (standard model, unit roundoff ε)."""
    e = errors[0]
    s = values[0]
    for x, ex in zip(values[1:], errors[1:]):
        s = s + x
        e = e + ex + eps * (abs(s) + e + ex)
    return e


def _quotient_error(w, E_N, D_abs, E_D, eps):
    """Bound on |fl(F[N]/F[D]) − N/D| with w = N/D, |F[N] − N| ≤ E_N, |F[D] − D| ≤ E_D.

    (F[N]/F[D] − w) = (e_N − w·e_D)/(D + e_D), so its size is ≤ (E_N + |w|E_D)/(|D| − E_D);
    the division then rounds once: |fl(x) − w| ≤ (1 + ε)|x − w| + ε|w|.
    Returns None when |D| ≤ E_D (no guarantee possible)."""
    if D_abs <= E_D:
        return None
    return (1 + eps) * (E_N + abs(w) * E_D) / (D_abs - E_D) + eps * abs(w)


def weight_error_bounds(ex: Exact) -> list:
    """Guaranteed error of each returned weight, for an exact configuration ``ex`` (hit).

    Every weight is a quotient F[N]/F[D] of computed quantities; with the derived
    absolute bounds E[N], E[D] (the instrumented run, evaluated at this ε and L) the
    returned weight ŵ satisfies

        |ŵ − w| ≤ (1 + ε)·(E[N] + w·E[D]) / (|D| − E[D]) + ε·w,      w = N/D exact,

    (to first order (E[N] + E[D])/|D|, e.g. (E[â] + E[m])/m for the edge-vertex weight
    â/m). When D is itself a sum or difference formed in the predicate (a_A − a_B,
    a_A + a_B + a_C, v_P − v_Q, …) E[D] is the sum of the terms' E plus one rounding per
    addition (:func:`_sum_error`). |D| is taken exactly (a rational lower bound of m for
    the edge-vertex weight). A priori, with the denominators the hierarchy guarantees for
    a hit (m > σ̂−, |a_X| > κ−, m² > λ− or ν−, |v_X| > μ− or ξ− or ρ−), this is
    O(√ε) for the edge-vertex weight but can be O(1) for the others (a triangle
    whose area is a few κ: the paper's "there may be some accuracy loss"); the
    guarantee that matters is the per-case one, which the tests assert.
    Returns a list (None entries when no bound is possible: |D| ≤ E[D]).
    """
    dim, name, eps, L, q = ex.dim, ex.name, ex.eps, ex.L, ex.q
    E = functools.partial(E_value, dim, name, eps=eps, L=L)
    w = ex.weights
    if name == "edge_vertex":
        m_lo = sqrt_lo(q["m2"])  # m exactly is irrational: a rational lower bound
        return [_quotient_error(w[0], E("a_hat"), m_lo, E("m"), eps)]
    if name == "edge_edge" and dim == 2:
        out = []
        for num, other, wi in (("a_A", "a_B", w[0]), ("a_P", "a_Q", w[1])):
            vals = [q[num], -q[other]]
            ED = _sum_error(vals, [E(num), E(other)], eps)
            out.append(_quotient_error(wi, E(num), abs(q[num] - q[other]), ED, eps))
        return out
    if name == "triangle_vertex" and dim == 2:
        names = ("a_A", "a_B", "a_C")
        ED = _sum_error([q[n] for n in names], [E(n) for n in names], eps)
        D = abs(sum(q[n] for n in names))
        return [_quotient_error(wi, E(n), D, ED, eps) for wi, n in zip(w, names)]
    if name == "edge_edge":
        return [_quotient_error(wi, E(n), q["m2"], E("m2"), eps)
                for wi, n in zip(w, ("a_hat", "b_hat"))]
    if name == "triangle_vertex":
        return [_quotient_error(wi, E(n), q["m2"], E("m2"), eps)
                for wi, n in zip(w, ("a_hat", "b_hat", "c_hat"))]
    if name == "triangle_edge":
        names = ("v_A", "v_B", "v_C")
        ED = _sum_error([q[n] for n in names], [E(n) for n in names], eps)
        D = abs(sum(q[n] for n in names))
        out = [_quotient_error(wi, E(n), D, ED, eps) for wi, n in zip(w[:3], names)]
        EDpq = _sum_error([q["v_P"], -q["v_Q"]], [E("v_P"), E("v_Q")], eps)
        out.append(_quotient_error(w[3], E("v_P"), abs(q["v_P"] - q["v_Q"]), EDpq, eps))
        return out
    if name == "tetrahedron_vertex":
        names = ("v_A", "v_B", "v_C", "v_D")
        ED = _sum_error([q[n] for n in names], [E(n) for n in names], eps)
        D = abs(sum(q[n] for n in names))
        return [_quotient_error(wi, E(n), D, ED, eps) for wi, n in zip(w, names)]
    return []


# ---------------------------------------------------------------------------------
# faces of a tetrahedron (degenerate sub-pairs are predicates.catalogue.sub_pairs)

_TET_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
_TET_FACES = ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))


# ---------------------------------------------------------------------------------
# random parameters: numpy generator or hypothesis data


class Source:
    """Random parameters for the constructions."""

    def uniform(self, a: float, b: float) -> float:
        raise NotImplementedError

    def integer(self, a: int, b: int) -> int:  # inclusive
        raise NotImplementedError

    def choice(self, seq):
        return seq[self.integer(0, len(seq) - 1)]

    def loguniform(self, a: float, b: float) -> float:
        return _exp(self.uniform(_log(a), _log(b)))

    def sign(self) -> int:
        return self.choice((-1, 1))


class RngSource(Source):
    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def uniform(self, a, b):
        return float(self.rng.uniform(a, b))

    def integer(self, a, b):
        return int(self.rng.integers(a, b + 1))


class DataSource(Source):
    """Draws from hypothesis' ``st.data()`` (shrinks towards simple values)."""

    def __init__(self, data):
        from hypothesis import strategies as st
        self.data, self.st = data, st

    def uniform(self, a, b):
        return self.data.draw(self.st.floats(a, b, allow_nan=False, allow_infinity=False))

    def integer(self, a, b):
        return self.data.draw(self.st.integers(a, b))


# ---------------------------------------------------------------------------------
# adversarial constructions (unit box [0, 1]^dim; tolerances in units of L^p)


def _unit(v):
    return v / _norm(v)


def _rand_dir(src, dim):
    """A random unit vector (no rejection loop: hypothesis' minimal draws are zeros)."""
    v = np.array([src.uniform(-1, 1) for _ in range(dim)])
    if _norm(v) < 0.2:
        v = v + np.array([1.0, 0.3, 0.1][:dim])
    return _unit(v)


def _perp(src, v):
    """A unit vector perpendicular to v (random in 3D)."""
    v = _unit(v)
    if len(v) == 2:
        return src.sign() * np.array([-v[1], v[0]])
    w = _rand_dir(src, 3)
    w = w - _dot(w, v) * v
    if _norm(w) < 0.2:
        e = np.zeros(3)
        e[int(np.argmin(np.abs(v)))] = 1.0
        w = e - _dot(e, v) * v
    return _unit(w)


def tol_multiple(src, lo: float, hi: float) -> float:
    """A distance in units of a tolerance T: the band [T−/T, T+/T] and its edges
    (lo, hi), anywhere in 0.1–10 tolerances, or 0."""
    mode = src.integer(0, 9)
    if mode <= 2:
        return src.uniform(0.97 * lo, 1.03 * hi)
    if mode == 3:
        return src.choice((lo, hi)) * (1 + src.uniform(-1e-3, 1e-3))
    if mode == 4:
        return 0.0
    return src.loguniform(0.1, 10)


@dataclass(frozen=True)
class Units:
    """Tolerances in units of L^p (floats, for placing points only) and their brackets."""

    dim: int
    t: dict  # name -> T/L^p
    lo: dict  # name -> T−/T
    hi: dict  # name -> T+/T

    @staticmethod
    def of(tol) -> "Units":
        L = float(tol.L)
        t, lo, hi = {}, {}, {}
        for name, spec in TABLES[tol.dim].items():
            t[name] = float(tol.values[name]) / L**spec.p
            lo[name] = float(spec.lo / spec.mid)
            hi[name] = float(spec.hi / spec.mid)
        return Units(tol.dim, t, lo, hi)

    def near(self, src, name):
        """A distance near the bracket of tolerance ``name`` (unit box scale). When the
        tolerances are coarse (3D at 17 bits: τ ≈ 0.24·L) multiples that would leave the
        box are redrawn below 0.45 (in the band when it fits)."""
        t = self.t[name]
        d = tol_multiple(src, self.lo[name], self.hi[name]) * t
        if d > 0.45:
            d = src.uniform(0.1, min(self.hi[name], 0.45 / t)) * t
        return d


def _along(src, length, u: Units):
    """A parameter t along a segment of ``length``: interior, near either end (within a
    few σ), or outside."""
    mode = src.integer(0, 4)
    if mode == 0 or length <= 0:
        return src.uniform(0.0, 1.0)
    if mode in (1, 2):
        s = src.uniform(-2.0, 2.0) * u.t["sigma"] / length
        return s if mode == 1 else 1 - s
    if mode == 3:
        return src.uniform(-0.3, 1.3)
    return src.choice((0.0, 0.5, 1.0))


def segment(src, u: Units):
    """Two points: random, long (corner to corner: coordinate differences up to L), medium,
    tiny (length just above σ̂), or axis-aligned."""
    dim = u.dim
    mode = src.integer(0, 5)
    if mode == 0:
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(2)]
    if mode == 1:
        corner = np.array([src.integer(0, 1) for _ in range(dim)], dtype=float)
        A = np.abs(corner - np.array([src.uniform(0, 0.05) for _ in range(dim)]))
        B = np.abs((1 - corner) - np.array([src.uniform(0, 0.05) for _ in range(dim)]))
        return [A, B]
    A = np.array([src.uniform(0.25, 0.75) for _ in range(dim)])
    d = _rand_dir(src, dim)
    if mode in (2, 3):
        length = src.uniform(0.02, 0.45)
    elif mode == 4:
        length = u.t["sigma_hat"] * src.choice((src.uniform(0.9, 1.5), src.uniform(1.5, 6.0)))
    else:
        d = np.zeros(dim)
        d[src.integer(0, dim - 1)] = src.sign()
        length = src.uniform(0.01, 0.45)
    return [A, A + length * d]


def triangle(src, u: Units):
    """Three points: random, large, thin (C within 0.1–10 τ of AB, or on it), tiny
    (sides just above σ̂), needle, or axis-aligned right triangle."""
    dim = u.dim
    mode = src.integer(0, 5)
    if mode == 0:
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(3)]
    if mode == 1:
        pts = [np.array([src.uniform(0, 0.1) for _ in range(dim)]),
               np.array([src.uniform(0.9, 1.0)] + [src.uniform(0, 0.1) for _ in range(dim - 1)]),
               np.array([src.uniform(0, 0.5)] + [src.uniform(0.9, 1.0) for _ in range(dim - 1)])]
        return pts
    if mode == 2:
        A, B = segment(src, u)
        t = _along(src, _norm(B - A), u)
        C = A + t * (B - A) + u.near(src, "tau") * _perp(src, B - A)
        return [A, B, C]
    if mode == 3:
        A = np.array([src.uniform(0.3, 0.7) for _ in range(dim)])
        s = u.t["sigma_hat"]
        return [A, A + s * src.uniform(1.0, 4.0) * _rand_dir(src, dim),
                A + s * src.uniform(1.0, 4.0) * _rand_dir(src, dim)]
    if mode == 4:
        A, B = segment(src, u)
        C = A + u.near(src, "sigma") * src.uniform(1.0, 3.0) * _rand_dir(src, dim)
        return [A, B, C]
    A = np.array([src.uniform(0.1, 0.5) for _ in range(dim)])
    B, C = A.copy(), A.copy()
    B[0] += src.uniform(0.05, 0.5)
    C[1] += src.uniform(0.05, 0.5)
    return [A, B, C]


def _normal(tri):
    A, B, C = tri
    return _unit(np.cross(B - A, C - A))


def _bary(src, k):
    x = np.array([src.loguniform(1e-3, 1.0) for _ in range(k)])
    return x / x.sum()


def _in_plane_point(src, tri, u: Units):
    """A point in the plane of a (2D or 3D) triangle: interior, near an edge (0.1–10 τ
    inside or outside, or on it), near a vertex, or random in the plane."""
    A, B, C = tri
    mode = src.integer(0, 5)
    if mode == 0:
        b = _bary(src, 3)
        return b[0] * A + b[1] * B + b[2] * C
    if mode == 5:  # well inside (around the centroid)
        b = np.array([1 / 3 + src.uniform(-0.15, 0.15) for _ in range(3)])
        b = b / b.sum()
        return b[0] * A + b[1] * B + b[2] * C
    if mode in (1, 2):
        i = src.integer(0, 2)
        X, Y, Z = tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]
        t = _along(src, _norm(Y - X), u)
        foot = X + t * (Y - X)
        e = Y - X
        inward = (Z - X) - _dot(Z - X, e) / _dot(e, e) * e
        if _norm(inward) == 0:
            return foot
        return foot + src.sign() * u.near(src, "tau") * _unit(inward)
    if mode == 3:
        V = tri[src.integer(0, 2)]
        d = (B - A) * src.uniform(-1, 1) + (C - A) * src.uniform(-1, 1)
        if _norm(d) == 0:
            return V
        return V + u.near(src, "sigma") * _unit(d)
    return A + src.uniform(-0.5, 1.5) * (B - A) + src.uniform(-0.5, 1.5) * (C - A)


def across(src, dim, margin=0.02):
    """A long segment through (near) the centre of the box, spanning it."""
    c = np.array([src.uniform(0.4, 0.6) for _ in range(dim)])
    d = _rand_dir(src, dim)
    h = min((min(ci, 1 - ci) - margin) / abs(di) for ci, di in zip(c, d) if abs(di) > 1e-12)
    return c - h * d, c + h * d


def construct_big(name: str, src: Source, u: Units):
    """Large elements (spanning the box) with a near-degenerate probe well inside them:
    the configurations that stay non-degenerate even when the tolerances are a sizeable
    fraction of L (3D at 17 bits: σ ≈ 0.34·L)."""
    dim = u.dim
    mid = lambda: src.choice((src.uniform(0.3, 0.7), src.uniform(0.05, 0.95)))
    if name == "vertex_vertex":
        return construct(name, src, u, big=False)
    if name == "edge_vertex":
        A, B = across(src, dim)
        return [A, B, A + mid() * (B - A) + u.near(src, "tau") * _perp(src, B - A)]
    if name == "edge_edge":
        A, B = across(src, dim)
        X = A + mid() * (B - A)
        uu = _unit(B - A)
        e = _perp(src, uu)
        ang = src.choice((src.uniform(0.3, math.pi - 0.3), src.uniform(0.02, 0.3)))
        v = _cos(ang) * uu + _sin(ang) * e
        if dim == 3:
            n = _unit(np.cross(uu, v))
            Y = X + src.sign() * u.near(src, "gamma") * n
        else:
            Y = X + (u.near(src, "tau") * _perp(src, v) if src.integer(0, 2) == 0 else 0.0)
        h = [src.uniform(0.2, 0.6) for _ in range(2)]
        return [A, B, Y - h[0] * v, Y + h[1] * v]
    tri = triangle_big(src, dim)
    if name == "triangle_vertex" and dim == 2:
        return tri + [_in_plane_point(src, tri, u)]
    if name == "triangle_vertex":
        foot = _in_plane_point(src, tri, u)
        return tri + [foot + src.sign() * u.near(src, "delta") * _normal(tri)]
    if name == "triangle_edge":
        X = _in_plane_point(src, tri, u)
        n = _normal(tri)
        e = _perp(src, n)
        phi = src.choice((src.uniform(0.3, math.pi / 2), src.uniform(0.02, 0.3)))
        d = _cos(phi) * e + _sin(phi) * n
        arms = [min(src.choice((u.near(src, "delta") / _sin(phi), src.uniform(0.1, 0.5))),
                    0.7) for _ in range(2)]
        return tri + [X - arms[0] * d, X + arms[1] * d]
    if name == "tetrahedron_vertex":
        base = [np.array(p, dtype=float) for p in ((0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1))]
        tet = [np.clip(p + np.array([src.uniform(-0.1, 0.1) for _ in range(3)]), 0, 1)
               for p in base]
        mode = src.integer(0, 2)
        if mode == 0:  # around the centroid: inside, or outside across a face
            return tet + [sum(tet) / 4 + src.uniform(0, 0.6) * _rand_dir(src, 3)]
        f = [tet[i] for i in _TET_FACES[src.integer(0, 3)]]
        n = _normal(f)
        inward = n if _dot(n, sum(tet) / 4 - f[0]) > 0 else -n
        foot = _in_plane_point(src, f, u)
        if mode == 1:  # within 0.1–10 δ of a face, either side
            return tet + [foot + src.choice((1, 1, -1)) * u.near(src, "delta") * inward]
        # beyond the face's δ window, either side
        return tet + [foot + src.sign() * src.uniform(1.0, 3.0) * u.t["delta"] * inward]
    raise KeyError(name)


def triangle_big(src, dim):
    """A large triangle (vertices near three corners of the box), jittered."""
    if dim == 2:
        c = [(0, 0), (1, 0), (0, 1), (1, 1)]
    else:
        c = [(0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    idx = [src.integer(0, len(c) - 1)]
    idx.append((idx[0] + src.integer(1, len(c) - 1)) % len(c))
    rest = [k for k in range(len(c)) if k not in idx]
    idx.append(rest[src.integer(0, len(rest) - 1)])
    return [np.clip(np.array(c[k], dtype=float) + np.array([src.uniform(-0.15, 0.15)
                                                            for _ in range(dim)]), 0, 1)
            for k in idx]


def construct(name: str, src: Source, u: Units, big: bool | None = None):
    """A configuration for predicate ``name`` (list of points in the unit box, floats).

    ``big``: use :func:`construct_big` (None: with probability 1/2 when the tolerances
    are coarse, σ > 0.02·L, else 1/6)."""
    dim = u.dim
    if big is None:
        big = src.integer(0, 5) < (3 if u.t["sigma"] > 0.02 else 1)
    if big:
        return construct_big(name, src, u)
    if src.integer(0, 9) == 0:  # plain random configuration
        npts = {"vertex_vertex": 2, "edge_vertex": 3, "edge_edge": 4, "triangle_vertex": 4,
                "triangle_edge": 5, "tetrahedron_vertex": 5}[name]
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(npts)]

    if name == "vertex_vertex":
        A = np.array([src.uniform(0.2, 0.8) for _ in range(dim)])
        return [A, A + u.near(src, "sigma") * _rand_dir(src, dim)]

    if name == "edge_vertex":
        A, B = segment(src, u)
        if src.integer(0, 3) == 0:  # near an endpoint
            P = src.choice((A, B)) + u.near(src, "sigma") * _rand_dir(src, dim)
        else:
            t = _along(src, _norm(B - A), u)
            P = A + t * (B - A) + u.near(src, "tau") * _perp(src, B - A)
        return [A, B, P]

    if name == "edge_edge" and dim == 2:
        A, B = segment(src, u)
        mode = src.integer(0, 3)
        if mode == 0:  # collinear (up to a shift of 0.1–10 τ)
            t1, t2 = src.uniform(-0.5, 1.5), src.uniform(-0.5, 1.5)
            n = _perp(src, B - A) * (u.near(src, "tau") if src.integer(0, 1) else 0.0)
            return [A, B, A + t1 * (B - A) + n, A + t2 * (B - A) + n]
        if mode == 1:  # a vertex of PQ near AB
            t = _along(src, _norm(B - A), u)
            P = A + t * (B - A) + u.near(src, "tau") * _perp(src, B - A)
            Q = np.array([src.uniform(0, 1) for _ in range(dim)])
            return [A, B, P, Q] if src.integer(0, 1) else [P, Q, A, B]
        # crossing at X with an angle (possibly tiny), short or long arms, optional shift
        X = A + _along(src, _norm(B - A), u) * (B - A)
        ang = src.choice((src.uniform(0, math.pi), src.loguniform(1e-12, 1e-2), 0.0,
                          math.pi / 2))
        e = _unit(B - A) if _norm(B - A) > 0 else np.array([1.0, 0.0])
        c, s = _cos(ang), _sin(ang)
        d = np.array([c * e[0] - s * e[1], s * e[0] + c * e[1]])
        arms = [src.choice((u.near(src, "tau"), src.uniform(0.02, 0.5),
                            u.t["sigma"] * src.uniform(0.5, 3))) for _ in range(2)]
        shift = _perp(src, d) * (u.near(src, "tau") if src.integer(0, 2) == 0 else 0.0)
        return [A, B, X - arms[0] * d + shift, X + arms[1] * d + shift]

    if name == "triangle_vertex" and dim == 2:
        tri = triangle(src, u)
        return tri + [_in_plane_point(src, tri, u)]

    if name == "edge_edge":  # 3D: closest points X (on AB) and Y = X + k·γ·n
        A, B = segment(src, u)
        mode = src.integer(0, 4)
        if mode == 0:  # collinear-ish / parallel
            v = B - A
            off = _perp(src, v) * src.choice((0.0, u.near(src, "gamma"), u.near(src, "tau")))
            t1, t2 = src.uniform(-0.5, 1.5), src.uniform(-0.5, 1.5)
            return [A, B, A + t1 * v + off, A + t2 * v + off]
        if mode == 1:  # an endpoint of PQ near AB
            t = _along(src, _norm(B - A), u)
            P = A + t * (B - A) + u.near(src, "tau") * _perp(src, B - A)
            Q = P + src.uniform(0.05, 0.6) * _rand_dir(src, 3)
            return [A, B, P, Q] if src.integer(0, 1) else [P, Q, A, B]
        uu = _unit(B - A) if _norm(B - A) > 0 else np.array([1.0, 0, 0])
        X = A + _along(src, _norm(B - A), u) * (B - A)
        e = _perp(src, uu)
        ang = src.choice((src.uniform(0, math.pi), src.loguniform(1e-12, 1e-2), math.pi / 2))
        v = _cos(ang) * uu + _sin(ang) * e
        n = _unit(np.cross(uu, v)) if ang > 0 else _perp(src, uu)
        Y = X + src.sign() * u.near(src, "gamma") * n
        arms = [src.choice((u.near(src, "tau"), src.uniform(0.02, 0.5),
                            u.t["sigma"] * src.uniform(0.5, 3))) for _ in range(2)]
        return [A, B, Y - arms[0] * v, Y + arms[1] * v]

    if name == "triangle_vertex":  # 3D
        tri = triangle(src, u)
        foot = _in_plane_point(src, tri, u)
        try:
            n = _normal(tri)
        except FloatingPointError:
            n = _rand_dir(src, 3)
        if not np.all(np.isfinite(n)):
            n = _rand_dir(src, 3)
        return tri + [foot + src.sign() * u.near(src, "delta") * n]

    if name == "triangle_edge":
        tri = triangle(src, u)
        X = _in_plane_point(src, tri, u)
        n = _normal(tri)
        if not np.all(np.isfinite(n)):
            n = _rand_dir(src, 3)
        e = _perp(src, n)
        mode = src.integer(0, 4)
        if mode == 0:  # coplanar segment (possibly shifted by 0.1–10 δ)
            off = n * src.choice((0.0, u.near(src, "delta")))
            return tri + [X - src.uniform(0, 0.5) * e + off, X + src.uniform(0, 0.5) * e + off]
        phi = src.choice((src.uniform(0.05, math.pi / 2), src.loguniform(1e-9, 0.05),
                          math.pi / 2))
        d = _cos(phi) * e + _sin(phi) * n
        arms = []
        for _ in range(2):
            k = src.integer(0, 2)
            if k == 0:  # endpoint within 0.1–10 δ of the plane (grazing: any length)
                a = u.near(src, "delta") / _sin(phi)
                arms.append(a if a < 0.7 else src.uniform(0.02, 0.5))
            elif k == 1:
                arms.append(src.uniform(0.02, 0.5))
            else:
                arms.append(u.t["sigma"] * src.uniform(0.5, 3))
        return tri + [X - arms[0] * d, X + arms[1] * d]

    if name == "tetrahedron_vertex":
        mode = src.integer(0, 4)
        if mode == 0:  # regular-ish (corners of the box), jittered
            base = [np.array(p, dtype=float) for p in ((0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1))]
            tet = [np.clip(p + np.array([src.uniform(-0.1, 0.1) for _ in range(3)]), 0, 1)
                   for p in base]
        elif mode == 1:  # flat: D within 0.1–10 δ of the plane ABC (or on it)
            tri = triangle(src, u)
            n = _normal(tri)
            if not np.all(np.isfinite(n)):
                n = _rand_dir(src, 3)
            tet = tri + [_in_plane_point(src, tri, u) + n * src.choice((0.0, u.near(src, "delta")))]
        elif mode == 2:  # tiny (edges just above σ̂)
            A = np.array([src.uniform(0.3, 0.7) for _ in range(3)])
            tet = [A] + [A + u.t["sigma_hat"] * src.uniform(1.0, 4.0) * _rand_dir(src, 3)
                         for _ in range(3)]
        else:
            tet = triangle(src, u) + [np.array([src.uniform(0, 1) for _ in range(3)])]
        pmode = src.integer(0, 3)
        if pmode == 0:
            b = _bary(src, 4)
            P = sum(bi * X for bi, X in zip(b, tet))
        elif pmode == 1:  # near a face: 0.1–10 δ inside or outside
            f = [tet[i] for i in _TET_FACES[src.integer(0, 3)]]
            n = _normal(f)
            if not np.all(np.isfinite(n)):
                n = _rand_dir(src, 3)
            P = _in_plane_point(src, f, u) + src.sign() * u.near(src, "delta") * n
        elif pmode == 2:  # near an edge
            i, j = _TET_EDGES[src.integer(0, 5)]
            X, Y = tet[i], tet[j]
            t = _along(src, _norm(Y - X), u)
            P = X + t * (Y - X) + u.near(src, "tau") * _perp(src, Y - X if _norm(Y - X) else np.ones(3))
        else:
            P = tet[src.integer(0, 3)] + u.near(src, "sigma") * _rand_dir(src, 3)
        return tet + [P]

    raise KeyError(name)


def place(points, box_lo: Fraction, L: Fraction, bits: int):
    """Unit-box points → exact coordinates of the format: box_lo + L·x, rounded to
    ``bits`` and clamped to [box_lo, box_lo + L] (so every coordinate difference is ≤ L,
    the analysis' assumption). Returns None when a point leaves the unit box by more
    than a rounding (the construction overshot)."""
    out = []
    lo_f, L_f = float(box_lo), float(L)
    hi = box_lo + L
    for p in points:
        if not np.all(np.isfinite(p)) or np.any(p < -1e-12) or np.any(p > 1 + 1e-12):
            return None
        pt = []
        for x in p:
            v = round_bits(Fraction(lo_f + L_f * float(x)), bits)
            pt.append(min(max(v, box_lo), hi))
        out.append(tuple(pt))
    return tuple(out)


def max_difference(points) -> Fraction:
    """The largest coordinate difference in a configuration (exact)."""
    dim = len(points[0])
    return max(max(p[k] for p in points) - min(p[k] for p in points) for k in range(dim))


# ---------------------------------------------------------------------------------
# an independent reference for the reference: first-principles linear algebra


def _solve(M, y):
    """Exact Gaussian elimination (Fractions); None when singular."""
    n = len(M)
    a = [[Fraction(x) for x in row] + [Fraction(v)] for row, v in zip(M, y)]
    for c in range(n):
        piv = next((r for r in range(c, n) if a[r][c] != 0), None)
        if piv is None:
            return None
        a[c], a[piv] = a[piv], a[c]
        for r in range(n):
            if r != c and a[r][c] != 0:
                f = a[r][c] / a[c][c]
                a[r] = [x - f * y_ for x, y_ in zip(a[r], a[c])]
    return [a[r][n] / a[r][r] for r in range(n)]


def first_principles(dim: int, name: str, points):
    """Weights (and, where a bracket applies, the squared distance) computed from their
    geometric definitions — intersection points, projections, closest points — by
    solving linear systems, independently of the paper's formulas (eqs. 5–23)."""
    P_ = [tuple(frac(c) for c in p) for p in points]
    S, D = _sub, _dot
    if name == "edge_vertex":
        A, B, P = P_
        u = S(B, A)
        t = D(S(P, A), u) / D(u, u)
        X = tuple(a + t * b for a, b in zip(A, u))
        return (t,), D(S(P, X), S(P, X))
    if name == "edge_edge" and dim == 2:  # A + s(B − A) = P + t(Q − P)
        A, B, P, Q = P_
        u, v = S(B, A), S(Q, P)
        st_ = _solve([[u[0], -v[0]], [u[1], -v[1]]], S(P, A))
        return (tuple(st_) if st_ else None), None
    if name == "triangle_vertex" and dim == 2:  # P = aA + bB + cC, a + b + c = 1
        A, B, C, P = P_
        sol = _solve([[A[0], B[0], C[0]], [A[1], B[1], C[1]], [1, 1, 1]], [P[0], P[1], 1])
        return (tuple(sol) if sol else None), None
    if name == "edge_edge":  # closest points A + s·u, P + t·v (normal equations)
        A, B, P, Q = P_
        u, v, w = S(B, A), S(Q, P), S(P, A)
        st_ = _solve([[D(u, u), -D(u, v)], [D(u, v), -D(v, v)]], [D(w, u), D(w, v)])
        if st_ is None:
            return None, None
        s, t = st_
        X = tuple(a + s * b for a, b in zip(A, u))
        Y = tuple(a + t * b for a, b in zip(P, v))
        return (s, t), D(S(X, Y), S(X, Y))
    if name == "triangle_vertex":  # projection P' = A + b·u + c·v
        A, B, C, P = P_
        u, v, w = S(B, A), S(C, A), S(P, A)
        bc = _solve([[D(u, u), D(u, v)], [D(u, v), D(v, v)]], [D(w, u), D(w, v)])
        if bc is None:
            return None, None
        b, c = bc
        X = tuple(a + b * x + c * y for a, x, y in zip(A, u, v))
        return (1 - b - c, b, c), D(S(P, X), S(P, X))
    if name == "triangle_edge":  # plane crossing X = P + α(Q − P), then barycentrics of X
        A, B, C, P, Q = P_
        n = _cross3(S(B, A), S(C, A))
        den = D(n, S(Q, P))
        if den == 0:
            return None, None
        alpha = D(n, S(A, P)) / den
        X = tuple(p + alpha * (q - p) for p, q in zip(P, Q))
        u, v, w = S(B, A), S(C, A), S(X, A)
        bc = _solve([[D(u, u), D(u, v)], [D(u, v), D(v, v)]], [D(w, u), D(w, v)])
        if bc is None:
            return None, None
        return (1 - bc[0] - bc[1], bc[0], bc[1], alpha), None
    if name == "tetrahedron_vertex":  # P = Σ γ_i V_i, Σ γ_i = 1
        *V, P = P_
        M = [[V[j][k] for j in range(4)] for k in range(3)] + [[1, 1, 1, 1]]
        sol = _solve(M, list(P) + [1])
        return (tuple(sol) if sol else None), None
    return (), None
