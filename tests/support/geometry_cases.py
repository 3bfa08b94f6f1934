"""Adversarial configurations for the predicate tests, placed in tolerance units (the
reference verdicts are :mod:`geometry_exact`'s, on the rounded coordinates).

* **random parameters** — a :class:`Source`: a numpy generator (:class:`RngSource`) or
  hypothesis' ``data`` (:class:`DataSource`);
* **tolerance units** — :class:`Units`: each tolerance in units of L^p and its T−/T+
  bracket, :func:`tol_multiple` (distances in the band, at its edges, 0.1–10 T, or 0);
* **shapes** — segments, triangles, points in a triangle's plane near its edges and
  vertices, long segments across the box; the predicates' configurations built from
  them are :mod:`geometry_constructions`;
* **placement** — :func:`place`: unit-box points to exact coordinates of a format.

Only points are *placed* here, with machine-independent arithmetic (docs/design.md,
"The same answer on every machine"): sums in a fixed order, correctly rounded
transcendental functions.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import mpmath
from mpmath.libmp import to_float
import numpy as np

from geometry_exact import _dot, round_bits
from predicates.portable import norm as _norm  # fixed order, not BLAS
from proofs.tables import TABLES

# -- machine-independent arithmetic for the constructions (docs/design.md, "The same
# answer on every machine"): sums in a fixed order, correctly rounded transcendentals
def _rounded(f, x: float) -> float:
    with mpmath.workprec(128):
        return to_float(f(mpmath.mpf(float(x)))._mpf_, rnd="n")


def cos_rn(x): return _rounded(mpmath.cos, x)  # noqa: E704
def sin_rn(x): return _rounded(mpmath.sin, x)  # noqa: E704
def exp_rn(x): return _rounded(mpmath.exp, x)  # noqa: E704
def log_rn(x): return _rounded(mpmath.log, x)  # noqa: E704




# ---------------------------------------------------------------------------------
# faces of a tetrahedron (degenerate sub-pairs are predicates.catalogue.sub_pairs)

TET_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
TET_FACES = ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))


# ---------------------------------------------------------------------------------
# random parameters: numpy generator or hypothesis data


class Source:
    """Random parameters for the constructions."""

    def uniform(self, a: float, b: float) -> float:
        raise NotImplementedError

    def integer(self, a: int, b: int) -> int:  # inclusive
        raise NotImplementedError

    def choice(self, seq):
        return seq[self.integer(0, len(seq) - 1)]

    def loguniform(self, a: float, b: float) -> float:
        return exp_rn(self.uniform(log_rn(a), log_rn(b)))

    def sign(self) -> int:
        return self.choice((-1, 1))


class RngSource(Source):
    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def uniform(self, a, b):
        return float(self.rng.uniform(a, b))

    def integer(self, a, b):
        return int(self.rng.integers(a, b + 1))


class DataSource(Source):
    """Draws from hypothesis' ``st.data()`` (shrinks towards simple values)."""

    def __init__(self, data):
        from hypothesis import strategies as st
        self.data, self.st = data, st

    def uniform(self, a, b):
        return self.data.draw(self.st.floats(a, b, allow_nan=False, allow_infinity=False))

    def integer(self, a, b):
        return self.data.draw(self.st.integers(a, b))


# ---------------------------------------------------------------------------------
# adversarial constructions (unit box [0, 1]^dim; tolerances in units of L^p)


def unit(v):
    return v / _norm(v)


def rand_dir(src, dim):
    """A random unit vector (no rejection loop: hypothesis' minimal draws are zeros)."""
    v = np.array([src.uniform(-1, 1) for _ in range(dim)])
    if _norm(v) < 0.2:
        v = v + np.array([1.0, 0.3, 0.1][:dim])
    return unit(v)


def perp(src, v):
    """A unit vector perpendicular to v (random in 3D)."""
    v = unit(v)
    if len(v) == 2:
        return src.sign() * np.array([-v[1], v[0]])
    w = rand_dir(src, 3)
    w = w - _dot(w, v) * v
    if _norm(w) < 0.2:
        e = np.zeros(3)
        e[int(np.argmin(np.abs(v)))] = 1.0
        w = e - _dot(e, v) * v
    return unit(w)


