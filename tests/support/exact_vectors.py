"""Vector helpers for the rule tests, written once for every number system: the same
expression runs on Tracked quantities, in the formats and exactly (``exact_eval``'s
contexts ``K``), with the same operation order."""
from __future__ import annotations

from fractions import Fraction

import fperr
from exact_eval import EXACT, INTERVAL, SYMBOLIC, TRACKED, OutOfRange
from fperr import guards

def sub(p, q):
    return [a - b for a, b in zip(p, q)]


def dot(u, v):
    s = u[0] * v[0]
    for a, b in zip(u[1:], v[1:]):
        s = s + a * b
    return s


def cross2(u, v):
    return u[0] * v[1] - u[1] * v[0]


def cross3(u, v):
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def norm(u, K):
    return K.sqrt(dot(u, u))


def normalise(u, K):
    """u = û·(1/m), m = sqrt(û·û): rule G's quotient multiplied into the vector."""
    inv = K.const(1) / norm(u, K)
    return [c * inv for c in u]


def pts(xs, d, k):
    """The first k points of dimension d from the flat coordinate list."""
    return [xs[i * d:(i + 1) * d] for i in range(k)]


def names(points: str, d: int) -> tuple[str, ...]:
    return tuple(f"{p}.{c}" for p in points.split() for c in "xyz"[:d])


def X(n):
    return tuple(f"x{i}" for i in range(n))


def nonzero(*idx_pairs):
    """Precondition: the vector of differences xs[i] − xs[j] is not zero."""
    return lambda xs: any(xs[i] != xs[j] for i, j in idx_pairs)


def sq(x):
    return x * x


def guarded(d, t: Fraction, p: int, xs, K):
    """d, used only where a passed check |F[d]| > t·Λ^p holds (Λ: the power of two
    ≥ 2·max|x|, so Λ ≥ the checker's L and the floor t·L^p is implied). Instrumented,
    the check is recorded as a predicate's rejection would be (rules GL/HL); in a
    format, inputs that fail it are discarded (OutOfRange) as the predicate would."""
    if K is TRACKED:
        T = fperr.const(t) * fperr.exact_input(f"L^{p}", 1, p, nonnegative=True, tight=True)
        guards.record_rejection(abs(d) <= T)
        return d
    if K in (EXACT, INTERVAL, SYMBOLIC):
        return d
    m = max((abs(K.to_fraction(x)) for x in xs), default=Fraction(0))
    lam = Fraction(1)
    while lam < 2 * m:
        lam *= 2
    while m and lam / 2 >= 2 * m:
        lam /= 2
    if not abs(K.to_fraction(d)) > t * lam ** p:
        raise OutOfRange("the guard |d| > T fails: the predicate rejects this input")
    return d
