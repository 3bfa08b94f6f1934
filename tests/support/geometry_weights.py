"""The guaranteed accuracy of each weight a predicate returns, for an exact
configuration (:func:`weight_error_bounds`): every weight is a quotient of computed
quantities whose derived bounds E (the instrumented run, :func:`fperr.bounds`) are
evaluated at the tolerances' ε and L (docs/notes.md, "Weight accuracy").
"""
from __future__ import annotations

import functools
from fractions import Fraction

import sympy

import fperr
import predicates
from geometry_exact import Exact, sqrt_lo


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