def tol_multiple(src, lo: float, hi: float) -> float:
    """A distance in units of a tolerance T: the band [T−/T, T+/T] and its edges
    (lo, hi), anywhere in 0.1–10 tolerances, or 0."""
    mode = src.integer(0, 9)
    if mode <= 2:
        return src.uniform(0.97 * lo, 1.03 * hi)
    if mode == 3:
        return src.choice((lo, hi)) * (1 + src.uniform(-1e-3, 1e-3))
    if mode == 4:
        return 0.0
    return src.loguniform(0.1, 10)


@dataclass(frozen=True)
class Units:
    """Tolerances in units of L^p (floats, for placing points only) and their brackets."""

    dim: int
    t: dict  # name -> T/L^p
    lo: dict  # name -> T−/T
    hi: dict  # name -> T+/T

    @staticmethod
    def of(tol) -> "Units":
        L = float(tol.L)
        t, lo, hi = {}, {}, {}
        for name, spec in TABLES[tol.dim].items():
            t[name] = float(tol.values[name]) / L**spec.p
            lo[name] = float(spec.lo / spec.mid)
            hi[name] = float(spec.hi / spec.mid)
        return Units(tol.dim, t, lo, hi)

    def near(self, src, name):
        """A distance near the bracket of tolerance ``name`` (unit box scale). When the
        tolerances are coarse (3D at 17 bits: τ ≈ 0.24·L) multiples that would leave the
        box are redrawn below 0.45 (in the band when it fits)."""
        t = self.t[name]
        d = tol_multiple(src, self.lo[name], self.hi[name]) * t
        if d > 0.45:
            d = src.uniform(0.1, min(self.hi[name], 0.45 / t)) * t
        return d


def along(src, length, u: Units):
    """A parameter t along a segment of ``length``: interior, near either end (within a
    few σ), or outside."""
    mode = src.integer(0, 4)
    if mode == 0 or length <= 0:
        return src.uniform(0.0, 1.0)
    if mode in (1, 2):
        s = src.uniform(-2.0, 2.0) * u.t["sigma"] / length
        return s if mode == 1 else 1 - s
    if mode == 3:
        return src.uniform(-0.3, 1.3)
    return src.choice((0.0, 0.5, 1.0))


def segment(src, u: Units):
    """Two points: random, long (corner to corner: coordinate differences up to L), medium,
    tiny (length just above σ̂), or axis-aligned."""
    dim = u.dim
    mode = src.integer(0, 5)
    if mode == 0:
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(2)]
    if mode == 1:
        corner = np.array([src.integer(0, 1) for _ in range(dim)], dtype=float)
        A = np.abs(corner - np.array([src.uniform(0, 0.05) for _ in range(dim)]))
        B = np.abs((1 - corner) - np.array([src.uniform(0, 0.05) for _ in range(dim)]))
        return [A, B]
    A = np.array([src.uniform(0.25, 0.75) for _ in range(dim)])
    d = rand_dir(src, dim)
    if mode in (2, 3):
        length = src.uniform(0.02, 0.45)
    elif mode == 4:
        length = u.t["sigma_hat"] * src.choice((src.uniform(0.9, 1.5), src.uniform(1.5, 6.0)))
    else:
        d = np.zeros(dim)
        d[src.integer(0, dim - 1)] = src.sign()
        length = src.uniform(0.01, 0.45)
    return [A, A + length * d]


def triangle(src, u: Units):
    """Three points: random, large, thin (C within 0.1–10 τ of AB, or on it), tiny
    (sides just above σ̂), needle, or axis-aligned right triangle."""
    dim = u.dim
    mode = src.integer(0, 5)
    if mode == 0:
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(3)]
    if mode == 1:
        pts = [np.array([src.uniform(0, 0.1) for _ in range(dim)]),
               np.array([src.uniform(0.9, 1.0)] + [src.uniform(0, 0.1) for _ in range(dim - 1)]),
               np.array([src.uniform(0, 0.5)] + [src.uniform(0.9, 1.0) for _ in range(dim - 1)])]
        return pts
    if mode == 2:
        A, B = segment(src, u)
        t = along(src, _norm(B - A), u)
        C = A + t * (B - A) + u.near(src, "tau") * perp(src, B - A)
        return [A, B, C]
    if mode == 3:
        A = np.array([src.uniform(0.3, 0.7) for _ in range(dim)])
        s = u.t["sigma_hat"]
        return [A, A + s * src.uniform(1.0, 4.0) * rand_dir(src, dim),
                A + s * src.uniform(1.0, 4.0) * rand_dir(src, dim)]
    if mode == 4:
        A, B = segment(src, u)
        C = A + u.near(src, "sigma") * src.uniform(1.0, 3.0) * rand_dir(src, dim)
        return [A, B, C]
    A = np.array([src.uniform(0.1, 0.5) for _ in range(dim)])
    B, C = A.copy(), A.copy()
    B[0] += src.uniform(0.05, 0.5)
    C[1] += src.uniform(0.05, 0.5)
    return [A, B, C]


