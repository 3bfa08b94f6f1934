"""The search driver (:mod:`proofs.audit`): sampling, landing on thresholds, hill
climbing, the tolerance audit, and the summary of what was measured."""
from __future__ import annotations

import dataclasses
import random
import time
import zlib
from dataclasses import dataclass, field
from fractions import Fraction

import sympy

import fperr
import predicates
from fperr.intervals import lower_fraction
from fperr.shadow import Shadow, ShadowContext
from predicates.tolerances import tolerance_values

from .inputs import Generator
from .user import UserGenerator, user_specs
from .shadow_run import Outcome, evaluate
from .worst_case import CI_BUDGET, Budget, WorstCaseSearch, records
from .spec import (DEFAULT_SAMPLES, DEFAULT_SEARCH, FORMATS, SCALES, Config, PredicateSpec,
                   lower_fraction_of, tolerance_bounds, spec_for, tolerance_info)

@dataclass
class Stat:
    """Running statistics of one quantity or check in one format."""

    count: int = 0
    worst: float = 0.0
    worst_cfg: Config | None = None
    evaluated: int = 0
    zone: int = 0
    undecided: int = 0
    premise_failed: int = 0
    violations: int = 0
    seeds: list = field(default_factory=list)   # (value, Config), best first
    flip: float = 0.0
    flip_seeds: list = field(default_factory=list)

    def add_flip(self, value, cfg, keep=3):
        self.flip = max(self.flip, value)
        if value > 0 and (len(self.flip_seeds) < keep or value > self.flip_seeds[-1][0]):
            self.flip_seeds.append((value, cfg))
            self.flip_seeds.sort(key=lambda t: -t[0])
            del self.flip_seeds[keep:]

    def add(self, value, cfg, keep=3):
        self.count += 1
        if value > self.worst or self.worst_cfg is None:
            self.worst, self.worst_cfg = value, cfg
        if value > 0 and (len(self.seeds) < keep or value > self.seeds[-1][0]):
            self.seeds.append((value, cfg))
            self.seeds.sort(key=lambda t: -t[0])
            del self.seeds[keep:]


