"""The paper's PRINTED figures, for comparison in the generated report ONLY.

Nothing here feeds a constraint: :mod:`proofs.verify` and :mod:`proofs.constraints`
never import this module (a test checks it). Every number below is copied from the
paper's "Floating point:" and "Tolerance constraints:" lines, Figures 1 and 5 (R[T])
and section 5.4.4, so the report can show "paper printed" next to "derived".

Entries of :data:`CONSTRAINTS` are (text, match, compare):
  * text: the bullet as printed;
  * match: how to find the generated constraint: ("geometric", key),
    ("window", tolerance, quantity), ("sign", quantity), ("nonzero", quantity),
    ("special", tolerance);
  * compare: ("abs", K) when the printed bound is K·ε^k·L^p on the same quantity the
    derived absolute error bounds (window: E[x] + E[T]; sign/nonzero: E[x]), so the
    two integers can be compared; None when the printed form is different (relative,
    or in other units), explained in ``note``.
"""
from __future__ import annotations

#: Figure 1 / Figure 5 print R[T] ≤ 4ε for every tolerance.
R_T = 4

#: "Floating point:" lines: (quantity, "R" | "E" | "c", K) = R ≤ Kε, E ≤ Kε·L^p, |x| ≤ K·L^p.
FLOATING_POINT = {
    (2, "vertex_vertex"): [("d2", "R", 5), ("d2", "E", 9)],
    (2, "edge_vertex"): [("m", "R", 4), ("m", "E", 5), ("d", "E", 19), ("a_hat", "E", 19),
                         ("a_bar", "E", 26)],
    (2, "edge_edge"): [("a_P", "E", 9), ("a_Q", "E", 9), ("a_A", "E", 9), ("a_B", "E", 9)],
    (2, "triangle_vertex"): [("a_A", "E", 9), ("a_B", "E", 9), ("a_C", "E", 9)],
    (3, "vertex_vertex"): [("d2", "R", 6), ("d2", "E", 16)],
    (3, "edge_vertex"): [("m", "R", 4), ("m", "E", 7), ("d2", "E", 261), ("a_hat", "E", 31),
                         ("a_bar", "E", 42)],
    (3, "edge_edge"): [("m2", "E", 129), ("d_hat", "E", 47), ("d_hat2", "E", 589),
                       ("a_hat", "E", 129), ("b_hat", "E", 129), ("a_bar", "E", 281),
                       ("b_bar", "E", 281), ("m2", "c", 12)],
    (3, "triangle_vertex"): [("m2", "E", 129), ("d_hat", "E", 47), ("a_hat", "E", 445),
                             ("b_hat", "E", 129), ("c_hat", "E", 129)],
    (3, "triangle_edge"): [(q, "E", 47) for q in ("v_A", "v_B", "v_C", "v_P", "v_Q")],
    (3, "tetrahedron_vertex"): [(q, "E", 47) for q in ("v_A", "v_B", "v_C", "v_D")],
}

_VV = ("min(σ+ − σ, σ − σ−) > 8εσ", ("window", "sigma", "d2"), None,
       "printed in σ units from the relative bound R[d²]; derived in σ² units, also relative")