def normal(tri):
    A, B, C = tri
    return unit(np.cross(B - A, C - A))


def bary(src, k):
    x = np.array([src.loguniform(1e-3, 1.0) for _ in range(k)])
    return x / x.sum()


def in_plane_point(src, tri, u: Units):
    """A point in the plane of a (2D or 3D) triangle: interior, near an edge (0.1–10 τ
    inside or outside, or on it), near a vertex, or random in the plane."""
    A, B, C = tri
    mode = src.integer(0, 5)
    if mode == 0:
        b = bary(src, 3)
        return b[0] * A + b[1] * B + b[2] * C
    if mode == 5:  # well inside (around the centroid)
        b = np.array([1 / 3 + src.uniform(-0.15, 0.15) for _ in range(3)])
        b = b / b.sum()
        return b[0] * A + b[1] * B + b[2] * C
    if mode in (1, 2):
        i = src.integer(0, 2)
        X, Y, Z = tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]
        t = along(src, _norm(Y - X), u)
        foot = X + t * (Y - X)
        e = Y - X
        inward = (Z - X) - _dot(Z - X, e) / _dot(e, e) * e
        if _norm(inward) == 0:
            return foot
        return foot + src.sign() * u.near(src, "tau") * unit(inward)
    if mode == 3:
        V = tri[src.integer(0, 2)]
        d = (B - A) * src.uniform(-1, 1) + (C - A) * src.uniform(-1, 1)
        if _norm(d) == 0:
            return V
        return V + u.near(src, "sigma") * unit(d)
    return A + src.uniform(-0.5, 1.5) * (B - A) + src.uniform(-0.5, 1.5) * (C - A)


def across(src, dim, margin=0.02):
    """A long segment through (near) the centre of the box, spanning it."""
    c = np.array([src.uniform(0.4, 0.6) for _ in range(dim)])
    d = rand_dir(src, dim)
    h = min((min(ci, 1 - ci) - margin) / abs(di) for ci, di in zip(c, d) if abs(di) > 1e-12)
    return c - h * d, c + h * d




def triangle_big(src, dim):
    """A large triangle (vertices near three corners of the box), jittered."""
    if dim == 2:
        c = [(0, 0), (1, 0), (0, 1), (1, 1)]
    else:
        c = [(0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    idx = [src.integer(0, len(c) - 1)]
    idx.append((idx[0] + src.integer(1, len(c) - 1)) % len(c))
    rest = [k for k in range(len(c)) if k not in idx]
    idx.append(rest[src.integer(0, len(rest) - 1)])
    return [np.clip(np.array(c[k], dtype=float) + np.array([src.uniform(-0.15, 0.15)
                                                            for _ in range(dim)]), 0, 1)
            for k in idx]




def place(points, box_lo: Fraction, L: Fraction, bits: int):
    """Unit-box points → exact coordinates of the format: box_lo + L·x, rounded to
    ``bits`` and clamped to [box_lo, box_lo + L] (so every coordinate difference is ≤ L,
    the analysis' assumption). Returns None when a point leaves the unit box by more
    than a rounding (the construction overshot)."""
    out = []
    lo_f, L_f = float(box_lo), float(L)
    hi = box_lo + L
    for p in points:
        if not np.all(np.isfinite(p)) or np.any(p < -1e-12) or np.any(p > 1 + 1e-12):
            return None
        pt = []
        for x in p:
            v = round_bits(Fraction(lo_f + L_f * float(x)), bits)
            pt.append(min(max(v, box_lo), hi))
        out.append(tuple(pt))
    return tuple(out)
