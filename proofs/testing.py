"""A helper for users' test suites: their tolerance constraints hold (docs/custom-predicates.md).

In a project's tests (pytest or any runner: a failure is an ``AssertionError``)::

    from proofs.testing import assert_tolerances_hold

    def test_my_tolerances():
        assert_tolerances_hold("mypkg.mypreds")

The module's ``FPERR_TOLERANCES`` (:mod:`proofs.user_predicates`) is verified exactly as
``fperr verify --predicates mypkg.mypreds`` does: every constraint of section 3 generated
from the instrumented predicates, and every declared fact, decided for every ε ≤ 1e-5.
"""
from __future__ import annotations

from .user_predicates import PredicateTolerances, verify
from .verify import Report, format_outcome

__all__ = ["assert_tolerances_hold"]


def assert_tolerances_hold(module: str | PredicateTolerances, tolerances=None,
                           require_paper_argument: bool = False) -> dict[int, Report]:
    """Raise ``AssertionError`` naming every failing constraint of ``module``'s declared
    predicates and tolerances (a module name, or a :class:`PredicateTolerances`);
    ``tolerances``: coefficient overrides, a mapping keyed by dimension or a file as
    ``fperr synthesize --predicates ... -o FILE`` writes. Returns {dim: Report}."""
    reports = verify(module, tolerances, require_paper_argument)
    failures = [o for rep in reports.values() for o in rep.failures]
    if failures:
        name = module if isinstance(module, str) else (module.name or repr(module))
        raise AssertionError(
            f"{len(failures)} tolerance constraint(s) of {name} fail for some ε ≤ 1e-5: "
            + ", ".join(o.id for o in failures) + "\n"
            + "\n".join(format_outcome(o) for o in failures))
    return reports