#: "Tolerance constraints:" bullets, per algorithm, in the paper's order.
CONSTRAINTS = {
    (2, "vertex_vertex"): [_VV],
    (2, "edge_vertex"): [
        ("m > 0, enforced by m ≥ σ̂−, with E[m] ≤ 5εL, so σ̂− > 5εL",
         ("nonzero", "m"), ("abs", 5), ""),
        ("ā > 0, enforced by ā > √(σ−² − τ+²), with E[ā] ≤ 26εL, so √(σ−² − τ+²) > 26εL",
         ("sign", "a_bar"), ("abs", 26), ""),
        ("â > 0, enforced by â > √(σ−² − τ+²), with E[â] ≤ 19εL, so √(σ−² − τ+²) > 19εL",
         ("sign", "a_hat"), ("abs", 19), ""),
        ("τ+ < (√3/2)σ−", ("geometric", "tau+<sqrt3/2*sigma-"), None, ""),
        ("σ− = σ̂+", ("geometric", "sigma_hat+<=sigma-"), None, ""),
        ("min(σ̂+ − σ̂, σ̂ − σ̂−) > 8εL", ("window", "sigma_hat", "m"), ("abs", 8),
         "derived uses the relative bound R[m] (m has r); its absolute form is compared"),
        ("min(τ+ − τ, τ − τ−) > 20εL", ("window", "tau", "d"), ("abs", 20), ""),
    ],
    (2, "edge_edge"): [
        ("κ+ = 2τ−²", ("geometric", "kappa+<=2tau-^2"), None, ""),
        ("|a_P| > 0, enforced by guaranteeing |a_P| > κ− and requiring κ− > E[a_P] ≥ 9εL²",
         ("sign", "a_P"), ("abs", 9), ""),
        ("min(κ+ − κ, κ − κ−) > 10εL²", ("window", "kappa", "|a_P|"), ("abs", 10), ""),
    ],
    (2, "triangle_vertex"): [
        ("κ+ = 2τ−²", ("geometric", "kappa+<=2tau-^2"), None, ""),
        ("a_A > 0, enforced by guaranteeing |a_A| > κ− and requiring κ− > E[a_A] ≥ 9εL²",
         ("sign", "a_A"), ("abs", 9), ""),
        ("min(κ+ − κ, κ − κ−) > 10εL²", ("window", "kappa", "|a_A|"), ("abs", 10), ""),
    ],
    (3, "vertex_vertex"): [_VV],
    (3, "edge_vertex"): [
        ("m > 0, enforced by m ≥ σ̂, with E[m] ≤ 7εL, so σ̂− > 7εL",
         ("nonzero", "m"), ("abs", 7), ""),
        ("ā > 0, enforced by ā > √(σ−² − τ+²), with E[ā] ≤ 42εL, so √(σ−² − τ+²) > 42εL",
         ("sign", "a_bar"), ("abs", 42), ""),
        ("â > 0, enforced by â > √(σ−² − τ+²), with E[â] ≤ 31εL, so √(σ−² − τ+²) > 31εL",
         ("sign", "a_hat"), ("abs", 31), ""),
        ("τ+ < (√3/2)σ−", ("geometric", "tau+<sqrt3/2*sigma-"), None, ""),
        ("σ− = σ̂+", ("geometric", "sigma_hat+<=sigma-"), None, ""),
        ("min(σ̂+ − σ̂, σ̂ − σ̂−) > 9εL", ("window", "sigma_hat", "m"), ("abs", 9),
         "derived uses the relative bound R[m] (m has r); its absolute form is compared"),
        ("min(τ+ − τ, τ − τ−) > 131εL²/τ", ("window", "tau", "d2"), None,
         "printed in τ units; derived in τ² units (τ±² − τ² vs E[d²] + E[τ²]); "
         "τ+² − τ² ≥ 2τ(τ+ − τ), so the printed form corresponds to 262εL²"),
    ],
    (3, "edge_edge"): [
        ("λ+ = 16(τ−² − γ+²)²", ("geometric", "lam+<=16(tau-^2-gamma+^2)^2"), None, ""),
        ("φ+ = 8(τ−² − γ+²)²", ("geometric", "phi+<=8(tau-^2-gamma+^2)^2"), None, ""),
        ("m² ≤ λ with E[m²] ≤ 129εL⁴ leads to min(λ+ − λ, λ − λ−) > 130εL⁴",
         ("window", "lam", "m2"), ("abs", 130), ""),
        ("â ≤ φ with E[â] ≤ 129εL⁴ leads to min(φ+ − φ, φ − φ−) > 130εL⁴",
         ("window", "phi", "a_hat"), ("abs", 130), ""),
        ("ā ≤ φ with E[ā] ≤ 281εL⁴ leads to min(φ+ − φ, φ − φ−) > 282εL⁴",
         ("window", "phi", "a_bar"), ("abs", 282), ""),
        ("d̂² ≤ γ²m², addressed in Section 5.4.4", ("special", "gamma"), None, ""),
    ],
    (3, "triangle_vertex"): [
        ("ν+ = 108(τ−² − δ+²)²", ("geometric", "nu+<=108(tau-^2-delta+^2)^2"), None, ""),
        ("ζ+ = 12√3(τ−² − δ+²)²", ("geometric", "zeta+<=12sqrt3(tau-^2-delta+^2)^2"), None,
         ""),
        ("m² ≤ ν with E[m²] ≤ 129εL⁴ leads to min(ν+ − ν, ν − ν−) > 130εL⁴",
         ("window", "nu", "m2"), ("abs", 130), ""),
        ("â ≤ ζ with E[â] ≤ 445εL⁴ leads to min(ζ+ − ζ, ζ − ζ−) > 446εL⁴",
         ("window", "zeta", "a_hat"), ("abs", 446), ""),
        ("b̂ ≤ ζ with E[b̂] ≤ 129εL⁴ leads to min(ζ+ − ζ, ζ − ζ−) > 130εL⁴",
         ("window", "zeta", "b_hat"), ("abs", 130), ""),
        ("ĉ ≤ ζ with E[ĉ] ≤ 129εL⁴ leads to min(ζ+ − ζ, ζ − ζ−) > 130εL⁴",
         ("window", "zeta", "c_hat"), ("abs", 130), ""),
        ("d̂² ≤ δ²m², identical to the case addressed in Section 5.4.4",
         ("special", "delta"), None,
         "not identical: the lower bound on m² here is ν− (3422.25εL⁴), not λ− (910εL⁴)"),
    ],
    (3, "triangle_edge"): [
        ("μ+ = 4γ−²·min(γ−, δ−)", ("geometric", "mu+<=4gamma-^2min(gamma-,delta-)"), None, ""),
        ("ξ+ = 6√3γ−²·min(γ−, δ−)", ("geometric", "xi+<=6sqrt3gamma-^2min(gamma-,delta-)"),
         None, ""),
        ("v_A > 0, enforced by guaranteeing |v_A| > μ− and requiring μ− > E[v_A] ≥ 47εL³",
         ("sign", "v_A"), ("abs", 47), ""),
        ("v_P > 0, enforced by guaranteeing |v_P| > ξ− and requiring ξ− > E[v_P] ≥ 47εL³",
         ("sign", "v_P"), ("abs", 47), ""),
        ("min(μ+ − μ, μ − μ−) > 48εL³", ("window", "mu", "|v_A|"), ("abs", 48), ""),
        ("min(ξ+ − ξ, ξ − ξ−) > 48εL³", ("window", "xi", "|v_P|"), ("abs", 48), ""),
    ],
    (3, "tetrahedron_vertex"): [
        ("ρ+ = 6√3δ−³", ("geometric", "rho+<=6sqrt3delta-^3"), None, ""),
        ("v_A > 0, enforced by guaranteeing |v_A| > ρ− and requiring ρ− > E[v_A] ≥ 47εL³",
         ("sign", "v_A"), ("abs", 47), ""),
        ("min(ρ+ − ρ, ρ − ρ−) > 48εL³", ("window", "rho", "|v_A|"), ("abs", 48), ""),
    ],
}

#: Section 5.4.4 as printed (edge-edge; triangle-vertex "identical").
SECTION_544 = {
    "R[m²]": "R[m²] < 129/910 (from m² > λ− = 910εL⁴ and E[m²] ≤ 129εL⁴)",
    "R[γ²m²]": "R[γ²m²] < (1 + 12ε)R[m²] + 12ε < 1/7 (using R[γ²] < 10ε)",
    "coefficient": "(351/4·(6/5·ε − 2/35) + 94√(6/5)·ε^(1/4)(1 + ε)) ≤ −5",
    "g": "g(2/35·γ²m²) ≤ −400ε^(3/2)L⁶ < 0",
    "g'": "g'(x) < −0.9",
    "m bound": "γm ≥ (2.25ε^(1/4)L)·4(τ−² − γ+²) on both sides",
    "E[d̂]": "E[d̂] ≤ 47εL³",
}
