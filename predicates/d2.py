"""2D predicates: Algorithms 2–5 of the paper (section 4).

Each function is the paper's pseudocode, written once against a context ``ctx`` (see
:mod:`fperr.contexts`); line numbers in ``reject(..., line=)`` are the algorithm's. The
"degenerate intersection" test of line 2 belongs to the registration layer. Deviations
from the printed pseudocode are listed in docs/errata.md.
"""
from __future__ import annotations

from .core import predicate
from .vector import cross2, dot, scale, sub

__all__ = ["edge_edge", "edge_vertex", "triangle_vertex", "vertex_vertex"]


@predicate(dim=2, points="AB", algorithm=2, section="4.2", sim="A", bracket="sigma",
           reach=("sigma", 7 / 6.5))
def vertex_vertex(ctx, A, B, tol):
    """Algorithms 2 and 7 (sections 4.2, 5.2): hit when d² = ‖A − B‖² ≤ σ². No weights.

    The same source serves ``d3.vertex_vertex`` (the body is dimension-free)."""
    w = sub(A, B)
    d2 = ctx.name("d2", dot(w, w))
    if ctx.reject(d2 > tol.sigma * tol.sigma, line=2):
        return ctx.miss()
    return ctx.hit(())


@predicate(dim=2, points="ABP", weights=("a",), algorithm=3, section="4.3", sim="AB",
           bracket="tau", reach=("tau", 5.5 / 4.5))
def edge_vertex(ctx, A, B, P, tol):
    """Algorithm 3 (section 4.3): P within τ of edge AB, strictly between A and B.

    Returns the weight a = â/m of P along AB (P ≈ (1 − a)·A + a·B). Uses û = B − A
    (the paper prints A − B, which makes â negative for P inside the edge: erratum E1).
    """
    u_hat = sub(B, A)
    m = ctx.name("m", ctx.sqrt(dot(u_hat, u_hat)))
    if ctx.reject(m <= tol.sigma_hat, line=7):
        return ctx.miss()
    u = scale(u_hat, 1 / m)  # û·(1/m): a reciprocal, then products (rule G's c = 1)
    w = sub(P, A)
    d = ctx.name("d", abs(cross2(u, w)))
    if ctx.reject(d > tol.tau, line=12):
        return ctx.miss()
    a_hat = ctx.name("a_hat", dot(u, w))
    a_bar = ctx.name("a_bar", m - a_hat)
    if ctx.reject(ctx.any(a_hat < 0, a_bar < 0), line=17):
        return ctx.miss()
    return ctx.hit((a_hat / m,))


@predicate(dim=2, points="ABPQ", weights=("alpha_AB", "alpha_PQ"), algorithm=4,
           section="4.4", sim="AB", reach=("tau", 1.0))
def edge_edge(ctx, A, B, P, Q, tol):
    """Algorithm 4 (section 4.4): edges AB and PQ cross.

    Returns (a_A/(a_A − a_B), a_P/(a_P − a_Q)): the crossing is A + α_AB·(B − A) =
    P + α_PQ·(Q − P). The signature gains Q (missing in the printed pseudocode).
    """
    BA = sub(B, A)
    a_P = ctx.name("a_P", cross2(sub(P, A), BA))
    a_Q = ctx.name("a_Q", cross2(sub(Q, A), BA))
    kappa = tol.kappa
    if ctx.reject(ctx.any(abs(a_P) <= kappa, abs(a_Q) <= kappa, ctx.same_sign(a_P, a_Q)),
                  line=7):
        return ctx.miss()
    QP = sub(Q, P)
    a_A = ctx.name("a_A", cross2(sub(A, P), QP))
    a_B = ctx.name("a_B", cross2(sub(B, P), QP))
    if ctx.reject(ctx.any(abs(a_A) <= kappa, abs(a_B) <= kappa, ctx.same_sign(a_A, a_B)),
                  line=12):
        return ctx.miss()
    return ctx.hit((a_A / (a_A - a_B), a_P / (a_P - a_Q)))


@predicate(dim=2, points="ABCP", weights=("gamma_A", "gamma_B", "gamma_C"), algorithm=5,
           section="4.5", sim="ABC", reach=("tau", 1.0))
def triangle_vertex(ctx, A, B, C, P, tol):
    """Algorithm 5 (section 4.5): P strictly inside triangle ABC.

    Returns the barycentric weights (γ_A, γ_B, γ_C) of P. The signature gains C
    (missing in the printed pseudocode).
    """
    a_A = ctx.name("a_A", cross2(sub(B, P), sub(C, P)))
    CA = sub(C, A)
    a_B = ctx.name("a_B", cross2(sub(P, A), CA))
    a_C = ctx.name("a_C", cross2(sub(B, A), sub(P, A)))
    kappa = tol.kappa
    if ctx.reject(ctx.any(abs(a_A) <= kappa, abs(a_B) <= kappa, abs(a_C) <= kappa,
                          ctx.differ_sign(a_A, a_B), ctx.differ_sign(a_B, a_C)), line=8):
        return ctx.miss()
    total = a_A + a_B + a_C
    return ctx.hit((a_A / total, a_B / total, a_C / total))
