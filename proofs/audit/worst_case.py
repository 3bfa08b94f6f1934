"""The worst-case search (:mod:`proofs.audit`): for every named quantity, the largest
error the real floating-point code can be driven to, in units of ε·L^p.

L is the largest bounding-box edge of the predicate's input points (the strictest reading
of the paper's L, "the maximum edge length of the bounding box surrounding each primitive
pair"), with the box inside [−L/2, L/2]^d as rule K assumes (else L = 2·max|coordinate|);
p is the quantity's degree. The derived bound E = c(ε)·L^p is c(ε)/ε in these units.

Per quantity and format, three phases (a budget bounds each, see :class:`Budget`):

1. *Configurations*: maximise the first-order attainable error A = Σ|∂x/∂y_k|·½ulp(y_k)
   over the operations that round (:mod:`proofs.audit.first_order`) over structured inputs
   (:mod:`proofs.audit.worst_inputs`: scale just above a binade edge, coordinates at
   the box extremes and binade edges, the last point on the hull where a proximity
   check must pass) by an evolutionary search on numpy lanes.
2. *Bit-level hill climbing* on the *measured* error from the best configurations and
   from random-low-bit variants of them (same structure, new rounding pattern): a
   (μ + λ) search on lanes whose children move one or two coordinates by ±k ulps
   (k = 1, 2, 4, …, 256, …, 2^20, or random, log-uniform below 2^(bits − 6): a new
   rounding pattern). The
   lanes are ranked by a fast approximate error (:mod:`proofs.audit.fast_error`: the
   working arithmetic against a wider one); every new best is confirmed by the exact
   shadow run (:func:`proofs.audit.shadow_run.run_shadow`), and only shadow runs are
   reported.
3. *Exhaustive sweep* of small ulp offsets around the best measured input: every
   coordinate by ±1..±4 ulps, every pair of coordinates by ±1 ulp each; the best four
   confirmed; again around a better one.

Reachability: the shadow run follows the working path, so a quantity behind a failing
check is simply not measured (no sample). Every measured error is also checked against
its bound (ratio > 1 is a soundness violation, reported, never hidden).

Slack: where worst/bound < 1/2, the record says where the slack is. If the measured
worst reaches at least half of the largest first-order attainable error found, the
search has done what rounding allows at the configurations found and the rest of the
gap is in the *rules* (E/A: the magnitude bounds treat each operand on its own, e.g. a
coordinate difference by L, a product of two by L², and cannot see that all points share
one box). Otherwise the slack is in the *search* (it did not align the rounding errors).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from .fast_error import fast_errors
from .first_order import attainable
from .shadow_run import run_shadow
from .spec import FORMATS, Config, PredicateSpec
from .worst_inputs import Lanes, StructuredInputs, scale_units

__all__ = ["Budget", "CI_BUDGET", "WorstCase", "WorstCaseSearch", "thorough_budget"]


@dataclass(frozen=True)
class Budget:
    """Work per quantity and format: phase-1 and phase-2 generations × lanes, phase-3
    sweeps, and a wall-clock cap (seconds; None: counts only). With a cap, the
    phases end at 25 % / 80 % / 100 % of it, so a loaded machine still finishes."""

    rounds: int
    lanes: int
    climb: int
    sweep: int
    seconds: float | None = None


#: Phase-2 moves in ulps (besides random ones, log-uniform up to 2^(bits − 6) ulps,
#: which redraw the low bits and with them the rounding pattern).
CLIMB_STEPS = (1, 2, 4, 8, 16, 32, 64, 128, 256, 1 << 10, 1 << 13, 1 << 16, 1 << 20)

#: Phase-2 generations without a better lane before the climb starts again from new
#: random low bits on the phase-1 configurations.
RESTART = 40

#: The CI-size search of the default ``fperr audit`` (deterministic: counts only).
CI_BUDGET = Budget(rounds=3, lanes=128, climb=6, sweep=2)


def thorough_budget(seconds: float = 6.0) -> Budget:
    """``fperr audit --thorough``: ``seconds`` of wall clock per quantity and format."""
    if not seconds > 0:
        raise ValueError(f"the per-quantity budget must be positive, got {seconds!r}")
    return Budget(rounds=10**9, lanes=256, climb=10**9, sweep=10**9, seconds=seconds)


@dataclass
class WorstCase:
    """The worst measured error of one quantity in one format (units of ε·L^p)."""

    units: float = -1.0                 # worst measured |F[x] − x| / (ε·L^p)
    ratio: float = 0.0                  # |F[x] − x| / E[x] at that input (≤ 1: sound)
    config: Config | None = None
    L: float = 0.0
    first_order: float = 0.0            # largest A/(ε·L^p) over phase-1 lanes
    first_order_config: list = field(default_factory=list)
    runs: int = 0
    lanes: int = 0
    seconds: float = 0.0


def units_of(spec: PredicateSpec, cfg: Config) -> dict:
    """Run the shadow code on ``cfg``: quantity -> (units, ratio, L) for every quantity
    it reached. Units: |F[x] − x| / (ε·L^p) with L of :func:`scale_units`."""
    fmt = FORMATS[cfg.fmt_name]
    ctx = run_shadow(spec, cfg)
    pts = cfg.points
    edge = max(max(p[a] for p in pts) - min(p[a] for p in pts) for a in range(cfg.dim))
    L = max(edge, 2 * max(abs(c) for p in pts for c in p))
    eps = Fraction(1, 2 ** fmt.bits)
    out = {}
    for name, s in ctx.quantities.items():
        q = spec.quantities.get(name)
        err = s.error() if q is not None and q.E is not None else None
        if err is None or L == 0:
            continue
        Lp = L ** q.power
        out[name] = (float(err / (eps * Lp)), float(err / (q.E1[cfg.fmt_name] * Lp)),
                     float(L))
    return out


class WorstCaseSearch:
    """The search of the module docstring for one predicate in one format.

    ``found[name]`` is the :class:`WorstCase` of each quantity; ``violations`` lists
    measured errors above their bound (soundness bugs). ``seeds``: name -> configurations
    to start phase 2 from as well (e.g. the random audit's worst samples)."""

    def __init__(self, spec: PredicateSpec, fmt_name: str, budget: Budget, seed: int = 0,
                 seeds: dict | None = None):
        spec.bound_coefficients(fmt_name)
        self.spec, self.fmt_name, self.budget = spec, fmt_name, budget
        self.bits = FORMATS[fmt_name].bits
        self.rng = np.random.default_rng(seed)
        self.inputs = StructuredInputs(spec.pred, fmt_name, self.bits, self.rng, spec.system)
        self.seeds = seeds or {}
        self.found = {n: WorstCase() for n, q in spec.quantities.items() if q.E is not None}
        self.violations: list = []

    # measurement ------------------------------------------------------------------------
    def measure(self, cfg: Config) -> dict:
        got = units_of(self.spec, cfg)
        for name, (units, ratio, L) in got.items():
            wc = self.found[name]
            wc.runs += 1
            if units > wc.units:
                wc.units, wc.ratio, wc.config, wc.L = units, ratio, cfg, L
            if ratio > 1:
                self.violations.append({"type": "worst-case", "predicate": self.spec.key,
                                        "format": self.fmt_name, "quantity": name,
                                        "ratio": ratio, "config": cfg.to_json()})
        return got

    def first_order(self, lanes: Lanes) -> dict:
        q = attainable(self.spec.pred, lanes.X, self.bits,
                       self.inputs.tolerances(lanes.L))
        Lu = scale_units(lanes.X)
        scores = {}
        for name, (A, reached, _) in q.items():
            if name not in self.found:
                continue
            p = self.spec.quantities[name].power
            with np.errstate(all="ignore"):
                s = np.where(reached & (Lu > 0), A / (2.0 ** -self.bits * Lu ** p), -1.0)
            s = np.nan_to_num(s, nan=-1.0, posinf=-1.0)
            scores[name] = s
            k = int(np.argmax(s))
            wc = self.found[name]
            wc.lanes += len(s)
            if s[k] > wc.first_order:
                wc.first_order = float(s[k])
                wc.first_order_config = lanes.X[k].tolist()
        return scores

    def config(self, X: np.ndarray) -> Config:
        """A Config of the lane coordinates; the tolerances' L_a = L_b = L/2 with L the
        scale rounded up to 1/64 (so the tolerance L bounds every coordinate difference)."""
        pts = tuple(tuple(Fraction(float(c)) for c in p) for p in X)
        Lq = float(np.ceil(scale_units(X[None])[0] * 64) / 64) or 1.0
        return Config(self.spec.dim, self.fmt_name, (Lq / 2, Lq / 2), pts, "worst-case",
                      system=self.spec.system)

    # the phases ---------------------------------------------------------------------------
    def run(self, names=None) -> "WorstCaseSearch":
        """Search every quantity (or ``names``) in turn, within the budget each."""
        for name in (names or list(self.found)):
            t0 = time.perf_counter()
            deadline = None if self.budget.seconds is None else t0 + self.budget.seconds
            start = self.phase_configurations(name, deadline)
            self.phase_climb(name, start, deadline)
            self.phase_sweep(name, deadline)
            self.found[name].seconds += time.perf_counter() - t0
        return self

    def _time_left(self, deadline, share):
        if deadline is None:
            return True
        total = self.budget.seconds
        return time.perf_counter() < deadline - total * (1 - share)

    def phase_configurations(self, name: str, deadline) -> Lanes | None:
        """Phase 1: evolve lanes toward the largest A of ``name``; returns the best
        (distinct) lanes, best first."""
        b, gen = self.budget, self.inputs
        pop, pop_s = None, None
        for r in range(b.rounds):
            if r and not self._time_left(deadline, 0.25):
                break
            lanes = gen.fresh(b.lanes) if pop is None else Lanes.concat(
                [gen.fresh(b.lanes // 4), gen.mutate(pop, b.lanes - b.lanes // 4)])
            s = self.first_order(lanes).get(name)
            if s is None:
                continue
            pop, pop_s = self._best(pop, pop_s, lanes, s, 16)
        return pop

    @staticmethod
    def _best(pop, pop_s, lanes, s, keep):
        if pop is not None:
            lanes, s = Lanes.concat([pop, lanes]), np.concatenate([pop_s, s])
        _, uniq = np.unique(lanes.X.reshape(len(s), -1), axis=0, return_index=True)
        idx = uniq[np.argsort(-s[uniq], kind="stable")][:keep]
        idx = idx[s[idx] > 0]
        return (lanes.take(idx), s[idx]) if len(idx) else (pop, pop_s)

    def fast(self, name: str, lanes: Lanes) -> np.ndarray:
        """The (approximate) measured error of ``name`` in units, per lane; −1 where
        the quantity is not reached (:mod:`proofs.audit.fast_error`)."""
        got = fast_errors(self.spec.pred, lanes.X, self.bits, self.inputs.tolerances(lanes.L))
        if name not in got:
            return np.full(len(lanes.L), -1.0)
        err, reached = got[name]
        Lu = scale_units(lanes.X)
        with np.errstate(all="ignore"):
            u = err / (2.0 ** -self.bits * Lu ** self.spec.quantities[name].power)
        return np.nan_to_num(np.where(reached & (Lu > 0), u, -1.0), nan=-1.0, posinf=-1.0)

    def confirm(self, name: str, lanes: Lanes, k: int) -> float:
        """Shadow runs (exact) on the first k lanes; the best units of ``name``."""
        best = -1.0
        for X in lanes.X[:k]:
            v = self.measure(self.config(X)).get(name)
            if v is not None:
                best = max(best, v[0])
        return best

    def phase_climb(self, name: str, start: Lanes | None, deadline) -> None:
        """Phase 2: bit-level hill climbing on the measured error, (μ + λ) on lanes: the
        best 8 lanes (from phase 1, their random-low-bit variants and the sampling's
        seeds) make ``budget.lanes`` children by ±k ulp moves per generation
        (:meth:`StructuredInputs.ulp_moves`); the fast error guides, shadow runs confirm
        each new best and the final population. Stuck for RESTART generations, it
        starts again from new random low bits (a new rounding pattern)."""
        b, gen = self.budget, self.inputs
        parts = [] if start is None else [start]
        for cfg in list(self.seeds.get(name, ()))[:3]:
            X = np.array([[float(c) for c in p] for p in cfg.points])[None]
            L = np.array([float(cfg.info.L)])
            parts.append(Lanes(X, L, np.zeros((1, len(cfg.points) - 1)), np.zeros(1, bool)))
        if not parts:
            return
        starts = Lanes.concat(parts)
        pop, pop_s, top, stale = None, None, -1.0, 0
        for _ in range(b.climb):
            if not self._time_left(deadline, 0.8):
                break
            if pop is None or stale >= RESTART:
                if pop is not None:  # stuck: a new rounding pattern on the starts
                    self.confirm(name, pop, len(pop_s))
                lanes = Lanes.concat([starts, self._jittered(starts, 4)])
                pop, pop_s = self._best(None, None, lanes, self.fast(name, lanes), 8)
                if pop is None:
                    return
                top, stale = pop_s[0], 0
                self.confirm(name, pop, 1)
            kids = gen.ulp_moves(pop, b.lanes, CLIMB_STEPS)
            pop, pop_s = self._best(pop, pop_s, kids, self.fast(name, kids), 8)
            stale += 1
            if pop_s[0] > top:
                top, stale = pop_s[0], 0
                self.confirm(name, pop, 1)
        if pop is not None:
            self.confirm(name, pop, len(pop_s))
            self.first_order(pop)  # A where the climb ended: its operations all round

    def _jittered(self, lanes: Lanes, k: int) -> Lanes:
        X = self.inputs.jitter(np.repeat(lanes.X, k, axis=0), np.repeat(lanes.L, k) / 2)
        n = len(X)
        return Lanes(X, np.repeat(lanes.L, k), np.repeat(lanes.W, k, axis=0),
                     np.zeros(n, dtype=bool))

    def phase_sweep(self, name: str, deadline) -> None:
        """Phase 3: every coordinate by ±1..±4 ulps and every pair by ±1 ulp each around
        the best measured input (fast error), the best 4 confirmed by shadow runs;
        again around a better one."""
        for _ in range(self.budget.sweep):
            wc = self.found[name]
            if wc.config is None or not self._time_left(deadline, 1.0):
                return
            X = np.array([[float(c) for c in p] for p in wc.config.points])
            lanes = self.inputs.sweep(X, float(wc.config.info.L))
            s = self.fast(name, lanes)
            order = np.argsort(-s, kind="stable")[:4]
            before = wc.units
            if self.confirm(name, lanes.take(order), 4) <= before:
                return


#: worst/bound below this: the record explains where the slack is
SLACK_RATIO = 0.5


def slack(worst: float, bound: float, first_order: float) -> str | None:
    """Where the slack of a loose ratio is (module docstring); None when worst/bound is
    at least SLACK_RATIO."""
    if worst < 0:
        return "not reached: no input passed the checks before this quantity"
    if worst >= SLACK_RATIO * bound:
        return None
    a, w = first_order / bound, worst / first_order if first_order > 0 else 0.0
    if worst >= SLACK_RATIO * first_order:
        return (f"rules: the largest first-order attainable error found is {a:.2f} of "
                f"the bound and the search measured {w:.2f} of it; the magnitude bounds "
                "take each operand on its own (a coordinate difference up to L, products "
                "of such) and cannot see that all points share one box")
    return (f"search: the measured worst is only {w:.2f} of the largest first-order "
            f"attainable error found ({a:.2f} of the bound): the rounding errors were not "
            "aligned")


def records(search: WorstCaseSearch) -> list:
    """JSON records of a search: dim, algorithm, quantity (the names of ``fperr tables``),
    format, worst_error_units, bound_units (c(ε)/ε of E = c(ε)·L^p), ratio,
    first_order_units, slack, L, power, shadow_runs, first_order_lanes, seconds, config."""
    spec, fmt = search.spec, search.fmt_name
    out = []
    for name, wc in search.found.items():
        q = spec.quantities[name]
        bound = float(q.E1[fmt] * 2 ** FORMATS[fmt].bits)
        reached = wc.config is not None
        out.append({
            "dim": spec.dim, "algorithm": spec.name, "quantity": name, "format": fmt,
            "power": q.power, "bound": q.text,
            "worst_error_units": wc.units if reached else None,
            "bound_units": bound, "ratio": wc.ratio if reached else None,
            "first_order_units": wc.first_order,
            "slack": slack(wc.units, bound, wc.first_order),
            "L": wc.L, "shadow_runs": wc.runs, "first_order_lanes": wc.lanes,
            "seconds": round(wc.seconds, 3),
            "config": wc.config.to_json() if reached else None})
    return out
