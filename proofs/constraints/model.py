"""The data model of the constraints (:mod:`proofs.constraints`): an inequality to hold
for every ε ∈ (0, 1e-5], the steps of an argument, a constraint; and how quantities and
expressions are displayed."""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy

from fperr import InvalidBound, Tracked
from fperr import bounds as _fperr_bounds

#: length-type tolerances (compared against distances), per dimension
LENGTHS = {2: ("sigma", "tau", "sigma_hat"),
           3: ("sigma", "tau", "delta", "gamma", "sigma_hat")}


_BOUNDS_MEMO: dict[tuple, tuple] = {}


def bounds(t: Tracked, strict: bool = False, sign: bool = False):
    """:func:`fperr.bounds`, memoised per Tracked object and ``sign`` (its state never
    changes; the memo keeps a reference so ids are not reused)."""
    key = (id(t), sign)
    hit = _BOUNDS_MEMO.get(key)
    if hit is None or hit[0] is not t:
        try:
            hit = _BOUNDS_MEMO[key] = (t, _fperr_bounds(t, sign=sign))
        except InvalidBound:  # the sign bound of an expression with an invalid operand
            hit = _BOUNDS_MEMO[key] = (t, _fperr_bounds(t))
    b = hit[1]
    if strict and not b.valid:
        return _fperr_bounds(t, strict=True)  # raises InvalidBound with the reason
    return b



@dataclass
class Inequality:
    """lhs > rhs (``strict``) or lhs ≥ rhs, to hold for every ε ∈ (0, 1e-5]."""

    lhs: sympy.Expr
    rhs: sympy.Expr
    strict: bool = True
    label: str = ""


@dataclass
class Step:
    """One step of an argument: a statement and the inequalities that prove it."""

    title: str
    inequalities: list
    explanation: str = ""


@dataclass
class Argument:
    """A proof of a constraint as a sequence of steps (all must hold)."""

    name: str
    steps: list
    note: str = ""


@dataclass
class Constraint:
    """One constraint. It holds when all ``inequalities`` hold and, when ``arguments``
    is non-empty, at least one argument has every step holding. ``error`` marks a
    constraint that could not even be formed (invalid bound, unprotected sign test,
    unsupported comparison): it fails."""

    id: str
    dim: int
    algorithm: str
    section: str
    kind: str          # bracket | setup | geometric | window | sign | nonzero | special
    statement: str
    inequalities: list = field(default_factory=list)
    arguments: list = field(default_factory=list)
    detail: str = ""
    lines: tuple = ()
    printed: str = ""  # the relation as the paper prints it (geometric facts only)
    error: str | None = None
    info: dict = field(default_factory=dict)


def label(t: Tracked) -> str:
    """Short display label of a Tracked quantity."""
    if t.name:
        return t.name
    if t.rule == "I" and t.args and t.args[0].name:
        return f"|{t.args[0].name}|"
    if t.rule == "A" and t.args and t.args[0].name:
        return f"-{t.args[0].name}"
    return t.s if len(t.s) <= 40 else t.s[:37] + "..."


def _ids(labels) -> str:
    """Quantity labels as they appear in constraint ids (no '|', no spaces)."""
    return ",".join(x.replace("|", "").replace(" ", "") for x in labels)


def fmt(e) -> str:
    """Compact display of an expression in ε and L."""
    if isinstance(e, str):
        return e
    t = sympy.sstr(e, order="none")
    for a, b in (("**", "^"), ("sqrt(", "√("), ("eps", "ε"), ("*", "·")):
        t = t.replace(a, b)
    return t

