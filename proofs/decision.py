"""The result of deciding one inequality for every ε ∈ (0, 1e-5] (:mod:`proofs.decide`)."""
from __future__ import annotations

from dataclasses import dataclass

from fperr.symbols import EPS_MAX


class NotHomogeneous(ValueError):
    """A constraint mixes powers of L: its sign could depend on the scale."""


@dataclass(frozen=True)
class Decision:
    """Outcome of deciding lhs > rhs on ε ∈ (0, 1e-5].

    ``holds``: proven for every ε. ``method``: how. ``fails_on``: ε-ranges (lo, hi)
    where it fails (approximate endpoints, from exact isolating intervals), ``witness``:
    an ε at which lhs − rhs ≤ 0 is proven. ``at64``/``at32``: (lhs − rhs, lhs/rhs)
    at binary64's and binary32's unit roundoff, L = 1 (floats, for display).
    """

    holds: bool
    method: str
    fails_on: tuple = ()
    witness: float | None = None
    at64: tuple = (None, None)
    at32: tuple = (None, None)
    note: str = ""

    @property
    def holds_up_to(self) -> float | None:
        """Largest ε0 with the inequality proven on (0, ε0] (None if it fails near 0)."""
        if self.holds:
            return float(EPS_MAX)
        if not self.fails_on:
            return None
        lo = self.fails_on[0][0]
        return lo if lo > 0 else None
