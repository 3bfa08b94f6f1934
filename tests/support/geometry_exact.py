"""Exact reference geometry for the predicate tests (no floating point in the verdicts).

* **numbers** — :func:`frac` (the exact value of a float / numpy scalar / mpf),
  :func:`round_bits` (correct rounding to a ``bits``-bit significand, ties to even);
* **thresholds** — :func:`threshold4`: T⁴ for T = T−, T or T+ of Figures 1 and 5
  (exact: T itself is irrational in 3D, ε^¼, but T⁴ is rational), so "distance ≤ T"
  is decided as (distance²)² ≤ T⁴;
* **exact predicates** — :func:`exact_eval`: every quantity the paper names, evaluated
  exactly (Python integers after scaling the dyadic coordinates to a common
  denominator), the exact weights, and the exact "inside" test of each predicate with a
  given bracket (T− or T+).

Around it: the guaranteed accuracy of each returned weight
(:func:`geometry_weights.weight_error_bounds`), an independent check of this reference
from first principles (:func:`geometry_reference.first_principles`), and the
adversarial configurations the tests evaluate (:func:`geometry_constructions.construct`,
placed by :func:`geometry_cases.place`); the lower-level pairs the registration checks
before a pair are ``predicates.catalogue.sub_pairs``.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction

import mpmath
import sympy

from fperr import round_fraction, to_fraction
from proofs.tables import TABLES


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
    ev = _Eval(dim, name, ip, Fraction(1, den), Fraction(eps), Fraction(L), {})
    if dim == 2 and name in _PLANAR:
        return _PLANAR[name](ev)
    if name not in _EVALUATORS:
        raise KeyError((dim, name))
    return _EVALUATORS[name](ev)


@dataclass
class _Eval:
    """One exact evaluation under way: the points as integers (common denominator
    1/s), the tolerances' ε and L, and the quantities found so far (true scale)."""

    dim: int
    name: str
    ip: list
    s: Fraction
    eps: Fraction
    L: Fraction
    q: dict

    def F(self, v, deg: int) -> Fraction:
        """An integer quantity of degree ``deg`` back at the true scale."""
        return Fraction(v) * self.s**deg

    def T4(self, tname: str, which: str) -> Fraction:
        return threshold4(self.dim, tname, which, self.eps, self.L)

    def done(self, weights, inside) -> Exact:
        return Exact(self.dim, self.name, self.q, weights, self.eps, self.L, inside)


def _vertex_vertex(ev: _Eval) -> Exact:
    A, B = ev.ip
    d2 = ev.F(_dot(_sub(A, B), _sub(A, B)), 2)
    ev.q["d2"] = d2
    return ev.done((), lambda w: le_T(d2, ev.T4("sigma", w)))


def _edge_vertex(ev: _Eval) -> Exact:
    A, B, P = ev.ip
    u, w = _sub(B, A), _sub(P, A)
    m2 = _dot(u, u)
    uw = _dot(u, w)  # = â·m
    if ev.dim == 2:
        c2 = _cross2(u, w) ** 2
    else:
        c = _cross3(u, w)
        c2 = _dot(c, c)
    ev.q.update(m2=ev.F(m2, 2), uw=ev.F(uw, 2))
    if m2 == 0:
        return ev.done(None, lambda w_: False)
    d2 = ev.F(c2, 4) / ev.F(m2, 2)  # |û × w|²/|û|²
    ev.q["d2"] = d2
    return ev.done((Fraction(uw, m2),),
                   lambda which: le_T(d2, ev.T4("tau", which)) and 0 < uw < m2)


def _edge_edge_2d(ev: _Eval) -> Exact:
    A, B, P, Q = ev.ip
    BA, QP = _sub(B, A), _sub(Q, P)
    aP, aQ = _cross2(_sub(P, A), BA), _cross2(_sub(Q, A), BA)
    aA, aB = _cross2(_sub(A, P), QP), _cross2(_sub(B, P), QP)
    ev.q.update(a_P=ev.F(aP, 2), a_Q=ev.F(aQ, 2), a_A=ev.F(aA, 2), a_B=ev.F(aB, 2))
    proper = _sgn(aP) * _sgn(aQ) == -1 and _sgn(aA) * _sgn(aB) == -1
    weights = (Fraction(aA, aA - aB), Fraction(aP, aP - aQ)) if proper else None
    return ev.done(weights, lambda w_: proper)


