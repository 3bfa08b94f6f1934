"""The operator table of :class:`fperr.Tracked` (section 2, rules A–I; S, SD, GL, HL:
exact power-of-two scaling and divisors/radicands bounded below by a passed check,
docs/proofs.md "Quotients and roots").

One row per operation: the rules tried in order (the more restricted first, as section 2
prescribes: C before B, E before D), the exact operation on exact values (Fractions or
sympy numbers), the canonical string ``s`` of the result and the text of a derivation
step. :class:`fperr.Tracked` installs its operators (reflected ones too) from this
table; ``Tracked.derivation``, the constraint generator's exact evaluation and the tests
read it instead of repeating the mapping (the model is the ``uncertainties`` package's
``ops.py``).
"""
from __future__ import annotations

import operator
from dataclasses import dataclass
from typing import Callable

import sympy


@dataclass(frozen=True)
class Op:
    """One operation: ``key`` ("+", "-", "*", "/", "neg", "abs", "sqrt")."""

    key: str
    arity: int
    rules: tuple[str, ...]   # candidate rules, tried in order
    exact: Callable          # the exact operation on exact values
    s_form: str              # canonical string of the result, "({0}+{1})"
    text: str                # a derivation step, "{0} + {1}"
    dunder: str | None       # the Python operator ("add": __add__ and __radd__)


OPS: dict[str, Op] = {op.key: op for op in (
    Op("+", 2, ("C", "B"), operator.add, "({0}+{1})", "{0} + {1}", "add"),
    Op("-", 2, ("E", "D"), operator.sub, "({0}-{1})", "{0} - {1}", "sub"),
    Op("*", 2, ("S", "F"), operator.mul, "({0}*{1})", "{0} * {1}", "mul"),
    Op("/", 2, ("SD", "G", "GL"), operator.truediv, "({0}/{1})", "{0} / {1}", "truediv"),
    Op("neg", 1, ("A",), operator.neg, "(-{0})", "-{0}", "neg"),
    Op("abs", 1, ("I",), abs, "|{0}|", "|{0}|", "abs"),
    Op("sqrt", 1, ("H", "HL"), sympy.sqrt, "sqrt({0})", "sqrt({0})", None),
)}

#: Rule letter -> the operation it belongs to (J, K are leaves: constants, inputs).
BY_RULE: dict[str, Op] = {r: op for op in OPS.values() for r in op.rules}
