"""Users' own predicates in the shadow-execution audit (:mod:`proofs.audit`;
docs/custom-predicates.md, "Auditing your predicates: measured error against the
derived bounds").

A module's ``@predicate`` functions are audited like the paper's, with the tolerance
table its ``FPERR_TOLERANCES`` declares (:mod:`proofs.user_predicates`): the same source
run through :class:`fperr.shadow.ShadowContext` with exact values beside, every named
quantity's measured |F[x] − x| against the bound rules A–K derive with that table
(relative R[x]·|x| where the bound is relative), every bracket check's working decision
against the exact value and the declared T−/T+ (section 3), the tolerances' own R[T].

Sign tests (section 3: T− = T+ = 0) count where their premise holds, which the
declaration says:

- a sign test of a predicate declared "sign exact or undecided" (``sign_filter``,
  :mod:`proofs.sign_tests`): where |F[x]| > θ, θ the working threshold the declaration
  gives for the configuration's L; below θ the lane is undecided by declaration;
- a sign test guarded by a magnitude check of the same quantity: where the guard passed;
- a sign test ``protected`` by a declared lower bound b on |x|: where the exact |x| > b;
- any other sign test (``fperr verify`` refuses it: "unprotected"): everywhere.

Inputs: the paper audit's scenarios (:class:`proofs.audit.inputs.Generator`: uniform
points in [−L/2, L/2]^d — rule K's premise —, near incidences at 0.1–10 tolerances,
flat, short and grid-aligned configurations, box extremes) and two more that need no
knowledge of the predicate: exactly degenerate configurations built from small integers
on a dyadic grid (coincident, collinear, coplanar points) perturbed by a few ulps or by
0.1–10 tolerances, and points on a circle or sphere (cocircular, cospherical) with one
point moved off it. A module without tolerances uses lengths between an ulp of L and
√ε·L in their place.
"""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from fperr import ulp
from fperr.intervals import lower_fraction

from .inputs import Generator
from .spec import FORMATS, Config, PredicateSpec

__all__ = ["USER_SIGN_KINDS", "UserGenerator", "classify_signs",
           "user_sign_premise", "user_spec", "user_specs"]

#: the check kinds of users' sign tests (the paper's are "sign-guarded", "sign-geometric")
USER_SIGN_KINDS = ("sign-filter", "sign-protected", "sign-unprotected")


# --------------------------------------------------------------------------------------
# what protects a sign test (the declaration)
# --------------------------------------------------------------------------------------
def classify_signs(spec: PredicateSpec, ins) -> None:
    """Re-kind ``spec``'s sign tests by the declaration (module docstring): a declared
    sign filter first (every sign test of a filtered predicate has a θ), then a guard,
    then a declared ``protected`` bound, else unprotected."""
    from proofs.constraints.model import label

    decl = spec.system.declared
    flt = decl.filtered.get((spec.dim, spec.name))
    prot = decl.protected.get((spec.dim, spec.name), {})
    for cs in spec.checks:
        if cs.kind == "bracket":
            continue
        x = ins.checks[cs.index].lhs
        lab = label(x)
        if flt is not None and ("*" in flt or x.name in flt):
            cs.kind, cs.protect = "sign-filter", lab
        elif cs.kind == "sign-guarded":
            continue
        elif x.name in prot or lab in prot:
            cs.kind, cs.protect = "sign-protected", prot.get(x.name) or prot[lab]
        else:
            cs.kind = "sign-unprotected"


def user_sign_premise(spec: PredicateSpec, cfg: Config, cs, c) -> bool:
    """Whether the sign test ``c`` (a :class:`fperr.shadow.ShadowCheck` of kind
    ``cs.kind``) must agree with the exact sign on ``cfg`` (module docstring)."""
    if cs.kind == "sign-filter":
        theta = cfg.info.thetas.get(spec.name, {}).get(cs.protect)
        return theta is None or abs(c.lhs.working_fraction) > theta
    if cs.kind == "sign-protected":
        mag = lower_fraction(c.lhs.x)
        return mag is not None and mag > _protected_value(spec, cs, cfg)
    return True  # unprotected: nothing excuses a wrong sign


