"""One shadow run and what it measured (:mod:`proofs.audit`): the predicate executed
with :class:`fperr.shadow.Shadow` numbers, every quantity's error against its bound,
every decision against its exact brackets (section 3's tolerance model)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from itertools import combinations

import numpy as np

import predicates
from fperr.intervals import compare, lower_fraction, upper_fraction
from fperr.intervals import exact_sub as _sub_exact
from fperr.shadow import Shadow, ShadowContext
from predicates.catalogue import pair_predicate

from .spec import FORMATS, Config, PredicateSpec, spec_for
from .user import USER_SIGN_KINDS, toward_zero, user_sign_premise

def run_shadow(spec: PredicateSpec, cfg: Config, pred=None, points=None) -> ShadowContext:
    """Run ``spec``'s predicate (or ``pred``) on ``cfg`` with shadow numbers."""
    fmt = FORMATS[cfg.fmt_name]
    info = cfg.info
    pred = pred or spec.pred
    pts = cfg.points if points is None else points
    ctx = ShadowContext(fmt).fresh(len(pred.weight_names))
    with ctx.session():
        coords = [tuple(Shadow(fmt.from_fraction(c), c, fmt) for c in p) for p in pts]
        pred.fn(ctx, *coords, info.shadow)
    return ctx


def working_points(fmt_name, pts):
    fmt = FORMATS[fmt_name]
    return [tuple(fmt.from_fraction(c) for c in p) for p in pts]


def real_context(fmt_name):
    return FORMATS[fmt_name]


def lower_pairs(dim, split):
    """Every pair (face of the first primitive, face of the second) except the pair itself,
    with the predicate that registers it and the argument order."""
    s1, s2 = split
    out = []
    for i in range(1, len(s1) + 1):
        for j in range(1, len(s2) + 1):
            if (i, j) == (len(s1), len(s2)):
                continue
            for f1 in combinations(s1, i):
                for f2 in combinations(s2, j):
                    pair = pair_predicate(dim, i, j)
                    if pair is None:
                        continue
                    pred, swap = pair
                    out.append((pred, (f2 + f1) if swap else (f1 + f2), f1 + f2))
    return out


def registered_sub_pairs(spec: PredicateSpec, cfg: Config) -> list:
    """The lower sub-pairs whose predicate says TRUE in the working format (the real
    predicate code, in the real context of that format). Empty: no degeneracy."""
    info = cfg.info
    names = "".join(spec.split)
    by_name = dict(zip(names, cfg.points))
    out = []
    for pred, args, faces in lower_pairs(cfg.dim, spec.split):
        pts = working_points(cfg.fmt_name, [by_name[a] for a in args])
        hit, _ = pred(*pts, info.real, ctx=real_context(cfg.fmt_name))
        if bool(np.all(hit)):
            out.append(f"{pred.name}({''.join(args)})")
    return out


@dataclass
class Outcome:
    """What one run measured."""

    ratios: dict = field(default_factory=dict)      # quantity -> E ratio (float)
    rratios: dict = field(default_factory=dict)     # quantity -> R ratio (float)
    stress: dict = field(default_factory=dict)      # check index -> stress (float)
    flip: dict = field(default_factory=dict)        # bracket check -> closeness to a flip
    mid: dict = field(default_factory=dict)         # bracket check -> exact decision at T
    zone: set = field(default_factory=set)          # check indices with exact x in [T-, T+]
    checks: set = field(default_factory=set)        # check indices evaluated
    violations: list = field(default_factory=list)
    undecided: set = field(default_factory=set)
    premise_failed: set = field(default_factory=set)  # sign tests whose premise fails
    result: object = None


#: A sign test without a guard needs its premise (no registered lower sub-pair) checked
#: when its stress reaches this share (or it disagrees, or is undecided).
PREMISE_STRESS = 0.05


def evaluate(spec: PredicateSpec, cfg: Config, pred=None) -> Outcome:
    fmt = FORMATS[cfg.fmt_name]
    info = cfg.info
    ctx = run_shadow(spec, cfg, pred)
    out = Outcome(result=ctx.result)
    L = info.L
    r_floor = (None if fmt.min_normal is None else fmt.min_normal * 2 ** (fmt.bits + 8))
    for name, s in ctx.quantities.items():
        q = spec.quantities.get(name)
        if q is None or q.E is None:
            continue
        err = s.error()
        if err is None:
            continue
        bound = q.E1[cfg.fmt_name] * L ** q.power
        ratio = float(err / bound) if bound else math.inf
        out.ratios[name] = ratio
        if err > bound:
            out.violations.append({"type": "quantity", "quantity": name, "bound": q.text,
                                   "ratio": ratio, "F": float(s.working_fraction),
                                   "exact": _approx(s.x)})
        R1 = q.R1.get(cfg.fmt_name)
        if R1 is not None:
            mag = lower_fraction(s.x)
            if mag and (r_floor is None or mag >= r_floor):
                rb = R1 * mag
                out.rratios[name] = float(err / rb)
                if err > rb:
                    out.violations.append({"type": "relative", "quantity": name,
                                           "bound": q.text, "ratio": float(err / rb),
                                           "F": float(s.working_fraction)})
    cks = spec.checks
    if len(ctx.checks) > len(cks):
        raise AssertionError(f"{spec.key}: the shadow run recorded more checks than the "
                             "instrumented run")
    sub_pairs = None
    for c in ctx.checks:
        cs = cks[c.index]
        if cs.rel != c.rel:
            raise AssertionError(f"{spec.key}: check {c.index} is {c.rel} in the shadow run "
                                 f"but {cs.rel} in the instrumented run")
        out.checks.add(c.index)
        d = bool(c.decision)
        if cs.kind == "bracket":
            _bracket(c, cs, d, out)
            continue
        # sign tests: T- = T+ = 0, the working sign must be the exact sign (premise)
        e = compare(c.lhs.x, Fraction(0))
        exact = None if e is None else e in _SIGN_OK[c.rel]
        stress = (toward_zero(c.lhs) if cs.kind in USER_SIGN_KINDS else
                  _sign_stress(c.lhs))
        if cs.kind == "sign-guarded":
            premise = not bool(ctx.checks[cs.guard].decision)
        elif cs.kind in USER_SIGN_KINDS:
            premise = user_sign_premise(spec, cfg, cs, c)
        elif exact is None or exact != d or stress >= PREMISE_STRESS:
            if sub_pairs is None:
                sub_pairs = registered_sub_pairs(spec, cfg)
            premise = not sub_pairs
        else:
            premise = True  # agrees with a small error: nothing to decide
        if not premise:
            if exact is None or exact != d:
                out.premise_failed.add(c.index)
            continue
        out.stress[c.index] = stress
        if exact is None:
            out.undecided.add(c.index)
        elif exact != d:
            out.violations.append({"type": "sign", "check": c.index, "line": cs.line,
                                   "label": cs.label, "working": d, "exact": exact,
                                   "F": float(c.lhs.working_fraction),
                                   "x": _approx(c.lhs.x),
                                   "registered_sub_pairs": sub_pairs or []})
    return out


