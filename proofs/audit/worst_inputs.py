"""Structured inputs for the worst-case search (:mod:`proofs.audit.worst_case`), many at
once as numpy lanes (lanes × points × dim, float64 holding values of the working format).

Where rounding hurts most relative to L (section 2's standard model: |e| ≤ ½ulp(y) ≤ ε|y|,
with equality just above a power of two): the scale L just above a binade edge (so the
coordinate differences near L, and their products near L^p, sit just above one too),
coordinates at the box extremes ±L/2 (exactly, or just inside with random low bits) and
just above / below binade edges (so a difference of two coordinates with different
exponents must round), uniform values, small values, zero. Reachability: when the predicate's first primitive
spans a lower-dimensional hull (an edge for edge-vertex, a triangle's plane), a share of
the lanes puts the last point on it (a convex combination of the others), so the
proximity checks before the later quantities pass (P within τ of AB, PQ meeting AB, P
within δ of ABC).
"""
from __future__ import annotations

import numpy as np

from .spec import tolerance_info

__all__ = ["Lanes", "StructuredInputs", "round_bits", "scale_units"]


def round_bits(x: np.ndarray, bits: int) -> np.ndarray:
    """Round float64 values to ``bits`` significant bits (nearest, ties to even)."""
    if bits >= 53:
        return np.asarray(x, dtype=np.float64)
    m, e = np.frexp(x)
    return np.ldexp(np.round(np.ldexp(m, bits)), e - bits)


def scale_units(X: np.ndarray) -> np.ndarray:
    """Per lane: L = max(largest bounding-box edge, 2·max|coordinate|) — the largest
    bounding-box edge of the points when their box lies in [−L/2, L/2]^d, as rule K
    assumes (the strictest L the derived bounds hold for)."""
    edge = (X.max(axis=1) - X.min(axis=1)).max(axis=1)
    return np.maximum(edge, 2 * np.abs(X).max(axis=(1, 2)))


class Lanes:
    """A batch: coordinates X, scale L (per lane), hull weights W (None: free lane)."""

    def __init__(self, X, L, W, hull):
        self.X, self.L, self.W, self.hull = X, L, W, hull

    def take(self, idx) -> "Lanes":
        return Lanes(self.X[idx], self.L[idx], self.W[idx], self.hull[idx])

    @staticmethod
    def concat(parts) -> "Lanes":
        return Lanes(*(np.concatenate([getattr(p, a) for p in parts])
                       for a in ("X", "L", "W", "hull")))


