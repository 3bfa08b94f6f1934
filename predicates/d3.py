"""3D predicates: Algorithms 7–12 of the paper (section 5).

Written once against a context ``ctx`` (see :mod:`fperr.contexts`); line numbers in
``reject(..., line=)`` are the algorithm's. The "degenerate intersection" test of
line 2 belongs to the registration layer. Deviations from the printed pseudocode are
listed in docs/errata.md.
"""
from __future__ import annotations

from . import d2
from .core import predicate
from .vector import cross3, dot, scale, sub, triple

__all__ = ["edge_edge", "edge_vertex", "tetrahedron_vertex", "triangle_edge",
           "triangle_vertex", "vertex_vertex"]


#: Algorithm 7 (section 5.2) is Algorithm 2 in three coordinates: one source for both.
vertex_vertex = predicate(dim=3, points="AB", algorithm=7, section="5.2", sim="A",
                          bracket="sigma", reach=("sigma", 7 / 6.5))(d2.vertex_vertex.fn)


@predicate(dim=3, points="ABP", weights=("a",), algorithm=8, section="5.3", sim="AB",
           bracket="tau", reach=("tau", 5.5 / 4.5))
def edge_vertex(ctx, A, B, P, tol):
    """Algorithm 8 (section 5.3): P within τ of edge AB, strictly between A and B.

    Checks d² = ‖u × w‖² ≤ τ² (no square root of d). Returns a = â/m, the weight of P
    along AB. Uses û = B − A (erratum E1, as in Algorithm 3).
    """
    u_hat = sub(B, A)
    m = ctx.name("m", ctx.sqrt(dot(u_hat, u_hat)))
    if ctx.reject(m <= tol.sigma_hat, line=7):
        return ctx.miss()
    u = scale(u_hat, 1 / m)
    w = sub(P, A)
    c = cross3(u, w)
    d2 = ctx.name("d2", dot(c, c))
    if ctx.reject(d2 > tol.tau * tol.tau, line=12):
        return ctx.miss()
    a_hat = ctx.name("a_hat", dot(u, w))
    a_bar = ctx.name("a_bar", m - a_hat)
    if ctx.reject(ctx.any(a_hat < 0, a_bar < 0), line=17):
        return ctx.miss()
    return ctx.hit((a_hat / m,))


@predicate(dim=3, points="ABPQ", weights=("a", "b"), algorithm=9, section="5.4", sim="AB",
           bracket="gamma", reach=("gamma", 2.75 / 2.25))
def edge_edge(ctx, A, B, P, Q, tol):
    """Algorithm 9 (section 5.4): edges AB and PQ pass within γ of each other.

    Returns (â/m², b̂/m²): the closest points are A + a·(B − A) and P + b·(Q − P).
    """
    u = sub(B, A)
    v = sub(Q, P)
    r = cross3(u, v)
    m2 = ctx.name("m2", dot(r, r))
    if ctx.reject(m2 <= tol.lam, line=9):
        return ctx.miss()
    w = sub(P, A)
    d_hat = ctx.name("d_hat", dot(r, w))
    d_hat2 = ctx.name("d_hat2", d_hat * d_hat)
    if ctx.reject(d_hat2 > (tol.gamma * tol.gamma) * m2, line=14):
        return ctx.miss()
    n = cross3(r, w)
    a_hat = ctx.name("a_hat", dot(n, v))
    b_hat = ctx.name("b_hat", dot(n, u))
    a_bar = ctx.name("a_bar", m2 - a_hat)
    b_bar = ctx.name("b_bar", m2 - b_hat)
    phi = tol.phi
    if ctx.reject(ctx.any(a_hat <= phi, b_hat <= phi, a_bar <= phi, b_bar <= phi), line=22):
        return ctx.miss()
    return ctx.hit((a_hat / m2, b_hat / m2))


@predicate(dim=3, points="ABCP", weights=("a", "b", "c"), algorithm=10, section="5.5",
           sim="ABC", bracket="delta", reach=("delta", 2.75 / 2.25))
