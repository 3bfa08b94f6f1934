"""Comparison records (section 3's tolerance model).

A floating-point comparison ``F[x] <= F[y]`` is exact: it decides the sign of
F[x] − F[y] without rounding. So the only uncertainty is the error of each side, and we
model the error of a check as E[x] + E[y]. The paper instead bounds E[y − x] by rule D,
which adds one rounding for a subtraction that never happens (for the 2D edge-vertex
check d ≤ τ it prints "> 20εL" where E[d] + E[τ] = 19εL + O(ε^1.5)). Both are sound;
ours is never larger, and the report (`proofs`) shows where they differ.

A comparison with zero (a sign test) needs less: rounding to nearest cannot change the
sign of a nonzero sum or difference, so its error is the *sign bound* of the left side,
E without its last rounding (:func:`fperr.bounds` with ``sign=True``; docs/proofs.md,
"Sign tests").
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy

from .bounds import bounds
from .rules import InvalidBound

if TYPE_CHECKING:  # annotations only: tracked.py builds Checks, so no import back
    from .tracked import Tracked


@dataclass(eq=False)
class Check:
    """A recorded comparison ``lhs rel rhs`` (rel in <=, <, >=, >)."""

    lhs: Tracked
    rhs: Tracked
    rel: str
    line: int | None = None
    label: str = ""
    meta: dict = field(default_factory=dict)

    def __bool__(self):
        raise TypeError("a comparison of Tracked values decides nothing; pass it to a "
                        "predicate context (ctx.reject / ctx.any)")

    @property
    def is_sign_test(self) -> bool:
        """True for a comparison against the constant zero."""
        return self.rhs.rule == "J" and self.rhs.v and self.rhs.c == 0

    @property
    def power(self):
        return self.lhs.p

    def error(self) -> sympy.Expr:
        """E[lhs] + E[rhs] (exact, in ε and L); for a sign test the sign bound of lhs
        (the rounding of its last sum or difference cannot change its sign). Raises
        InvalidBound for an invalid side."""
        bl = bounds(self.lhs, strict=True, sign=self.is_sign_test)
        br = bounds(self.rhs, strict=True)
        if not self.is_sign_test and bl.power != br.power:
            raise InvalidBound(f"check {self} compares L^{bl.power} with L^{br.power}")
        return sympy.expand(bl.E + br.E)

    def __str__(self) -> str:
        where = f" (line {self.line})" if self.line is not None else ""
        return f"{self.lhs.label} {self.rel} {self.rhs.label}{where}"