def _triangle_vertex_2d(ev: _Eval) -> Exact:
    A, B, C, P = ev.ip
    aA = _cross2(_sub(B, P), _sub(C, P))
    aB = _cross2(_sub(P, A), _sub(C, A))
    aC = _cross2(_sub(B, A), _sub(P, A))
    ev.q.update(a_A=ev.F(aA, 2), a_B=ev.F(aB, 2), a_C=ev.F(aC, 2))
    inside = aA != 0 and _sgn(aA) == _sgn(aB) == _sgn(aC)
    tot = aA + aB + aC
    weights = tuple(Fraction(x, tot) for x in (aA, aB, aC)) if inside else None
    return ev.done(weights, lambda w_: inside)


def _closest_3d(ev: _Eval) -> Exact:
    """3D edge-edge and triangle-vertex: the same algebra, eqs. (13)-(16)."""
    if ev.name == "edge_edge":
        A, B, P, Q = ev.ip
        u, v, w = _sub(B, A), _sub(Q, P), _sub(P, A)
    else:
        A, B, C, P = ev.ip
        u, v, w = _sub(B, A), _sub(C, A), _sub(P, A)
    r = _cross3(u, v)
    m2 = _dot(r, r)
    dh = _dot(r, w)
    n = _cross3(r, w)
    F, q = ev.F, ev.q
    q.update(m2=F(m2, 4), d_hat=F(dh, 3))
    if ev.name == "edge_edge":
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
    return ev.done(weights, lambda which: signs_ok and le_T(dist2, ev.T4(tname, which)))


def _triangle_edge(ev: _Eval) -> Exact:
    A, B, C, P, Q = ev.ip
    PQ = _sub(P, Q)
    AQ, BQ, CQ = _sub(A, Q), _sub(B, Q), _sub(C, Q)
    vA, vB, vC = _triple(BQ, CQ, PQ), _triple(CQ, AQ, PQ), _triple(AQ, BQ, PQ)
    vP = _triple(_sub(A, P), _sub(B, P), _sub(C, P))
    vQ = _triple(AQ, BQ, CQ)
    F = ev.F
    ev.q.update(v_A=F(vA, 3), v_B=F(vB, 3), v_C=F(vC, 3), v_P=F(vP, 3), v_Q=F(vQ, 3))
    proper = (vA != 0 and _sgn(vA) == _sgn(vB) == _sgn(vC)
              and _sgn(vP) * _sgn(vQ) == -1)
    tot = vA + vB + vC
    weights = ((Fraction(vA, tot), Fraction(vB, tot), Fraction(vC, tot),
                Fraction(vP, vP - vQ)) if proper else None)
    return ev.done(weights, lambda w_: proper)


def _tetrahedron_vertex(ev: _Eval) -> Exact:
    A, B, C, D, P = ev.ip
    DA, PA = _sub(D, A), _sub(P, A)
    vA = _triple(_sub(B, P), _sub(C, P), _sub(D, P))
    vB = _triple(PA, _sub(C, A), DA)
    vC = _triple(_sub(B, A), PA, DA)
    vD = _triple(_sub(B, A), _sub(C, A), PA)
    F = ev.F
    ev.q.update(v_A=F(vA, 3), v_B=F(vB, 3), v_C=F(vC, 3), v_D=F(vD, 3))
    inside = vA != 0 and _sgn(vA) == _sgn(vB) == _sgn(vC) == _sgn(vD)
    tot = vA + vB + vC + vD
    weights = tuple(Fraction(x, tot) for x in (vA, vB, vC, vD)) if inside else None
    return ev.done(weights, lambda w_: inside)


_PLANAR = {"edge_edge": _edge_edge_2d, "triangle_vertex": _triangle_vertex_2d}
_EVALUATORS = {"vertex_vertex": _vertex_vertex, "edge_vertex": _edge_vertex,
               "edge_edge": _closest_3d, "triangle_vertex": _closest_3d,
               "triangle_edge": _triangle_edge, "tetrahedron_vertex": _tetrahedron_vertex}


def max_difference(points) -> Fraction:
    """The largest coordinate difference in a configuration (exact)."""
    dim = len(points[0])
    return max(max(p[k] for p in points) - min(p[k] for p in points) for k in range(dim))
