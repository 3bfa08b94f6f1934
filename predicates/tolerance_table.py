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
from fractions import Fraction

from .coefficients import CoefficientError, Monomial, constant, parse, value

R = Fraction
#: √3 as an exact coefficient (sympy-free: the float and numpy paths never load sympy)
S3 = value(parse("sqrt(3)"))


@dataclass(frozen=True)
class ToleranceSpec:
    """T = coefficient·ε^q·L^p, with brackets lo = T−, hi = T+ (same ε^q·L^p factor).

    Coefficients are exact: Fractions and :class:`~predicates.coefficients.Monomial`
    here; the proofs hold sympy numbers (:data:`proofs.tables.TABLES`). Both compare
    equal when equal."""

    name: str
    lo: object
    mid: object
    hi: object
    q: Fraction
    p: int
    description: str


def _exact(x: Monomial):
    """A Fraction when rational, else the Monomial."""
    return x.fraction() if x.is_rational else x


def _spec(name, lo, mid, hi, q, p, desc):
    lo, mid, hi = (_exact(constant(x)) for x in (lo, mid, hi))
    return ToleranceSpec(name, lo, mid, hi, R(q), p, desc)


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


_FIELD_NAMES = {"lo": "lo", "t-": "lo", "minus": "lo", "mid": "mid", "t": "mid",
                "hi": "hi", "t+": "hi", "plus": "hi"}


def resolve_table(dim: int, table=None) -> dict:
    """The table (name → :class:`ToleranceSpec`) to compute tolerances with.

    ``table``: None (Figure 1/5), a full mapping name → ToleranceSpec, or coefficient
    overrides ``{name: {"lo"|"mid"|"hi": value}}``, optionally keyed by dimension first
    (``{3: {...}}``, the structure of ``fperr verify --tolerances`` files after
    :func:`proofs.tables.load_overrides`, and of ``fperr synthesize`` tables). Values are
    exact: ints, Fractions, decimal floats, sympy numbers or strings of the grammar of
    :mod:`predicates.coefficients` such as "269/64" or "2*(7/2)**2" (a
    :class:`~predicates.coefficients.CoefficientError` names the entry otherwise).
    """
    base = dict(TABLES[dim])
    if table is None:
        return base
    if not isinstance(table, dict):
        raise TypeError(f"a tolerance table must be a dict, got {type(table).__name__}")
    keyed = {str(k).lower().removesuffix("d"): v for k, v in table.items()}
    if keyed and set(keyed) <= {"2", "3"}:
        if str(dim) not in keyed:
            raise ValueError(f"the tolerance table has no {dim}D entries "
                             f"(it has {', '.join(sorted(keyed))}D)")
        table = keyed[str(dim)]
    for name, fields in table.items():
        if name not in base:
            raise ValueError(f"unknown {dim}D tolerance {name!r}; known: {', '.join(base)}")
        if isinstance(fields, ToleranceSpec):
            base[name] = ToleranceSpec(name, *(_exact(constant(from_sympy(getattr(fields, f)),
                                                               f"{dim}D {name}.{f}"))
                                               for f in ("lo", "mid", "hi")),
                                       spec_fraction(fields.q), fields.p, fields.description)
            continue
        new = {}
        for key, v in fields.items():
            f = _FIELD_NAMES.get(str(key).lower())
            if f is None:
                raise ValueError(f"{dim}D {name}: unknown field {key!r} (use lo, mid, hi)")
            x = constant(from_sympy(v), f"{dim}D {name}.{f}")
            if f == "mid" and not x.is_rational:
                raise CoefficientError(f"{dim}D {name}.mid must be rational, got {v!r}")
            new[f] = _exact(x)
        spec = base[name]
        base[name] = ToleranceSpec(name, new.get("lo", spec.lo), new.get("mid", spec.mid),
                                   new.get("hi", spec.hi), spec.q, spec.p, spec.description)
    return base


def from_sympy(v):
    """A sympy number (the proofs' tables) as an exact value: Fraction when rational,
    else read from its printed form by :mod:`predicates.coefficients` (never sympify);
    anything else unchanged."""
    if not type(v).__module__.startswith("sympy"):
        return v
    if v.is_Rational:
        return Fraction(int(v.p), int(v.q))
    return value(parse(str(v)))


def spec_fraction(x) -> Fraction:
    """The exact rational value of a coefficient or exponent (Fraction, int, sympy
    Rational or rational Monomial); CoefficientError if it is irrational."""
    x = from_sympy(x)
    if isinstance(x, Monomial):
        return x.fraction()
    if isinstance(x, (int, Fraction)) and not isinstance(x, bool):
        return Fraction(x)
    raise CoefficientError(f"{x!r} is not an exact rational number")