def toward_zero(s) -> float:
    """The stress of a user's sign test: the rounding error |F[x] − x| when it points
    toward zero (or across it), over |x|; 0 when it points away. ≥ 1: a wrong sign
    (the hill climbing of :meth:`proofs.audit.Audit.search` maximises it)."""
    from fperr.intervals import compare, exact_sub, upper_fraction

    delta = exact_sub(s.working_fraction, s.x)
    sd, sx = compare(delta, Fraction(0)), compare(s.x, Fraction(0))
    if not sd or sx is None or sd == sx:
        return 0.0
    mag = lower_fraction(s.x)
    return float(upper_fraction(delta) / mag) if mag else math.inf


def _protected_value(spec: PredicateSpec, cs, cfg: Config) -> Fraction:
    """The declared lower bound of ``cs`` at the format's ε and the configuration's L,
    rounded up (a Fraction)."""
    import sympy

    from fperr.symbols import L, eps
    from proofs import tables
    from proofs.sign_tests import _upper_fraction

    cache = spec.__dict__.setdefault("_protected", {})
    key = (cs.index, cfg.fmt_name, cfg.info.L)
    if key not in cache:
        expr = cs.protect.expr(tables.Values(spec.system.table()))
        Lq = cfg.info.L
        val = sympy.sympify(expr).subs({eps: sympy.Rational(1, 2 ** FORMATS[cfg.fmt_name].bits),
                                        L: sympy.Rational(Lq.numerator, Lq.denominator)})
        cache[key] = _upper_fraction(val)
    return cache[key]


