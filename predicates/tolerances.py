"""Tolerance computation (Algorithms 1 and 6, sections 4.1 and 5.1).

L is computed as the paper does, in the working precision,
L = (1 + 5ε)/(1 − 7ε^g)·(L_a + L_b) (g = 1/2 in 2D, 1/4 in 3D), and then rounded *up* to
⌊prec/4⌋ significant bits. Rounding up keeps L an upper bound of L̂ (the only property
the proofs use, F[L] > L̂); the short significand makes L², L³, L⁴ exact in the working
precision (13 bits in binary64: L grows by at most 2^-12 ≈ 0.02%; 6 bits in binary32:
at most 3%). Each tolerance T = C·ε^q·L^p is then computed as

    T = root_k(C^k·ε^(qk)) · L^p,     k = denominator of q (1, 2 or 4),

where C^k·ε^(qk) is an exact constant (rule J: C^k fits 17 bits, ε is a power of two),
root_k is k = 2: one sqrt (rule H), k = 4: two, and one product (rule F). The same
function runs instrumented and derives R[T] ≤ 3ε for every tolerance (paper: ≤ 4ε).
Evaluated literally, Algorithm 6 cannot reach 4ε for λ, φ, ν, ζ under rules A–K
(L⁴ alone costs a = 3, the constant product one more): see docs/errata.md.

ε is the unit roundoff of the format (binary64: 2^-53, binary32: 2^-24, a p-bit mpmath
context: 2^-p): the standard model |F[x∘y] − x∘y| ≤ u·|x∘y| holds with u, and using the
machine epsilon 2u would only widen every tolerance by √2 or 2^(1/4) for no benefit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

import fperr
from fperr import round_fraction, to_fraction

from .tolerance_table import L_ROOT, L_SIGMA_PLUS, TABLES, resolve_table, spec_fraction


class UnknownTolerance(AttributeError):
    """A predicate asked for a tolerance its table does not have (``name``; ``known``:
    the table's names)."""

    def __init__(self, name: str, known: tuple, dim: int | None = None):
        super().__init__(
            f"no tolerance {name!r} in this {dim}D table (it has: {', '.join(known) or 'none'}); "
            "a predicate with its own tolerances runs with its table: "
            "pred.instrumented(table=...), predicates.tolerances(..., table=...) "
            "(docs/custom-predicates.md, FPERR_TOLERANCES)")
        self.name, self.known = name, known


def check_dim(dim, table=None) -> None:
    """Raise a clear ValueError for a dimension without a tolerance table: Figures 1
    and 5 are 2D and 3D; another dimension needs its own ``table``."""
    if table is None and dim not in TABLES:
        raise ValueError(f"dim must be 2 or 3 (the paper's Figures 1 and 5), got {dim!r}; "
                         "predicates of another dimension need their own tolerance table "
                         "(name → ToleranceSpec), see docs/custom-predicates.md")


@dataclass
class Tolerances:
    """Every tolerance of Figure 1 (dim 2) or Figure 5 (dim 3) in the working format.

    ``values[name]`` is also reachable as an attribute (``tol.sigma``); ``L`` and
    ``eps`` are the scale and unit roundoff they were computed for; ``ctx`` is the
    number system (a :class:`fperr.Context`).
    """

    dim: int
    L: object
    eps: object
    ctx: object
    values: dict = field(default_factory=dict)
    table: dict | None = None  # name → ToleranceSpec computed with (None: Figure 1/5)

    def __getattr__(self, name):
        try:
            return self.__dict__["values"][name]
        except KeyError:
            if name.startswith("__") or "values" not in self.__dict__:
                raise AttributeError(name) from None
            raise UnknownTolerance(name, tuple(self.__dict__["values"]),
                                   self.__dict__.get("dim")) from None

    def names(self):
        return tuple(self.values)

    def scaled(self, factor) -> "Tolerances":
        """The same tolerances times ``factor`` (0 gives the naive zero-tolerance run)."""
        vals = {k: v * factor for k, v in self.values.items()}
        return Tolerances(self.dim, self.L, self.eps, self.ctx, vals, self.table)

    def spec(self, name: str):
        """The :class:`ToleranceSpec` (T−, T, T+ coefficients) of ``name``."""
        return (self.table or TABLES[self.dim])[name]


def round_up_bits(x: Fraction, bits: int) -> Fraction:
    """The smallest number ≥ x (x > 0) with a ``bits``-bit significand."""
    if x <= 0:
        raise ValueError("L must be positive")
    return round_fraction(x, bits, "up")


def compute_L(dim: int, L_a, L_b, ctx, degree: int = 4) -> object:
    """L of Algorithms 1/6, in the working precision, rounded up to ⌊prec/degree⌋ bits
    (4: the paper's tolerances; a table with tolerances up to L^degree needs L^degree
    exact, so fewer bits).

    The paper's factor 1 + 5ε is meant to absorb the roundings of line 5 so that
    F[L] ≥ L̂ = (L_a + L_b)/(1 − 7ε^g); that holds for binary64, binary32 and 17-bit
    arithmetic with ≥ 3ε to spare, but only by the constants' luck (1 + 5ε itself is not
    representable in binary64). So F[L] ≥ L̂ is then checked exactly and, if it ever
    failed, L is raised until it holds: soundness by construction, not by argument.
    """
    g = L_ROOT[dim].denominator
    with ctx.session():
        eps = ctx.const(ctx.eps)
        root = ctx.sqrt(eps)
        if dim == 3:
            root = ctx.sqrt(root)
        # L_a, L_b enter rounded *up* to the working format (they are upper bounds).
        La, Lb = (ctx.const(ctx.from_fraction(round_up_bits(to_fraction(x), ctx.bits)))
                  if x else ctx.const(0) for x in (L_a, L_b))
        L = (ctx.const(1) + ctx.const(5) * eps) / (ctx.const(1) - ctx.const(L_SIGMA_PLUS) * root) \
            * (La + Lb)
    bits = ctx.bits // max(4, degree)
    S, e = ctx.to_fraction(La) + ctx.to_fraction(Lb), Fraction(1, 2**ctx.bits)
    q = round_up_bits(ctx.to_fraction(L), bits)
    while not bounds_L_hat(q, S, e, g):
        q = round_up_bits(q * (1 + Fraction(1, 2**bits)), bits)
    with ctx.session():
        return ctx.const(ctx.from_fraction(q))


def bounds_L_hat(L: Fraction, S: Fraction, eps: Fraction, g: int) -> bool:
    """Exactly: L ≥ S/(1 − 7·ε^(1/g)), i.e. ((L − S)/(7L))^g ≥ ε with L − S ≥ 0."""
    x = (L - S) / (L_SIGMA_PLUS * L)
    return x >= 0 and x**g >= eps


def tolerance_values(dim: int, L_power, ctx, table: dict | None = None) -> dict:
    """Every tolerance T = root_k(C^k ε^(qk))·L^p of Figure 1/5 (see module docstring).

    ``L_power(p)`` returns L^p in the working format (exact). One source for every
    number system: with a :class:`fperr.TrackedContext` it derives R[T]. ``table``
    (name → ToleranceSpec, default ``TABLES[dim]``) lets the proofs try other
    coefficients (``fperr verify --tolerances``); every ``mid`` must be rational.
    """
    specs = TABLES[dim] if table is None else table
    key = (dim, type(ctx), ctx.format) if table is None and type(ctx) in _PLAIN else None
    roots = _ROOTS.get(key) if key is not None else None
    if roots is None:
        roots = {name: _root(name, spec, ctx) for name, spec in specs.items()}
        if key is not None:
            _ROOTS[key] = roots
    return {name: ctx.name(name, roots[name] * L_power(spec.p))
            for name, spec in specs.items()}


def _root(name: str, spec, ctx):
    """T's coefficient root_k(C^k·ε^(qk)) in ``ctx`` (module docstring): the exact
    constant, then k = 2: one sqrt, k = 4: two."""
    q = spec_fraction(spec.q)  # exact data, sympy (the proofs) or not
    k = q.denominator  # 1, 2 or 4
    power = int(q * k)
    C = spec_fraction(spec.mid) ** k
    x = ctx.eps_multiple(C, power)
    if ctx.bits is not None and ctx.to_fraction(x) != C * Fraction(1, 2**ctx.bits) ** power:
        raise ValueError(f"{name}: T's coefficient {spec.mid} is not admissible in "
                         f"this format: its {k}th power {C} must be a dyadic that fits "
                         f"{ctx.bits} bits (T is computed as root_{k}(C^{k}·ε^{power}))")
    while k > 1:
        x, k = ctx.sqrt(x), k // 2
    return x


#: The coefficients of Figures 1/5 per (dim, plain float context, format): constants
#: of the table and the format alone — CGAL's static filter constants, in effect — so
#: a plan computes them once per process (~0.3 ms of Fractions a call), not per L. Only
#: for the built-in tables and the plain float contexts, whose roots are IEEE sqrt of an
#: exact constant (the same bits every time); a tracked, mpmath or exact context, or a
#: user's table, computes them each call (the instrumented run derives R[T] from them).
_ROOTS: dict = {}
_PLAIN = (fperr.contexts.FloatContext, fperr.contexts.NumpyContext)


def tolerances(dim: int, L_a, L_b, dtype=np.float64, table=None) -> Tolerances:
    """Tolerances for meshes whose primitives' largest bounding-box edges are L_a, L_b.

    ``table``: other coefficients (e.g. an ``fperr synthesize`` table), see
    :func:`predicates.tolerance_table.resolve_table`; valid only if ``fperr verify
    --tolerances`` accepts it.

    ``dtype``: numpy.float64 / numpy.float32 (values are numpy scalars of that type),
    ``float`` (Python floats, binary64), ``"mp17"``, or anything :func:`fperr.context`
    accepts (a context included).
    """
    check_dim(dim)
    for name, v in (("L_a", L_a), ("L_b", L_b)):
        if not (math.isfinite(float(v)) and float(v) >= 0):
            raise ValueError(f"{name} must be finite and non-negative, got {v!r}")
    if float(L_a) + float(L_b) <= 0:
        raise ValueError("L_a + L_b must be positive (both meshes are single points?)")
    ctx = fperr.context(dtype)
    tab = None if table is None else resolve_table(dim, table)
    degree = max([4] + [int(s.p) for s in (tab or {}).values()])
    L = compute_L(dim, L_a, L_b, ctx, degree)
    check_scale(dim, L, ctx)
    with ctx.session():
        powers = {p: L ** p for p in range(1, degree + 1)}
        for p, v in powers.items():
            if ctx.to_fraction(v) != ctx.to_fraction(L) ** p:
                raise ArithmeticError(f"L^{p} is not exact (overflow or underflow: L = {L})")
        values = tolerance_values(dim, powers.__getitem__, ctx, tab)
    return Tolerances(dim, L, ctx.eps, ctx, values, tab)


#: Highest power of L any predicate computes: ‖A−B‖², areas (2D); d̂², γ²·m² (3D).
MAX_DEGREE = {2: 2, 3: 6}


def safe_scale_range(dim: int, ctx) -> tuple[float, float] | None:
    """(lo, hi): the L for which no quantity up to L^deg overflows or loses its error
    model to underflow (section 2 assumes neither), or None when the format has no
    exponent limit (mpmath). The context gives the format's facts (``bits``,
    ``min_normal``, ``max_finite``); the degree is geometry, so the range is computed
    here, not in fperr.

    Overflow: every quantity is below 64·L^deg (the largest magnitude bound, d̂², is
    36·L⁶). Underflow: a subnormal result errs by up to one quantum q absolutely, not
    relatively; requiring u·L^deg ≥ 2^20·q makes that error far below every derived bound
    (≈ ε·L^p) and every constraint margin, for the degree-deg quantities and all lower
    ones. binary64 3D: 2^-166.8 ≤ L ≤ 2^169.6; binary32 3D: 2^-17.5 ≤ L ≤ 2^20.3.
    """
    if ctx.min_normal is None or ctx.max_finite is None:
        return None
    deg = MAX_DEGREE[dim]
    quantum = ctx.min_normal / 2 ** (ctx.bits - 1)  # the smallest subnormal
    log_q = math.log2(float(quantum))
    log_u = math.log2(float(Fraction(1, 2**ctx.bits)))
    lo = (20 + log_q - log_u) / deg
    hi = (math.log2(float(ctx.max_finite)) - 6) / deg
    return 2.0**lo, 2.0**hi


def check_scale(dim: int, L, ctx) -> None:
    """Raise ArithmeticError when L is outside :func:`safe_scale_range`."""
    rng = safe_scale_range(dim, ctx)
    if rng is not None and not rng[0] <= float(L) <= rng[1]:
        raise ArithmeticError(
            f"scale L = {float(L):.3g} is outside the safe range [{rng[0]:.3g}, {rng[1]:.3g}] "
            f"of {dim}D predicates in this format: quantities up to L^{MAX_DEGREE[dim]} would "
            "overflow or underflow. Rescale the coordinates by a power of two "
            "(predicates.intersect does so automatically).")


def tracked_tolerances(dim: int, table: dict | None = None) -> Tolerances:
    """The tolerances as :class:`fperr.Tracked` (instrumented run of the same code).

    ``table``: optional replacement of ``TABLES[dim]`` (see :func:`tolerance_values`).
    """
    check_dim(dim, table)
    ctx = fperr.context("tracked")
    degree = max([4] + [int(s.p) for s in (table or {}).values()])
    powers = {p: fperr.exact_input("L" if p == 1 else f"L^{p}", 1, p, nonnegative=True,
                                   tight=True)
              for p in range(1, degree + 1)}
    values = tolerance_values(dim, powers.__getitem__, ctx, table)
    for name, t in values.items():  # keep the paper's short names in check records
        t.s = name
    return Tolerances(dim, powers[1], fperr.eps, ctx, values)
