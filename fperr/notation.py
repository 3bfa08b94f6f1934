"""The paper's notation as text: Greek names of the tolerances, powers of L and ε.

Pure text formatting (no geometry, no bounds), shared by ``fperr tables``
(:mod:`predicates.tables`) and the generated report (:mod:`proofs.report`), so each
symbol is spelled in one place. Names are those of the tolerance tables (Figure 1 and
Figure 5 of the paper: sigma, tau, ..., rho; ``lam`` is λ).
"""
from __future__ import annotations

import sympy

#: tolerance name -> (Unicode, LaTeX), Figures 1 and 5
SYMBOLS: dict[str, tuple[str, str]] = {
    "sigma": ("σ", r"\sigma"), "tau": ("τ", r"\tau"), "sigma_hat": ("σ̂", r"\hat{\sigma}"),
    "kappa": ("κ", r"\kappa"), "delta": ("δ", r"\delta"), "gamma": ("γ", r"\gamma"),
    "lam": ("λ", r"\lambda"), "phi": ("φ", r"\phi"), "nu": ("ν", r"\nu"),
    "zeta": ("ζ", r"\zeta"), "mu": ("μ", r"\mu"), "xi": ("ξ", r"\xi"), "rho": ("ρ", r"\rho"),
}

#: tolerance name -> Unicode symbol
GREEK: dict[str, str] = {k: u for k, (u, _) in SYMBOLS.items()}

#: tolerance name -> LaTeX symbol
LATEX_GREEK: dict[str, str] = {k: t for k, (_, t) in SYMBOLS.items()}

#: digits -> superscript digits
SUP = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def lpow(p, superscript: bool = True) -> str:
    """L^p as text: "" for p = 0, "L" for p = 1; else "L²" (``superscript``, a
    non-integer p as "L^(3/2)") or "L^2" (plain, p printed as given)."""
    if not superscript:
        return "" if p == 0 else ("L" if p == 1 else f"L^{p}")
    p = sympy.nsimplify(p)
    if p == 0:
        return ""
    if p == 1:
        return "L"
    return "L" + (str(p).translate(SUP) if p.is_Integer else f"^({p})")


def epow(q) -> str:
    """ε^q as text: "ε", "√ε", else "ε^(q)"."""
    q = sympy.nsimplify(q)
    return {sympy.Rational(1, 2): "√ε", sympy.Integer(1): "ε"}.get(q, f"ε^({q})")


def greek(name: str, which: str = "") -> str:
    """The symbol of tolerance ``name`` with its bracket end: ``which`` "lo" (T−),
    "hi" (T+) or "" (T). Unknown names are returned as given."""
    return GREEK.get(name, name) + {"lo": "−", "hi": "+", "": ""}[which]