# --------------------------------------------------------------------------------------
# inputs: the paper's scenarios and degenerate ones that need no knowledge of the code
# --------------------------------------------------------------------------------------
class UserGenerator(Generator):
    """:class:`proofs.audit.inputs.Generator` for a user's predicate: its tolerances'
    lengths (or rounding-scale lengths), plus exactly degenerate and cocircular
    configurations perturbed by ulps or by tolerances (module docstring)."""

    #: the paper's scenarios (its near incidences at fewer draws: their tolerances are
    #: the paper's) and the degenerate ones, which decide most sign tests
    scenarios = (("uniform", 1), ("boxes", 1), ("near", 3), ("flat", 2), ("short", 1),
                 ("grid", 1), ("extreme", 1), ("degenerate", 10), ("cocircular", 3))

    def _tol(self, info, name):
        """A length: a declared tolerance's (as the paper's), else one between an ulp of
        L and √ε·L (a module may declare no tolerance at all)."""
        names = sorted(info.floats)
        if name in info.floats and self.rng.random() < 0.7:
            return super()._tol(info, name)
        if names and self.rng.random() < 0.6:
            return super()._tol(info, self.rng.choice(names))
        bits = self.fmt.bits
        return float(info.L) * 2.0 ** -self.rng.uniform(bits / 2, bits)

    def _n(self):
        return self.n1 + self.n2

    def _degenerate(self, info):
        """Coincident, collinear or coplanar points with small-integer coordinates on a
        dyadic grid (exact), then a few ulps or 0.1–10 tolerances off."""
        rng, d = self.rng, self.d
        k = rng.choice([1, 1, 2] if d == 3 else [0, 1, 1])  # dimension of the flat
        if rng.random() < 0.5:  # rounding alone puts them ulps off: moved less often
            pts = self._on_flat(info, k)
            return self._off(pts, info) if rng.random() < 0.4 else self._floats(pts)
        h = Fraction(info.L) / 2
        step = h / 2 ** rng.randint(2, 6)
        base = [rng.randint(-4, 4) for _ in range(d)]
        dirs = [[rng.randint(-3, 3) for _ in range(d)] for _ in range(k)]
        pts = []
        for _ in range(self._n()):
            c = [Fraction(b) for b in base]
            for v in dirs:
                t = rng.randint(-3, 3)
                c = [a + t * b for a, b in zip(c, v)]
            pts.append([a * step for a in c])
        big = max(abs(a) for p in pts for a in p) or h
        if big > h:  # keep inside the box: scale by a power of two (exact)
            s = Fraction(1, 2 ** (int(big / h)).bit_length())
            pts = [[a * s for a in p] for p in pts]
        return self._off(pts, info)

    def _on_flat(self, info, k):
        """k + 1 random points (full significands) and the others exactly on their
        affine hull (random weights in [−1.5, 2.5]: extrapolation rounds worse), scaled
        into the box by a power of two, in random order: rounding puts them ulps off."""
        h = Fraction(info.L) / 2
        base = [[Fraction(float(v)) for v in self.np_rng.uniform(-1.0, 1.0, self.d) * float(h)]
                for _ in range(k + 1)]
        pts = [list(p) for p in base]
        while len(pts) < self._n():
            t = [Fraction(self.rng.uniform(-1.5, 2.5)) for _ in range(k)]
            pts.append([b0 + sum(tj * (bj[a] - b0) for tj, bj in zip(t, base[1:]))
                        for a, b0 in enumerate(base[0])])
        big = max(abs(a) for p in pts for a in p)
        while big > h:
            pts, big = [[a / 2 for a in p] for p in pts], big / 2
        self.rng.shuffle(pts)
        return pts

    def _off(self, pts, info):
        """Move a few coordinates by ±1..4 ulps, or one point by 0.1–10 tolerances."""
        rng = self.rng
        if rng.random() < 0.5:
            for _ in range(rng.randint(1, 3)):
                p, a = rng.randrange(len(pts)), rng.randrange(self.d)
                c = pts[p][a]
                u = ulp(c, self.fmt.bits) if c else ulp(Fraction(info.L), self.fmt.bits)
                pts[p][a] = c + rng.choice((-1, 1)) * rng.randint(1, 4) * u
        elif rng.random() < 0.8:
            p = rng.randrange(len(pts))
            off = self._unit() * self._k() * self._tol(info, "any")
            pts[p] = [a + Fraction(float(o)) for a, o in zip(pts[p], off)]
        return self._floats(pts)

    @staticmethod
    def _floats(pts):
        return [np.array([float(a) for a in p]) for p in pts]

    def _cocircular(self, info):
        """Points on a circle (2D) or sphere (3D) through rational points of the unit
        circle/sphere (rounded to the format: ulps off it), one moved off radially by
        0.1–10 tolerances half of the time."""
        rng = self.rng
        h = float(info.L) / 2
        r = h * rng.uniform(0.1, 0.45)
        c = self.np_rng.uniform(-h + r, h - r, self.d)
        pts = []
        for _ in range(self._n()):
            t = [Fraction(rng.randint(-12, 12), rng.randint(1, 12)) for _ in range(self.d - 1)]
            s = sum(x * x for x in t)
            u = [2 * x / (1 + s) for x in t] + [(1 - s) / (1 + s)]  # |u| = 1 exactly
            rng.shuffle(u)
            pts.append(c + r * np.array([float(x) for x in u]))
        if rng.random() < 0.5:
            p = rng.randrange(len(pts))
            v = pts[p] - c
            pts[p] = pts[p] + v / max(float(np.abs(v).max()), 1e-300) * \
                rng.choice((-1, 1)) * self._k() * self._tol(info, "any")
        return pts


# --------------------------------------------------------------------------------------
# the specs of a module's predicates
# --------------------------------------------------------------------------------------
def user_specs(decls, names=(), bound_fn=None) -> list[PredicateSpec]:
    """The audit specs of the predicates of ``decls`` (user declarations) whose names
    are in ``names`` (all when empty). ValueError naming an unknown name, or a
    predicate whose instrumented run with the declared table fails."""
    known = [p.name for d in decls for p in d.predicates]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown predicate {unknown[0]!r} (the module's: "
                         f"{', '.join(known)})")
    out = []
    for d in decls:
        for p in d.predicates:
            if names and p.name not in names:
                continue
            try:
                spec = PredicateSpec(p, bound_fn, system=d)
                classify_signs(spec, p.instrumented(d.table()))  # cached run
                out.append(spec)
            except (AttributeError, TypeError, ValueError, ArithmeticError) as e:
                raise ValueError(f"{p.name}: its instrumented run failed: "
                                 f"{type(e).__name__}: {e}") from e
    return out


def user_spec(module: str, dim: int, name: str) -> PredicateSpec:
    """The spec of predicate ``name`` of ``module``'s ``dim``-D declaration (replay)."""
    from proofs.user_predicates import load

    decls = [d for d in load(module) if d.dim == dim]
    return user_specs(decls, (name,))[0]