class Audit:
    """The audit of a set of predicates in a set of formats (see module docstring).

    ``brackets``: bracket overrides ((name, T− coefficient, T+ coefficient), ...) — a
    way for tests to plant a wrong tolerance bracket; ``bound_fn`` replaces
    :func:`fperr.bounds` (tests plant a wrong bound with it).
    """

    def __init__(self, preds=None, formats=("binary64", "binary32", "mp17"),
                 samples=DEFAULT_SAMPLES, search_steps=DEFAULT_SEARCH, seed=0, bound_fn=None,
                 progress=None, brackets: tuple = (), zone_pairs: int = 2, zone_steps: int = 72,
                 audit_tolerances: bool = True, worst_budget: Budget | None = CI_BUDGET):
        preds = preds if preds is not None else [p for d in (2, 3) for p in predicates.ALL[d]]
        self.specs = [p if isinstance(p, PredicateSpec) else
                      (spec_for(p) if bound_fn is None else PredicateSpec(p, bound_fn))
                      for p in preds]
        self.formats = tuple(formats)
        self.samples = samples
        self.search_steps = search_steps
        self.seed = seed
        self.progress = progress
        self.brackets = tuple(brackets)
        self.zone_pairs = zone_pairs
        self.zone_steps = zone_steps
        self.do_tolerances = audit_tolerances
        self.worst_budget = worst_budget
        self.worst_cases: list = []  # records of proofs.audit.worst_case
        self.q: dict = {}       # (key, fmt, quantity) -> Stat
        self.r: dict = {}       # (key, fmt, quantity) -> Stat (relative)
        self.c: dict = {}       # (key, fmt, check index) -> Stat
        self.sides: dict = {}   # (key, fmt, check, L_ab, exact decision at T) -> [Config]
        self.violations: list = []
        self.n_violations = 0
        self.runs = 0
        self.tolerance_rows: list = []
        self.elapsed = 0.0

    # bookkeeping ----------------------------------------------------------------------
    def _record(self, spec, fmt, cfg, out: Outcome):
        self.runs += 1
        for name, v in out.ratios.items():
            self.q.setdefault((spec.key, fmt, name), Stat()).add(v, cfg)
        for name, v in out.rratios.items():
            self.r.setdefault((spec.key, fmt, name), Stat()).add(v, cfg)
        for k in out.checks:
            st = self.c.setdefault((spec.key, fmt, k), Stat())
            if k in out.stress:
                st.add(out.stress[k], cfg)
            if k in out.flip:
                st.add_flip(out.flip[k], cfg)
            st.evaluated += 1
            st.zone += k in out.zone
            st.undecided += k in out.undecided
            st.premise_failed += k in out.premise_failed
        for k, m in out.mid.items():
            if m is None:
                continue
            lst = self.sides.setdefault((spec.key, fmt, k, cfg.L_ab, m), [])
            if len(lst) < 4:
                lst.append(cfg)
        for v in out.violations:
            self.n_violations += 1
            if "check" in v:
                self.c[(spec.key, fmt, v["check"])].violations += 1
            rec = dict(v, predicate=spec.key, format=fmt, config=cfg.to_json())
            if sum(x["predicate"] == spec.key for x in self.violations) < 20:
                self.violations.append(rec)

    def _eval(self, spec, fmt, cfg):
        out = evaluate(spec, cfg)
        self._record(spec, fmt, cfg, out)
        return out

    # phases -----------------------------------------------------------------------------
    def run(self):
        t0 = time.perf_counter()
        if self.do_tolerances:
            self.audit_tolerances()
        for spec in self.specs:
            for fmt in self.formats:
                spec.bound_coefficients(fmt)
                rng = random.Random(zlib.crc32(f"{self.seed}/{spec.key}/{fmt}".encode()))
                gen = (Generator if spec.system is None else UserGenerator)(
                    spec, fmt, rng, self.brackets)
                for _ in range(self.samples):
                    self._eval(spec, fmt, gen.sample())
                if self.zone_pairs:
                    self.zone(spec, fmt, gen)
                if self.search_steps:
                    self.search(spec, fmt, gen)
                if self.worst_budget is not None:
                    self.worst_case(spec, fmt)
                if self.progress:
                    self.progress(spec, fmt)
        self.elapsed = time.perf_counter() - t0
        return self

    def zone(self, spec, fmt, gen: Generator):
        """Land inputs on each bracket check's threshold: bisect between two samples of the
        same scale whose exact decisions at T differ, where the check is most fragile."""
        for cs in spec.checks:
            if cs.kind != "bracket":
                continue
            pairs = []
            for (key, f, k, L_ab, m), lst in self.sides.items():
                if key == spec.key and f == fmt and k == cs.index and m:
                    other = self.sides.get((key, f, k, L_ab, False), [])
                    pairs += [(a, b) for a in lst for b in other]
            gen.rng.shuffle(pairs)
            for c_true, c_false in pairs[: self.zone_pairs]:
                t0, t1 = Fraction(0), Fraction(1)
                prev, after = None, None
                for _ in range(self.zone_steps):
                    t = (t0 + t1) / 2
                    cand = gen.between(c_true, c_false, t)
                    if cand.points == prev:
                        break
                    prev = cand.points
                    out = self._eval(spec, fmt, cand)
                    m = out.mid.get(cs.index)
                    if m is None:
                        break
                    if cs.index in out.zone and after is None:
                        after = 4  # landed between T- and T+: a few more steps toward T
                    if after is not None:
                        after -= 1
                        if after < 0:
                            break
                    if m:
                        t0 = t
                    else:
                        t1 = t

    def search(self, spec, fmt, gen: Generator):
        """Hill climbing from the worst samples of every quantity (error ratio), every
        sign test (stress) and every bracket check (closeness to a forbidden flip)."""
        targets = []
        for (key, f, name), st in list(self.q.items()):
            if key == spec.key and f == fmt:
                targets.append(("q", name, st.seeds))
        seen_labels = set()
        for (key, f, k), st in list(self.c.items()):
            if key != spec.key or f != fmt:
                continue
            lab = (spec.checks[k].line, spec.checks[k].label)
            if lab in seen_labels:  # duplicate sign leaves share a search
                continue
            seen_labels.add(lab)
            if spec.checks[k].kind == "bracket":
                targets.append(("flip", k, st.flip_seeds))
            else:
                targets.append(("stress", k, st.seeds))
        for kind, name, seeds in targets:
            for value, cfg in list(seeds[:2]):
                cur, cur_v = cfg, value
                for _ in range(self.search_steps):
                    cand = gen.perturb(cur)
                    out = self._eval(spec, fmt, cand)
                    v = {"q": out.ratios, "stress": out.stress, "flip": out.flip}[kind].get(name)
                    if v is None:
                        continue
                    if v >= cur_v:
                        cur, cur_v = cand, v

    def worst_case(self, spec, fmt):
        """The worst-case search of every quantity (:mod:`proofs.audit.worst_case`),
        also started from the sampling's worst inputs."""
        seeds = {name: [cfg for _, cfg in st.seeds] for (key, f, name), st in self.q.items()
                 if key == spec.key and f == fmt}
        ws = WorstCaseSearch(spec, fmt, self.worst_budget,
                             seed=zlib.crc32(f"{self.seed}/{spec.key}/{fmt}/worst".encode()),
                             seeds=seeds).run()
        self.worst_cases += records(ws)
        self.runs += sum(wc.runs for wc in ws.found.values())
        self.n_violations += len(ws.violations)
        self.violations += ws.violations[:20]

    def audit_tolerances(self):
        """R[T] of every tolerance: the shared tolerance code run with shadow numbers."""
        systems = {s.dim: s.system for s in self.specs}  # a user table: its declaration
        for dim in sorted(systems):
            system = systems[dim]
            table = None if system is None else system.table()
            rb = tolerance_bounds(dim, system)
            for fmt_name in self.formats:
                fmt = FORMATS[fmt_name]
                e = sympy.Rational(1, 2 ** fmt.bits)
                for L_ab in SCALES:
                    info = tolerance_info(dim, fmt_name, *L_ab, system=system)
                    ctx = ShadowContext(fmt)
                    L = info.L
                    with ctx.session():
                        vals = tolerance_values(
                            dim, lambda p: Shadow(fmt.from_fraction(L ** p), L ** p, fmt), ctx,
                            table)
                    for name, s in vals.items():
                        same = fmt.to_fraction(s.w) == fmt.to_fraction(info.real.values[name])
                        R, text = rb[name]
                        R1 = lower_fraction_of(R.subs(fperr.eps, e))
                        ratio = float(s.error() / (R1 * lower_fraction(s.x)))
                        self.tolerance_rows.append((dim, fmt_name, L_ab, name, ratio, same,
                                                    text))
                        if ratio > 1 or not same:
                            self.n_violations += 1
                            self.violations.append({
                                "type": "tolerance", "predicate": f"{dim}D tolerances",
                                "format": fmt_name, "tolerance": name, "ratio": ratio,
                                "same_as_predicates.tolerances": same, "L_ab": L_ab})

    # report ---------------------------------------------------------------------------
    def summary(self) -> dict:
        rows_q = []
        for spec in self.specs:
            for name, qs in spec.quantities.items():
                row = {"predicate": spec.key, "quantity": name, "bound": qs.text, "formats": {}}
                for fmt in self.formats:
                    st = self.q.get((spec.key, fmt, name))
                    rs = self.r.get((spec.key, fmt, name))
                    row["formats"][fmt] = {
                        "samples": st.count if st else 0,
                        "max_ratio": st.worst if st else None,
                        "max_relative_ratio": rs.worst if rs else None,
                        "worst": st.worst_cfg.to_json() if st and st.worst_cfg else None}
                rows_q.append(row)
        rows_c = []
        for spec in self.specs:
            merged = {}
            for cs in spec.checks:
                merged.setdefault((cs.line, cs.label), []).append(cs)
            for (line, label), group in merged.items():
                row = {"predicate": spec.key, "line": line, "check": label,
                       "kind": group[0].kind, "formats": {}}
                for fmt in self.formats:
                    sts = [self.c[(spec.key, fmt, cs.index)] for cs in group
                           if (spec.key, fmt, cs.index) in self.c]
                    if not sts:
                        row["formats"][fmt] = {"evaluated": 0}
                        continue
                    best = max(sts, key=lambda s: s.worst)
                    row["formats"][fmt] = {
                        "evaluated": max(s.evaluated for s in sts),
                        "in_zone": sum(s.zone for s in sts),
                        "max_stress": best.worst,
                        "max_flip": max(s.flip for s in sts),
                        "violations": sum(s.violations for s in sts),
                        "undecided": sum(s.undecided for s in sts),
                        "premise_failed": sum(s.premise_failed for s in sts),
                        "worst": best.worst_cfg.to_json() if best.worst_cfg else None}
                rows_c.append(row)
        tol = {}
        for dim, fmt, L_ab, name, ratio, same, text in self.tolerance_rows:
            k = (dim, name)
            t = tol.setdefault(k, {"dim": dim, "tolerance": name, "bound": text, "formats": {}})
            f = t["formats"].setdefault(fmt, {"max_ratio": 0.0, "same": True})
            f["max_ratio"] = max(f["max_ratio"], ratio)
            f["same"] = f["same"] and same
        return {"samples_per_predicate_and_format": self.samples,
                "search_steps": self.search_steps, "seed": self.seed,
                "formats": list(self.formats), "runs": self.runs,
                "elapsed_s": round(self.elapsed, 2), "violation_count": self.n_violations,
                "violations": self.violations, "quantities": rows_q, "checks": rows_c,
                "tolerances": list(tol.values()),
                "worst_budget": (None if self.worst_budget is None else
                                 dataclasses.asdict(self.worst_budget)),
                "worst_cases": self.worst_cases}