_SIGN_OK = {">": (1,), "<": (-1,), ">=": (1, 0), "<=": (-1, 0)}


def _sgn(x):
    c = compare(x, Fraction(0))
    return -1 if c == -1 else 1


def _approx(x):
    if x is None:
        return None
    if type(x) is Fraction:
        return float(x)
    return float(lower_fraction(x)) * _sgn(x)


def _sign_stress(s):
    err = s.error()
    mag = lower_fraction(s.x)
    if err is None or mag is None:
        return 0.0
    if mag == 0:
        return math.inf if err else 0.0
    return float(err / mag)


def _bracket(c, cs, d, out):
    lo, hi = c.exact_decision("lo"), c.exact_decision("hi")
    out.mid[c.index] = c.exact_decision("mid")
    if lo is None or hi is None:
        out.undecided.add(c.index)
        return
    if lo != hi:
        out.zone.add(c.index)
    # stress: share of the gap consumed by rounding, in the direction that could flip
    Fl, Fr = c.lhs.working_fraction, c.rhs.working_fraction
    dx = _sub_exact(c.lhs.x, c.rhs.x)                  # x − T, exact
    delta = _sub_exact(_sub_exact(Fl, Fr), dx)         # what rounding added to it
    g_lo = lower_fraction(_sub_exact(c.rhs.x, c.rhs.lo))
    g_hi = lower_fraction(_sub_exact(c.rhs.hi, c.rhs.x))
    sd = _sgn(delta) if compare(delta, Fraction(0)) else 0
    dpos = upper_fraction(delta) if sd > 0 else Fraction(0)
    dneg = upper_fraction(delta) if sd < 0 else Fraction(0)
    # stress is measured near the threshold only (T − 2·gap_lo ≤ x ≤ T + 2·gap_hi): far
    # from it a large absolute error is harmless (and typically the relative bound is
    # what protects the check near T, e.g. d² vs σ²)
    if compare(dx, -2 * g_lo) != -1 and compare(dx, 2 * g_hi) != 1:
        out.stress[c.index] = max(float(dpos / g_lo) if g_lo else math.inf * bool(dpos),
                                  float(dneg / g_hi) if g_hi else math.inf * bool(dneg))
    # closeness to a flip: rounding pushing x − T toward the other side, relative to the
    # distance it would have to cover (at least the gap: flips inside [T−, T+] are allowed).
    sx = compare(dx, Fraction(0))
    if sd and sx is not None and sd != sx:
        need = max(lower_fraction(dx), g_lo if sd > 0 else g_hi)
        out.flip[c.index] = float(upper_fraction(delta) / need) if need else math.inf
    else:
        out.flip[c.index] = 0.0
    # the forbidden disagreements (section 3, (1))
    if c.rel in ("<=", "<"):
        bad = (lo and not d) or (d and not hi)
    else:
        bad = (hi and not d) or (d and not lo)
    if bad:
        out.violations.append({"type": "decision", "check": c.index, "line": cs.line,
                               "label": cs.label, "working": d, "exact_at_T-": lo,
                               "exact_at_T+": hi, "F_lhs": float(Fl), "F_rhs": float(Fr),
                               "lhs": _approx(c.lhs.x), "T-": _approx(c.rhs.lo),
                               "T+": _approx(c.rhs.hi)})




def replay(violation_or_worst: dict, predicate_key: str | None = None):
    """Re-run a recorded configuration: returns (PredicateSpec, Config, ShadowContext,
    Outcome). Accepts a violation record, or a ``worst`` entry plus ``predicate_key``
    ("3D edge_edge")."""
    key = predicate_key or violation_or_worst["predicate"]
    cfgd = violation_or_worst.get("config", violation_or_worst)
    dim = int(key[0])
    if "module" in cfgd:  # a user's predicate (fperr audit --predicates MODULE)
        from .user import user_spec
        spec = user_spec(cfgd["module"], dim, key.split()[1])
    else:
        spec = spec_for(next(p for p in predicates.ALL[dim] if p.name == key.split()[1]))
    cfg = Config.from_json(dim, cfgd)
    cfg = Config(cfg.dim, cfg.fmt_name, cfg.L_ab, cfg.points, cfg.scenario, cfg.brackets,
                 spec.system)
    spec.bound_coefficients(cfg.fmt_name)
    return spec, cfg, run_shadow(spec, cfg), evaluate(spec, cfg)

