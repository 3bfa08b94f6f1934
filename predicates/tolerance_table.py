"""Figures 1 and 5 of the paper: the tolerances T and their exact brackets T−, T+.

These are the paper's *design choices* (inputs of the method, not derived figures), kept
exact. Every entry is a coefficient times ε^q·L^p; a T+ the paper prints as "≈" is
stored as the exact geometric expression that defines it (section 5.5.3 ζ+ = 12√3(τ−² −
δ+²)², section 5.6 ξ+ = 6√3γ−²·min(γ−, δ−), section 5.7 ρ+ = 6√3δ−³), and so are the
other T+ the proofs fix by a geometric identity (κ+, λ+, φ+, ν+, μ+): the verifier
checks those identities rather than trusting these numbers.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

R = sympy.Rational
S3 = sympy.sqrt(3)


@dataclass(frozen=True)
class ToleranceSpec:
    """T = coefficient·ε^q·L^p, with brackets lo = T−, hi = T+ (same ε^q·L^p factor)."""

    name: str
    lo: sympy.Expr
    mid: sympy.Expr
    hi: sympy.Expr
    q: sympy.Rational
    p: int
    description: str


def _spec(name, lo, mid, hi, q, p, desc):
    return ToleranceSpec(name, sympy.nsimplify(lo), sympy.nsimplify(mid), sympy.nsimplify(hi),
                         R(q), p, desc)


TABLE_2D = {
    "sigma": _spec("sigma", 6, R(13, 2), 7, R(1, 2), 1, "vertex-vertex"),
    "tau": _spec("tau", 4, R(9, 2), 5, R(1, 2), 1, "edge-vertex"),
    "sigma_hat": _spec("sigma_hat", 5, R(11, 2), 6, R(1, 2), 1,
                       "vertex-vertex degeneracy rejection"),
    "kappa": _spec("kappa", 10, 21, 32, 1, 2, "edge-edge area bound"),
}

TABLE_3D = {
    "sigma": _spec("sigma", 6, R(13, 2), 7, R(1, 4), 1, "vertex-vertex"),
    "tau": _spec("tau", 4, R(9, 2), 5, R(1, 4), 1, "edge-vertex"),
    "delta": _spec("delta", 2, R(9, 4), R(5, 2), R(1, 4), 1, "face-vertex"),
    "gamma": _spec("gamma", 2, R(9, 4), R(5, 2), R(1, 4), 1, "edge-edge"),
    "sigma_hat": _spec("sigma_hat", 5, R(11, 2), 6, R(1, 4), 1,
                       "vertex-vertex degeneracy rejection"),
    "lam": _spec("lam", 910, 1215, 1521, 1, 4, "edge-edge area bound"),
    "phi": _spec("phi", 150, 470, R(1521, 2), 1, 4, "edge-edge volume bound"),
    "nu": _spec("nu", R(342225, 100), R(13689, 2), R(1026675, 100), 1, 4,
                "triangle-vertex area bound"),
    "zeta": _spec("zeta", 658, 1317, 12 * S3 * R(1521, 16), 1, 4,
                  "triangle-vertex volume bound"),
    "mu": _spec("mu", 16, 24, 32, R(3, 4), 3, "triangle-edge volume bound"),
    "xi": _spec("xi", 28, 56, 6 * S3 * 8, R(3, 4), 3, "triangle-edge volume bound"),
    "rho": _spec("rho", 28, 56, 6 * S3 * 8, R(3, 4), 3, "tetrahedron-vertex volume bound"),
}

TABLES = {2: TABLE_2D, 3: TABLE_3D}

#: L = (1 + 5ε)/(1 − 7·ε^g)·(L_a + L_b), g = 1/2 in 2D, 1/4 in 3D (Algorithms 1 and 6):
#: 7 = σ+'s coefficient, the largest tolerance (section 4.1's text says 8: an erratum).
L_ROOT = {2: R(1, 2), 3: R(1, 4)}
L_SIGMA_PLUS = 7