def select_predicates(dims=(2, 3), names=()) -> list:
    """The predicates of ``dims`` (2 and/or 3) whose names are in ``names`` (all when
    empty). Raises ValueError for an unknown dimension or name, naming the choices."""
    bad = [d for d in dims if d not in predicates.ALL]
    if bad:
        raise ValueError(f"unknown dimension {bad[0]!r} (choose from 2, 3)")
    known = {p.name for d in dims for p in predicates.ALL[d]}
    unknown = sorted(set(names) - known)
    if unknown:
        raise ValueError(f"unknown predicate {unknown[0]!r} in {', '.join(map(str, dims))}D "
                         f"(choose from {', '.join(sorted(known))})")
    return [p for d in dims for p in predicates.ALL[d] if not names or p.name in names]


def audit(*, dims=(2, 3), formats=("binary64", "binary32", "mp17"), names=(),
          samples: int = DEFAULT_SAMPLES, search_steps: int = DEFAULT_SEARCH, seed: int = 0,
          progress=None, worst_budget: Budget | None = CI_BUDGET) -> dict:
    """Run the audit (see :mod:`proofs.audit`) and return its summary (JSON-ready;
    ``violation_count`` 0 when every measured error is within its bound).
    ``worst_budget``: the worst-case search per quantity (:mod:`proofs.audit.worst_case`;
    ``thorough_budget()`` for ``fperr audit --thorough``, None: no search)."""
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise ValueError(f"unknown format {unknown[0]!r} (choose from {', '.join(FORMATS)})")
    preds = select_predicates(dims, names)
    return Audit(preds, formats, samples, search_steps, seed, progress=progress,
                 worst_budget=worst_budget).run().summary()


