"""Error bounds of a Tracked quantity, exact and in the paper's integer form.

Section 2: a valid quantity with magnitude c·L^p and relative error 1 + aε + bε² has
absolute error E ≤ c·L^p·(aε + bε²); when r holds its error is relative to itself and
R ≤ aε + bε². The paper reports each bound as an integer K ("E ≤ 19εL"): the smallest
integer with K ≥ c·(a + b·ε) for every ε ≤ 1e-5 (the ε² term is absorbed). Since
a, b, c ≥ 0 the worst case is ε = 1e-5, so K = ⌈c·(a + b·10⁻⁵)⌉, computed exactly.

``bounds(x, sign=True)`` is the *sign bound* (docs/proofs.md, "Sign tests"): the error
of the value the last operation rounds, y = F[x1] ± F[x2], i.e. E without the last
rounding. Round-to-nearest is monotone and odd, and a nonzero sum or difference of two
floats never rounds to 0 (it is a multiple of the smallest subnormal, exact when
subnormal), so F[x] has the sign of x whenever |x| > E_sign[x]. Only a last + or − is
dropped (a nonzero product can underflow to 0): for a last ×, ÷, √ the sign bound is E.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy

from .notation import lpow
from .symbols import EPS_MAX, L, eps
from .rules import InvalidBound

if TYPE_CHECKING:  # annotations only: tracked.py builds Checks, so no import back
    from .tracked import Tracked


@dataclass(frozen=True)
class Bounds:
    """``E`` and ``R`` as sympy expressions (``R`` None unless r; ``E`` None for a bare
    quotient, rule G); ``E_int``/``R_int`` the paper's integers (None when not
    applicable: invalid, quotient, or c depends on ε)."""

    valid: bool
    power: sympy.Rational | None
    E: sympy.Expr | None
    R: sympy.Expr | None
    E_int: int | None
    R_int: int | None
    relative: bool
    sign: bool = False   # the sign bound (E without the last rounding)

    def E_at(self, epsilon, scale=1):
        """E evaluated at a numeric ε and L (exact sympy number)."""
        return self.E.subs({eps: sympy.nsimplify(epsilon), L: sympy.nsimplify(scale)})

    def R_at(self, epsilon):
        return None if self.R is None else self.R.subs(eps, sympy.nsimplify(epsilon))

    def text(self) -> str:
        if not self.valid:
            return "invalid"
        parts = []
        if self.R_int is not None:
            parts.append(f"R ≤ {self.R_int}ε")
        if self.E_int is not None:
            parts.append(f"E ≤ {self.E_int}ε{lpow(self.power, superscript=False)}")
        return ", ".join(parts) or f"E ≤ {self.E}"


def paper_integer(coefficient: sympy.Expr, b_term: sympy.Expr = sympy.Integer(0)) -> int | None:
    """Smallest integer K ≥ coefficient + b_term·ε for all 0 < ε ≤ 1e-5 (None if symbolic)."""
    val = sympy.sympify(coefficient + b_term * EPS_MAX)
    if val.free_symbols:
        return None
    return int(sympy.ceiling(val))


def bounds(x: Tracked, strict: bool = False, sign: bool = False) -> Bounds:
    """The bounds of ``x``. For an invalid ``x``: ``valid`` False and no bound, or
    :class:`InvalidBound` when ``strict`` (use that wherever a bound is needed).

    ``sign=True``: the sign bound (module docstring) — F[x] has the sign of x whenever
    |x| > E (the bound every comparison with zero is decided with)."""
    if sign:
        return _sign_bounds(x, strict)
    if not x.v:
        if strict:
            raise InvalidBound(f"no error bound for {x.label}: {x.why}")
        return Bounds(False, None, None, None, None, None, False)
    st = x.state
    rel = st.a * eps + st.b * eps**2
    R = sympy.expand(rel) if st.r else None
    if x.inv:
        # A bare quotient: rule G's c = 1 is a convention (it holds once the quotient is
        # multiplied into a unit vector), not a magnitude bound, so there is no E.
        if strict:
            raise InvalidBound(f"no absolute bound for the quotient {x.label} (rule G's "
                               "c = 1 is not a magnitude bound); use R")
        return Bounds(True, st.p, None, R, None, paper_integer(st.a, st.b), st.r)
    E = _tidy(st.c * L**st.p * rel)
    E_int = paper_integer(st.c * st.a, st.c * st.b)
    R_int = paper_integer(st.a, st.b) if st.r else None
    return Bounds(True, st.p, E, R, E_int, R_int, st.r)


def _tidy(e: sympy.Expr) -> sympy.Expr:
    """Expanded when a polynomial in ε (every bound of rules A–K); one fraction when a
    divisor bounded below (rules GL/HL) put ε in a denominator."""
    e = sympy.expand(e)
    return e if e.is_polynomial(eps) else sympy.cancel(sympy.together(e))


#: Operations whose last rounding the sign bound drops: a sum or difference (rules B–E).
_SIGN_DROPS = {"B", "C", "D", "E"}
#: Exact operations: the sign of −x1 and |x1| is decided exactly when x1's is.
_SIGN_EXACT_OPS = {"A", "I"}


def _sign_error(x: Tracked) -> sympy.Expr:
    """E_sign[x] (docs/proofs.md, "Sign tests"): y = F[x1] ± F[x2] errs from x by at
    most E[x1] + E[x2]; a negation or absolute value is exact, so its operand's sign
    bound carries over; any other operation (and a leaf) keeps its full E."""
    while x.rule in _SIGN_EXACT_OPS and x.args:
        x = x.args[0]
    if x.rule in _SIGN_DROPS and len(x.args) == 2:
        return _tidy(sum(bounds(a, strict=True).E for a in x.args))
    return bounds(x, strict=True).E


def _sign_bounds(x: Tracked, strict: bool) -> Bounds:
    full = bounds(x, strict=strict)
    if not full.valid or full.E is None:
        return Bounds(full.valid, full.power, full.E, full.R, full.E_int, full.R_int,
                      full.relative, sign=True)
    E = _sign_error(x)
    # the paper's integer: E/(ε·L^p) is a polynomial in ε with non-negative
    # coefficients, largest at ε = 1e-5
    unit = sympy.expand(E / (eps * L**full.power))
    E_int = paper_integer(unit.subs(eps, EPS_MAX)) if not unit.has(L) else None
    R = sympy.Integer(0) if E == 0 and full.relative else full.R
    R_int = 0 if R == 0 else full.R_int
    return Bounds(True, full.power, E, R, E_int, R_int, full.relative, sign=True)


def error(x: Tracked) -> sympy.Expr:
    """E[x] as an exact expression; raises :class:`InvalidBound` when x is invalid."""
    return bounds(x, strict=True).E