class StructuredInputs:
    """Random structured lanes and mutations for one predicate in one format."""

    def __init__(self, pred, fmt_name: str, bits: int, rng: np.random.Generator,
                 system=None):
        self.pred, self.bits, self.rng = pred, bits, rng
        self.n, self.d = len(pred.points), pred.dim
        self.u = 2.0 ** -bits
        # last point on the hull of the others: only when that hull is lower-dimensional
        self.can_hull = 3 <= self.n <= self.d + 1
        info = tolerance_info(self.d, fmt_name, 0.5, 0.5, system=system)   # L_a + L_b = 1
        self.tol_ref = {k: (v, info.powers[k]) for k, v in info.floats.items()}

    def tolerances(self, L: np.ndarray) -> dict:
        """Per-lane tolerances for scale L (T ∝ L^p; reachability only)."""
        return {k: v * L ** p for k, (v, p) in self.tol_ref.items()}

    # generation -------------------------------------------------------------------------
    def scales(self, k: int) -> np.ndarray:
        r = self.rng.random(k)
        just_above = 1 + 2 * self.u * self.rng.integers(1, 4, k)
        near = 1 + 2.0 ** -self.rng.integers(4, 30, k).astype(float) * (1 + self.rng.random(k))
        anywhere = 1 + self.rng.random(k)
        L = np.where(r < 0.3, just_above, np.where(r < 0.75, near, anywhere))
        return round_bits(L, self.bits)

    def coordinates(self, h: np.ndarray, shape) -> np.ndarray:
        """Coordinates of the kinds in the module docstring; h broadcasts against shape.
        "Just inside" an extreme or "just above/below" a binade edge keeps random low
        bits: a short significand would make the products of differences exact."""
        rng = self.rng
        h = np.broadcast_to(h, shape)
        kind = rng.choice(6, size=shape, p=(0.2, 0.2, 0.25, 0.23, 0.06, 0.06))
        sign = rng.choice((-1.0, 1.0), size=shape)
        low = rng.random(shape) * 2.0 ** -rng.integers(8, 44, shape).astype(float)
        edge = 2.0 ** -rng.integers(1, 4, shape).astype(float)
        edge = edge * (1 + rng.choice((-1.0, 1.0), size=shape) * low)
        small = 2.0 ** -rng.integers(2, 40, shape).astype(float)
        out = np.select([kind == 0, kind == 1, kind == 2, kind == 3, kind == 4],
                        [h, h * (1 - low), np.minimum(edge, h), rng.uniform(-1, 1, shape) * h,
                         small], 0.0)
        return round_bits(np.clip(sign * out, -h, h), self.bits)

    def fresh(self, k: int) -> Lanes:
        L = self.scales(k)
        h = L[:, None, None] / 2
        X = self.coordinates(h, (k, self.n, self.d))
        W = self.rng.dirichlet(np.ones(self.n - 1), k)
        hull = (self.rng.random(k) < 0.6) & self.can_hull
        return self.fix(Lanes(X, L, W, hull))

    def fix(self, lanes: Lanes) -> Lanes:
        """Put the last point of hull lanes on the hull of the others (rounded)."""
        if lanes.hull.any():
            P = np.einsum("kj,kjd->kd", lanes.W, lanes.X[:, :-1, :])
            X = lanes.X.copy()
            X[lanes.hull, -1, :] = round_bits(P[lanes.hull], self.bits)
            lanes = Lanes(X, lanes.L, lanes.W, lanes.hull)
        return lanes

    def mutate(self, parents: Lanes, k: int) -> Lanes:
        """k children: one or two coordinates redrawn, the scale changed (coordinates at
        the old extremes follow), or the hull weights redrawn."""
        idx = self.rng.integers(0, len(parents.L), k)
        ch = parents.take(idx)
        X, L, W = ch.X.copy(), ch.L.copy(), ch.W.copy()
        r = self.rng.random(k)
        rows = np.arange(k)
        for j in range(2):
            i = self.rng.integers(0, self.n, k)
            a = self.rng.integers(0, self.d, k)
            new = self.coordinates(L / 2, (k,))
            pick = (r < 0.7) & ((j == 0) | (self.rng.random(k) < 0.5))
            X[rows[pick], i[pick], a[pick]] = new[pick]
        rescale = (r >= 0.7) & (r < 0.85)
        if rescale.any():
            L2 = self.scales(k)
            at_edge = np.abs(X) == (L / 2)[:, None, None]
            Xs = np.where(at_edge, np.sign(X) * L2[:, None, None] / 2,
                          np.clip(X, -L2[:, None, None] / 2, L2[:, None, None] / 2))
            X = np.where(rescale[:, None, None], round_bits(Xs, self.bits), X)
            L = np.where(rescale, L2, L)
        rew = r >= 0.85
        W[rew] = self.rng.dirichlet(np.ones(self.n - 1), int(rew.sum()))
        hull = ch.hull ^ ((self.rng.random(k) < 0.05) & self.can_hull)
        return self.fix(Lanes(X, L, W, hull))

    def ulp_moves(self, parents: Lanes, k: int, steps: tuple) -> Lanes:
        """k children, each with one or two coordinates moved by ±s ulps of the format
        (s from ``steps`` or random, log-uniform below 2^(bits − 6): new low bits and
        with them a new rounding pattern), or (one in
        five) with random low bits everywhere (:meth:`jitter`); clipped to ±L/2."""
        ch = parents.take(self.rng.integers(0, len(parents.L), k))
        X = ch.X.copy()
        rows, h = np.arange(k), ch.L / 2
        for j in range(2):
            i = self.rng.integers(0, self.n, k)
            a = self.rng.integers(0, self.d, k)
            c = X[rows, i, a]
            _, e = np.frexp(np.where(c == 0, h * 2.0**-8, c))
            # random steps: log-uniform up to 2^(bits − 6) ulps, i.e. 1/64 of the
            # coordinate in every format (binary64 too: its low bits alone cannot align
            # the roundings of a structure with short significands)
            big = np.floor(np.exp2(self.rng.random(k) * (self.bits - 6)))
            s = np.where(self.rng.random(k) < 0.6, self.rng.choice(steps, k), big)
            s *= self.rng.choice((-1.0, 1.0), k) * ((j == 0) | (self.rng.random(k) < 0.4))
            X[rows, i, a] = np.clip(round_bits(c + s * np.ldexp(1.0, e - self.bits), self.bits),
                                    -h, h)
        jit = self.rng.random(k) < 0.2
        if jit.any():
            X[jit] = self.jitter(X[jit], h[jit])
        return self.fix_free(Lanes(X, ch.L, ch.W, ch.hull))

    def fix_free(self, lanes: Lanes) -> Lanes:
        """Moves end the hull placement: the climb works on the measured error, and a
        point ulps off the hull still passes the proximity checks."""
        return Lanes(lanes.X, lanes.L, lanes.W, np.zeros_like(lanes.hull))

    def jitter(self, X: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The lanes X with most coordinates moved by a random relative 2^-j, j between
        0.4 and 0.85 of the format's bits — the structure (and the first-order error A)
        stays, the low bits and with them the rounding pattern are new (a short
        significand would make many operations exact); clipped to ±h (per lane)."""
        shape = X.shape
        lo, hi = int(0.4 * self.bits), int(0.85 * self.bits)
        rel = self.rng.random(shape) * 2.0 ** -self.rng.integers(lo, hi, shape).astype(float)
        rel *= self.rng.choice((-1.0, 1.0), size=shape) * (self.rng.random(shape) < 0.7)
        hb = h[:, None, None]
        return round_bits(np.clip(X * (1 + rel), -hb, hb), self.bits)

    def sweep(self, X: np.ndarray, L: float) -> Lanes:
        """Every coordinate of X by ±1..±4 ulps, every pair by ±1 ulp each (phase 3)."""
        flat = X.reshape(-1)
        m = len(flat)
        _, e = np.frexp(np.where(flat == 0, L * 2.0**-9, flat))
        step = np.ldexp(1.0, e - self.bits)
        moves = [{i: s * k} for i in range(m) for k in (1, 2, 3, 4) for s in (1, -1)]
        moves += [{i: s, j: t} for i in range(m) for j in range(i + 1, m)
                  for s in (1, -1) for t in (1, -1)]
        out = np.repeat(flat[None], len(moves), axis=0)
        for r, mv in enumerate(moves):
            for i, k in mv.items():
                out[r, i] = flat[i] + k * step[i]
        out = np.clip(round_bits(out, self.bits), -L / 2, L / 2).reshape((-1,) + X.shape)
        n = len(moves)
        return Lanes(out, np.full(n, L), np.zeros((n, self.n - 1)), np.zeros(n, dtype=bool))