#: Pairs of samples on either side of each bracket check that the zone bisection lands
#: between T− and T+ (the paper's audit: 2): a user's predicates are few and cheap, and a
#: window too narrow for the rounding error shows only at inputs that land there.
ZONE_PAIRS = 6


def audit_module(decls, *, names=(), formats=("binary64", "binary32", "mp17"),
                 samples: int = DEFAULT_SAMPLES, search_steps: int = DEFAULT_SEARCH,
                 seed: int = 0, progress=None, worst_budget=None, bound_fn=None,
                 specs: list | None = None) -> dict:
    """The audit (:class:`proofs.audit.Audit`) of the predicates of ``decls`` (user
    declarations, :func:`proofs.user_predicates.load`) with their declared tables: its
    summary, with ``module`` (the declarations' names). ``bound_fn`` replaces
    :func:`fperr.bounds` (tests plant a wrong bound with it); ``specs``: the
    :func:`user_specs` of the same selection, when already built."""
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise ValueError(f"unknown format {unknown[0]!r} (choose from {', '.join(FORMATS)})")
    specs = specs if specs is not None else user_specs(decls, names, bound_fn)
    s = Audit(specs, formats, samples, search_steps, seed, progress=progress,
              zone_pairs=ZONE_PAIRS, worst_budget=worst_budget).run().summary()
    s["module"] = ", ".join(dict.fromkeys(d.name for d in decls))
    return s
