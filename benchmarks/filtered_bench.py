"""Filtered sign predicates (predicates.classic) against naive numpy and the all-exact
path, timed in the same run, and the share of lanes each filter decides natively beside
Shewchuk's static error bounds (``ccwerrboundA``-style: (c + d·ε)·ε × the permanent of
the same expansion, computed here in float64 with his published constants) on random and
near-degenerate inputs. Figures, not assertions (benchmarks/README.md).

Run: PYTHONPATH=. python3 benchmarks/filtered_bench.py [--lanes N]"""
from __future__ import annotations

import argparse
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "test_predicates"))

from predicates import classic  # noqa: E402
from predicates.vector import cross2, sub, triple  # noqa: E402

EPS = 2.0 ** -53
#: Shewchuk's static error-bound constants (predicates.c: ccwerrboundA, o3derrboundA,
#: iccerrboundA, isperrboundA), the multipliers of each expansion's permanent
SHEWCHUK = {"orient2d": (3 + 16 * EPS) * EPS, "orient3d": (7 + 56 * EPS) * EPS,
            "incircle": (10 + 96 * EPS) * EPS, "insphere": (16 + 224 * EPS) * EPS}


def _abs_sub(p, q):
    return tuple(abs(a - b) for a, b in zip(p, q))


def permanent(name, pts):
    """The permanent of the expansion (every product with absolute values)."""
    if name == "orient2d":
        u, v = _abs_sub(pts[1], pts[0]), _abs_sub(pts[2], pts[0])
        return u[0] * v[1] + u[1] * v[0]
    if name == "orient3d":
        a, b, c = (_abs_sub(p, pts[0]) for p in pts[1:])
        return (a[0] * (b[1] * c[2] + b[2] * c[1]) + a[1] * (b[0] * c[2] + b[2] * c[0])
                + a[2] * (b[0] * c[1] + b[1] * c[0]))
    last = pts[-1]
    d = [_abs_sub(p, last) for p in pts[:-1]]
    lift = [sum(x * x for x in r) for r in d]
    if name == "incircle":
        a, b, c = d
        return (lift[0] * (b[0] * c[1] + b[1] * c[0]) + lift[1] * (c[0] * a[1] + c[1] * a[0])
                + lift[2] * (a[0] * b[1] + a[1] * b[0]))
    total = 0.0
    for i in range(4):  # |lift_i| · permanent of the other three rows' triple product
        a, b, c = [d[j] for j in range(4) if j != i]
        total = total + lift[i] * (a[0] * (b[1] * c[2] + b[2] * c[1])
                                   + a[1] * (b[0] * c[2] + b[2] * c[0])
                                   + a[2] * (b[0] * c[1] + b[1] * c[0]))
    return total


def naive(pred, pts):
    return np.sign(pred.fn(*[tuple(p[:, j] for j in range(pred.dim)) for p in pts]))


def timed(f, reps=3):
    best = np.inf
    for _ in range(reps):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lanes", type=int, default=200_000)
    args = ap.parse_args(argv)
    from test_filtered import _on_the_locus

    rng = np.random.default_rng(0)
    print(f"{'predicate':<9} {'input':<11} {'naive ns':>9} {'filtered ns':>11} "
          f"{'exact ns':>9} {'undecided fperr':>15} {'undecided Shewchuk':>18}")
    for pred in (classic.orient2d, classic.orient3d, classic.incircle, classic.insphere):
        for kind in ("random", "near 1e-12", "ulps"):
            n = args.lanes if kind == "random" else max(2000, args.lanes // 100)
            if kind == "random":
                pts = [rng.uniform(-1, 1, (n, pred.dim)) for _ in pred.points]
            else:  # on the line/plane/circle/sphere up to a few ulps, or moved by ~1e-12
                pts = _on_the_locus(pred.name, rng, n, np.float64)
                if kind != "ulps":
                    pts[-1] = pts[-1] + rng.uniform(-1e-12, 1e-12, pts[-1].shape)
            t_naive = timed(lambda: naive(pred, pts))
            t_filt = timed(lambda: pred.decide(*pts))
            _, share = pred.decide(*pts)
            m = min(n, 2000)  # the all-exact path on a sample
            sub_pts = [p[:m] for p in pts]
            t_exact = timed(lambda: [pred.fn(*[tuple(Fraction(float(x)) for x in p[i])
                                               for p in sub_pts]) for i in range(m)],
                            reps=1) * n / m
            q = pred.fn(*[tuple(p[:, j] for j in range(pred.dim)) for p in pts])
            perm = permanent(pred.name, [tuple(p[:, j] for j in range(pred.dim))
                                         for p in pts])
            shew = float(np.mean(np.abs(q) <= SHEWCHUK[pred.name] * perm))
            print(f"{pred.name:<9} {kind:<11} {1e9 * t_naive / n:>9.1f} "
                  f"{1e9 * t_filt / n:>11.1f} {1e9 * t_exact / n:>9.0f} {share:>15.4f} "
                  f"{shew:>18.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
