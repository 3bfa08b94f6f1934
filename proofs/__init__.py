"""proofs: tolerance constraints of the paper, verified for every ε ≤ 1e-5 (top layer)."""