def triangle_vertex(ctx, A, B, C, P, tol):
    """Algorithm 10 (section 5.5): P within δ of triangle ABC, projecting inside it.

    Returns the barycentric weights (â, b̂, ĉ)/m² of P's projection.
    """
    u = sub(B, A)
    v = sub(C, A)
    r = cross3(u, v)
    m2 = ctx.name("m2", dot(r, r))
    if ctx.reject(m2 <= tol.nu, line=9):
        return ctx.miss()
    w = sub(P, A)
    d_hat = ctx.name("d_hat", dot(r, w))
    d_hat2 = ctx.name("d_hat2", d_hat * d_hat)
    if ctx.reject(d_hat2 > (tol.delta * tol.delta) * m2, line=14):
        return ctx.miss()
    n = cross3(r, w)
    b_hat = ctx.name("b_hat", dot(n, v))
    c_hat = ctx.name("c_hat", -dot(n, u))
    a_hat = ctx.name("a_hat", m2 - b_hat - c_hat)
    zeta = tol.zeta
    if ctx.reject(ctx.any(a_hat <= zeta, b_hat <= zeta, c_hat <= zeta), line=21):
        return ctx.miss()
    return ctx.hit((a_hat / m2, b_hat / m2, c_hat / m2))


@predicate(dim=3, points="ABCPQ", weights=("gamma_A", "gamma_B", "gamma_C", "alpha_P"),
           algorithm=11, section="5.6", sim="ABC", reach=("tau", 1.0))
def triangle_edge(ctx, A, B, C, P, Q, tol):
    """Algorithm 11 (section 5.6): edge PQ crosses triangle ABC.

    Returns the barycentric weights (γ_A, γ_B, γ_C) of the crossing on ABC and
    α_P = v_P/(v_P − v_Q), its parameter along PQ (crossing = P + α_P·(Q − P)).
    """
    PQ = sub(P, Q)
    AQ, BQ, CQ = sub(A, Q), sub(B, Q), sub(C, Q)
    v_A = ctx.name("v_A", triple(BQ, CQ, PQ))
    v_B = ctx.name("v_B", triple(CQ, AQ, PQ))
    v_C = ctx.name("v_C", triple(AQ, BQ, PQ))
    mu = tol.mu
    if ctx.reject(ctx.any(abs(v_A) <= mu, abs(v_B) <= mu, abs(v_C) <= mu,
                          ctx.differ_sign(v_A, v_B), ctx.differ_sign(v_B, v_C)), line=8):
        return ctx.miss()
    v_P = ctx.name("v_P", triple(sub(A, P), sub(B, P), sub(C, P)))
    v_Q = ctx.name("v_Q", triple(AQ, BQ, CQ))
    xi = tol.xi
    if ctx.reject(ctx.any(abs(v_P) <= xi, abs(v_Q) <= xi, ctx.same_sign(v_P, v_Q)), line=13):
        return ctx.miss()
    total = v_A + v_B + v_C
    return ctx.hit((v_A / total, v_B / total, v_C / total, v_P / (v_P - v_Q)))


@predicate(dim=3, points="ABCDP", weights=("gamma_A", "gamma_B", "gamma_C", "gamma_D"),
           algorithm=12, section="5.7", sim="ABCD", reach=("tau", 1.0))
def tetrahedron_vertex(ctx, A, B, C, D, P, tol):
    """Algorithm 12 (section 5.7): P strictly inside tetrahedron ABCD.

    Returns the barycentric weights (γ_A, γ_B, γ_C, γ_D) of P.
    """
    DA = sub(D, A)
    PA = sub(P, A)
    v_A = ctx.name("v_A", triple(sub(B, P), sub(C, P), sub(D, P)))
    v_B = ctx.name("v_B", triple(PA, sub(C, A), DA))
    v_C = ctx.name("v_C", triple(sub(B, A), PA, DA))
    v_D = ctx.name("v_D", triple(sub(B, A), sub(C, A), PA))
    rho = tol.rho
    if ctx.reject(ctx.any(abs(v_A) <= rho, abs(v_B) <= rho, abs(v_C) <= rho,
                          abs(v_D) <= rho), line=9):
        return ctx.miss()
    if ctx.reject(ctx.any(ctx.differ_sign(v_A, v_B), ctx.differ_sign(v_B, v_C),
                          ctx.differ_sign(v_C, v_D)), line=12):
        return ctx.miss()
    total = v_A + v_B + v_C + v_D
    return ctx.hit((v_A / total, v_B / total, v_C / total, v_D / total))
