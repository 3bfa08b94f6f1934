"""Random and adversarial inputs of one predicate in one format (:mod:`proofs.audit`):
near-degenerate configurations at 0.1–10 tolerances, long and short elements, slivers,
flat and grid-aligned configurations, coordinates at the bounding-box extremes, and the
local moves of the search."""
from __future__ import annotations

import math
import random
from fractions import Fraction

import numpy as np

from fperr import round_fraction, ulp
from predicates.portable import dirichlet_ones, dot, exp2, exp10, log, norm

from .spec import FORMATS, NEAR_TOL, SCALES, Config, PredicateSpec, tolerance_info

SCENARIOS = (("uniform", 1), ("boxes", 2), ("near", 5), ("flat", 2), ("short", 2),
             ("grid", 1), ("extreme", 1))


class Generator:
    """Random and adversarial configurations for one predicate in one format."""

    scenarios = SCENARIOS

    def __init__(self, spec: PredicateSpec, fmt_name: str, rng: random.Random,
                 brackets: tuple = ()):
        self.spec, self.fmt_name, self.rng = spec, fmt_name, rng
        self.brackets = brackets
        self.fmt = FORMATS[fmt_name]
        self.d = spec.dim
        self.n1, self.n2 = len(spec.split[0]), len(spec.split[1])
        self.np_rng = np.random.default_rng(rng.getrandbits(64))

    # helpers ------------------------------------------------------------------------
    def _unit(self):
        v = self.np_rng.uniform(-1.0, 1.0, size=self.d)
        while norm(v) < 0.25:  # a direction, not a tiny vector
            v = self.np_rng.uniform(-1.0, 1.0, size=self.d)
        return v / norm(v)

    def _k(self):
        return exp10(self.rng.uniform(-1, 1))

    def _tol(self, info, name):
        """A length: the tolerance ``name`` (power 1), or T/L^(p-1) for an area (p = 2),
        volume (p = 3) or L^4 tolerance, i.e. the height that gives that area/volume
        against elements of length ~L. ``"any"`` picks one at random."""
        if name == "any":
            name = self.rng.choice(sorted(info.floats))
        if name not in info.floats:
            name = "tau"
        p = info.powers[name]
        return info.floats[name] / float(info.L) ** (p - 1)

    def finish(self, pts, info, scenario) -> Config:
        """Round to the format (toward zero), clamp to [−L/2, L/2]."""
        h = info.L / 2
        tiny = info.L / 2**100
        out = []
        for p in pts:
            q = []
            for v in p:
                f = Fraction(float(v)) if math.isfinite(v) else Fraction(0)
                f = round_fraction(f, self.fmt.bits, "zero")
                if f > h:
                    f = h
                elif f < -h:
                    f = -h
                if abs(f) < tiny:
                    f = Fraction(0)
                q.append(f)
            out.append(tuple(q))
        return Config(self.d, self.fmt_name, info.L_ab, tuple(out), scenario, self.brackets,
                      self.spec.system)

    # scenarios ----------------------------------------------------------------------
    def sample(self) -> Config:
        L_ab = self.rng.choice(SCALES)
        info = tolerance_info(self.d, self.fmt_name, *L_ab, self.brackets, self.spec.system)
        names, weights = zip(*self.scenarios)
        scen = self.rng.choices(names, weights)[0]
        pts = getattr(self, "_" + scen)(info)
        if self.rng.random() < 0.15:
            pts = self._snap_extremes(pts, info)
            scen += "+extreme"
        return self.finish(pts, info, scen)

    def _uniform(self, info):
        h = float(info.L) / 2
        return [self.np_rng.uniform(-h, h, self.d) for _ in range(self.n1 + self.n2)]

    def _boxes(self, info):
        h = float(info.L) / 2
        La, Lb = info.L_ab
        s1 = La * self.rng.uniform(0.3, 1.0)
        s2 = Lb * self.rng.uniform(0.3, 1.0)
        c1 = self.np_rng.uniform(-h + s1 / 2, h - s1 / 2, self.d) if s1 < 2 * h else np.zeros(self.d)
        c2 = c1 + self.np_rng.uniform(-1, 1, self.d) * (s1 + s2) / 2
        p1 = [c1 + self.np_rng.uniform(-s1 / 2, s1 / 2, self.d) for _ in range(self.n1)]
        p2 = [c2 + self.np_rng.uniform(-s2 / 2, s2 / 2, self.d) for _ in range(self.n2)]
        return p1 + p2

    def _point_on(self, face):
        w = dirichlet_ones(self.np_rng, 1, len(face))[0]
        r = self.rng.random()
        if len(face) > 1 and r < 0.3:  # on a sub-face, or just outside it
            k = self.rng.randrange(len(face))
            w[k] = 0 if r < 0.15 else -self.np_rng.random() * 0.1
            w = w / w.sum()
        return sum(wi * p for wi, p in zip(w, face))

    def _normal_to(self, face):
        v = self._unit()
        if len(face) >= 2:
            basis = []
            for p in face[1:]:
                e = np.array(p - face[0], dtype=float)
                for b in basis:
                    e = e - dot(e, b) * b
                n = norm(e)
                if n > 0:
                    basis.append(e / n)
            for b in basis:
                v = v - dot(v, b) * b
            n = norm(v)
            v = v / n if n > 0 else self._unit()
        return v

    def _near(self, info):
        pts = self._boxes(info) if self.rng.random() < 0.6 else self._uniform(info)
        for _ in range(self.rng.choice((1, 1, 2, 3))):
            opts = [(i, j) for i in range(1, self.n1 + 1) for j in range(1, self.n2 + 1)
                    if i + j <= self.d + 1 and (i, j) in NEAR_TOL]
            if not opts:
                opts = [(1, 1)]
            i, j = self.rng.choice(opts)
            f1 = self.rng.sample(range(self.n1), i)
            f2 = self.rng.sample(range(self.n1, self.n1 + self.n2), j)
            X = self._point_on([pts[k] for k in f1])
            Y = self._point_on([pts[k] for k in f2])
            T = self._tol(info, self.rng.choice([NEAR_TOL[(i, j)], NEAR_TOL[(i, j)], "sigma_hat",
                                                 "any", "any"]))
            off = (self._normal_to([pts[k] for k in f1]) if self.rng.random() < 0.6
                   else self._unit()) * self._k() * T
            if self.rng.random() < 0.05:
                off = off * 0
            shift = X + off - Y
            move = range(self.n1, self.n1 + self.n2)
            if self.rng.random() < 0.5:  # move only the face, or the whole primitive
                move = f2
            for k in move:
                pts[k] = pts[k] + shift
        return pts

    def _flat(self, info):
        pts = self._boxes(info) if self.rng.random() < 0.5 else self._uniform(info)
        n = self._unit()
        o = pts[0]
        names = ["sigma", "tau", "delta", "gamma", "sigma_hat", "any", "any", "any"]
        out = []
        line = self.d == 3 and self.rng.random() < 0.3
        m = self._unit()
        T = self._tol(info, self.rng.choice(names))  # one scale for the whole sample
        for p in pts:
            q = p - dot(p - o, n) * n
            if line:
                q = q - dot(q - o, m) * m
            q = q + n * self.rng.choice((-1, 1)) * self._k() * T * (self.rng.random() < 0.9)
            out.append(q)
        return out

    def _short(self, info):
        pts = self._boxes(info)
        which = range(self.n1) if (self.rng.random() < 0.5 and self.n1 > 1) or self.n2 == 1 \
            else range(self.n1, self.n1 + self.n2)
        which = list(which)
        if len(which) < 2:
            return pts
        c = sum(pts[k] for k in which) / len(which)
        if self.rng.random() < 0.5:  # tiny element, size ~ a tolerance
            T = self._tol(info, self.rng.choice(["sigma_hat", "sigma", "tau", "delta"]))
            size = max(norm(pts[k] - c) for k in which) or 1.0
            s = self._k() * T / size
            for k in which:
                pts[k] = c + (pts[k] - c) * s
        else:  # sliver: squash along one direction
            n = self._unit()
            f = exp10(-self.rng.uniform(0, 9))
            for k in which:
                v = pts[k] - c
                pts[k] = c + v - (1 - f) * dot(v, n) * n
        return pts

    def _grid(self, info):
        h = float(info.L) / 2
        g = 2 ** self.rng.randint(1, 4)
        pts = [np.array([self.rng.randint(-g, g) * h / g for _ in range(self.d)])
               for _ in range(self.n1 + self.n2)]
        if self.rng.random() < 0.5:
            k = self.rng.randrange(len(pts))
            T = self._tol(info, self.rng.choice(["sigma", "tau", "delta", "gamma", "any"]))
            pts[k] = pts[k] + self._unit() * self._k() * T
        return pts

    def _extreme(self, info):
        h = float(info.L) / 2
        pts = [np.array([self.rng.choice((-h, h)) for _ in range(self.d)])
               for _ in range(self.n1 + self.n2)]
        for p in pts:
            for a in range(self.d):
                if self.rng.random() < 0.5:
                    p[a] -= np.sign(p[a]) * float(info.L) * 2.0 ** -self.rng.randint(1, 60)
        return pts

    def _snap_extremes(self, pts, info):
        h = float(info.L) / 2
        pts = [np.array(p, dtype=float) for p in pts]
        for p in pts:
            for a in range(self.d):
                if self.rng.random() < 0.3:
                    p[a] = h if p[a] >= 0 else -h
        return pts

    # local moves for the search -------------------------------------------------------
    def perturb(self, cfg: Config) -> Config:
        info = cfg.info
        h = info.L / 2
        pts = [list(p) for p in cfg.points]
        r = self.rng.random()
        i = self.rng.randrange(len(pts))
        if r < 0.5:  # a few ulps .. many ulps on one coordinate
            a = self.rng.randrange(self.d)
            c = pts[i][a]
            ulp_ = (ulp(c, self.fmt.bits) if c
                    else ulp(info.L, self.fmt.bits) * 2 ** -self.rng.randint(0, 40))
            pts[i][a] = c + self.rng.choice((-1, 1)) * ulp_ * 2 ** int(-4 * log(1.0 - self.rng.random()))
        elif r < 0.85:  # a random step of a random scale on one point
            s = float(info.L) * exp2(-self.rng.uniform(2, 45))
            for a in range(self.d):
                pts[i][a] = pts[i][a] + Fraction(float(self.np_rng.uniform(-2.0, 2.0) * s))
        elif r < 0.93:  # snap one coordinate to the box extremes
            a = self.rng.randrange(self.d)
            pts[i][a] = h if pts[i][a] >= 0 else -h
        else:  # copy a coordinate of another point (exact alignment)
            a = self.rng.randrange(self.d)
            pts[i][a] = pts[self.rng.randrange(len(pts))][a]
        return cfg.with_points(self._fit(pts, h), cfg.scenario.split("+search")[0] + "+search")

    def _fit(self, pts, h):
        out = []
        for p in pts:
            q = []
            for v in p:
                v = round_fraction(v, self.fmt.bits, "zero")
                q.append(min(max(v, -h), h))
            out.append(tuple(q))
        return out

    def between(self, c0: Config, c1: Config, t: Fraction) -> Config:
        """The configuration (1 − t)·c0 + t·c1, rounded to the format (same scale)."""
        pts = [[a + t * (b - a) for a, b in zip(p, q)] for p, q in zip(c0.points, c1.points)]
        return c0.with_points(self._fit(pts, c0.info.L / 2), "zone-bisection")


