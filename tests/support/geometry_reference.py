"""An independent reference for the reference (:mod:`geometry_exact`): the weights and
squared distances from their geometric definitions — intersection points, projections,
closest points — by exact linear algebra, not from the paper's formulas (eqs. 5–23).
"""
from __future__ import annotations

from fractions import Fraction

from geometry_exact import _cross3, _dot, _sub, frac


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
