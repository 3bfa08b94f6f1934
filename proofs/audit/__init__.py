"""Shadow-execution audit: measured floating-point error against the derived bounds.

Every predicate of :data:`predicates.ALL` is run — the *same* source, through
:class:`fperr.shadow.ShadowContext` — on random and adversarial inputs in binary64,
binary32 and mpmath at 17 bits (ε = 2^-17, the paper's worst case). Each run follows the
working-precision decisions (the real floating-point path, early returns included) and
carries the exact value of every quantity beside it (fractions; 300-bit rigorous intervals
where a square root is irrational).

Soundness of quantities
    For every named quantity x (the names of the instrumented run), the largest observed
    |F[x] − x| / E[x], with E[x] the bound rules A–K derive, evaluated at the format's ε
    and the configuration's L (coordinates lie in [−L/2, L/2], as rule K assumes). It must
    never exceed 1; how close it gets to 1 is the bound's tightness. Quantities with a
    relative bound (r) are also checked against R[x]·|x|.
Decisions
    For a check "x ≤ T" (the section 3 tolerance model): exact x ≤ T− must imply that the
    working check says ≤, and the working check saying ≤ must imply exact x ≤ T+ (mirrored
    for ">"). Sign tests must agree with the exact sign wherever the paper's premise holds:
    a sign test guarded by a magnitude check on the same quantity counts when the guard
    passed; an unguarded one (edge-vertex's â < 0, ā < 0, protected by a degeneracy-excluded
    geometric bound) counts only when no lower sub-pair registers — the lower predicates
    are run, in the same format, to decide. "stress" is the share of the bracket gap
    (T − T−, T+ − T) the rounding actually consumed; it must stay below 1 for a violation
    to be possible.
Worst cases (:mod:`proofs.audit.worst_case`)
    Per quantity and format, the largest measured |F[x] − x| in units of ε·L^p, with L
    the largest bounding-box edge of the input points (the box inside [−L/2, L/2]^d,
    rule K's premise), against the derived bound in the same units: a search that
    maximises the first-order attainable error Σ|∂x/∂y_k|·½ulp(y_k) over structured
    configurations (scale just above a binade edge, coordinates at the box extremes and
    binade edges, reachability of the quantity respected), then climbs on the measured
    error by ±k ulps per coordinate and sweeps small ulp offsets around the best. The
    records (``worst_cases`` of the summary: dim, algorithm, quantity, format,
    worst_error_units, bound_units, ratio, first_order_units, slack, ...) say where a
    ratio below 1/2 comes from: the rules or the search.
Search
    Besides uniform and adversarial sampling (near-degenerate configurations at 0.1–10
    tolerances, long and short elements, slivers, flat and grid-aligned configurations,
    coordinates at the bounding-box extremes), a hill-climbing search starts from the worst
    samples of every quantity and check and perturbs their coordinates (by ulps, by random
    steps at every scale, by snapping to the box extremes) to maximise the error ratio or
    the stress.

The exact reference
    Exact values are fractions while rational and rigorous 300-bit rational intervals
    after an irrational square root (edge-vertex's m, the ε^(1/2), ε^(1/4) factors of the
    tolerances, the √3 of some T+): see :mod:`fperr.shadow`. A measured error is the far
    end of |F[x] − x| (an upper bound), so a ratio ≤ 1 is a proof for that input; a
    comparison the interval cannot decide is counted as "undecided", never as agreement.

Runs
    CI size (the default, about 11 s of CPU, the worst-case search at a small count
    budget included): ``fperr audit``. The worst-case hunt, at most about 15 minutes
    (6 s of wall clock per quantity and format, ``--budget`` to change):
    ``fperr audit --thorough --format json -o audit.json``; its figures are in
    benchmarks/README.md. A larger sampling run (about 200 s of CPU):
    ``fperr audit --samples 1500 --search-steps 150 --seed 7``. ``--formats``, ``--dims`` and
    ``--only`` restrict the audit; ``proofs.audit.replay(record)`` re-runs a
    violation or worst case from the JSON report.
Users' predicates
    ``fperr audit --predicates MODULE`` audits the ``@predicate`` functions a module
    declares in ``FPERR_TOLERANCES``, with its tolerance table and sign filters
    (:mod:`proofs.audit.user`, :func:`audit_module`).

Exit status 1 when any violation was found.
"""
from __future__ import annotations

from .inputs import Generator
from .markdown import render_markdown
from .search import Audit, Stat, audit, audit_module, select_predicates
from .user import user_specs
from .worst_case import (CI_BUDGET, Budget, WorstCase, WorstCaseSearch, records,
                         thorough_budget, units_of)
from .shadow_run import (Outcome, evaluate, lower_pairs, real_context,
                         registered_sub_pairs, replay, run_shadow, working_points)
from .spec import (DEFAULT_SAMPLES, DEFAULT_SEARCH, FORMATS, SCALES, CheckSpec,
                   Config, PredicateSpec, QuantitySpec, ToleranceInfo, spec_for,
                   tolerance_info)

__all__ = ["Audit", "Budget", "CI_BUDGET", "CheckSpec", "Config", "DEFAULT_SAMPLES",
           "DEFAULT_SEARCH", "FORMATS", "Generator", "Outcome", "PredicateSpec", "QuantitySpec", "SCALES",
           "Stat", "ToleranceInfo", "audit", "evaluate", "lower_pairs", "real_context",
           "records", "registered_sub_pairs", "render_markdown", "replay", "run_shadow",
           "select_predicates", "spec_for", "thorough_budget", "tolerance_info",
           "units_of", "working_points", "WorstCase", "WorstCaseSearch", "audit_module", "user_specs"]
