"""The constraints the paper's correctness rests on, per algorithm, in two kinds.

**Declared by hand** (geometric facts of the proofs, exact sympy relations between
T−, T, T+ of the tolerance table, each citing its section): :data:`GEOMETRIC`,
the lower bounds that protect sign tests (:data:`PROTECTED`) and divisions
(:data:`NONZERO`), and the geometric lower bounds on m used by the special argument
(:data:`M_LOWER`). Where the paper prints an *equality* that fixes a T+ (κ+ = 2τ−²,
λ+ = 16(τ−² − γ+²)², ...) soundness only needs T+ ≤ the proven lower bound of the
quantity (a rejection "|x| ≤ T" then only discards pairs with |x| ≤ T+, which cannot
intersect); that inequality is what is checked, and the report says whether the table
meets it with equality.

**Generated from an instrumented run** (:class:`predicates.core.Instrumented`) — no
error figure is typed in; every error comes from :func:`fperr.bounds`:

* each comparison of a quantity x against an expression g(T) of one tolerance T
  (a *window*): with E = E[x] + E[g(T)] (``Check.error()``),
      g(T+) − g(T) > E   and   g(T) − g(T−) > E,
  in the units of the check (the check d² ≤ σ² gives a window in σ² units:
  σ+² − σ², σ² − σ−²). When x carries a relative error (r: the paper's
  "R[d²] ≤ 5ε") the error near the threshold is R[x]·g(T±) instead of the
  worst case over all x: g(T+) − g(T) > R[x]·g(T+) + E[g(T)], and likewise below.
  Either is sound; the tighter one is used and the report shows both;
* each sign test (comparison with 0) of a quantity x: the lower bound B that the
  paper's argument gives for |x| when the test is reached must exceed E[x]. B is
  T− when the run rejects |x| ≤ T on the same or an earlier line (section 3, second
  case), else a declared geometric bound (:data:`PROTECTED`, e.g. â > √(σ−² − τ+²)
  in edge-vertex); a sign test with neither is reported as unprotected;
* the check x̂² ≤ T²·q where q has no relative error bound (section 5.4.4: d̂² ≤ γ²m²
  in 3D edge-edge, d̂² ≤ δ²m² in 3D triangle-vertex, line 14): the special argument,
  encoded step by step (:func:`special_argument`).

Homogeneity: every relation is homogeneous in L (checked), which lets the decision
procedure set L = 1 (:mod:`proofs.decide`).
"""
from __future__ import annotations

from .facts import (GEOMETRIC, M_LOWER, NONZERO, PAPER, PROTECTED, Bound, Declared, Fact,
                    geometric_constraints, table_constraints)
from .generated import exact_value, run_constraints, tolerance_nodes
from .model import (LENGTHS, Argument, Constraint, Inequality, Step, bounds,
                    fmt, label)
from .special import special_argument

__all__ = ["Argument", "Bound", "Constraint", "Declared", "Fact", "GEOMETRIC", "Inequality",
           "LENGTHS", "M_LOWER", "NONZERO", "PAPER", "PROTECTED", "Step", "bounds",
           "exact_value", "fmt", "geometric_constraints", "label", "run_constraints",
           "special_argument", "table_constraints", "tolerance_nodes"]
