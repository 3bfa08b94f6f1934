"""Exact determinants of the classic predicates, independent of any predicate source:
the determinant of each predicate's matrix (Laplace expansion) in Fractions of the
floats given (orient2d/3d: the differences to the last point; incircle/insphere: the
lifted rows)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = ["exact_det", "exact_signs"]


def _det(m):
    """Determinant of a square list of Fractions (Laplace along the first row)."""
    if len(m) == 1:
        return m[0][0]
    return sum((-1) ** j * m[0][j] * _det([row[:j] + row[j + 1:] for row in m[1:]])
               for j in range(len(m)) if m[0][j])


def exact_det(name, pts):
    """The exact determinant of one lane (points: tuples of floats)."""
    q = [tuple(Fraction(float(v)) for v in p) for p in pts]
    *rows, last = q
    diffs = [tuple(a - b for a, b in zip(p, last)) for p in rows]
    if name in ("orient2d", "orient3d"):
        return _det([list(d) for d in diffs])
    return _det([list(d) + [sum(x * x for x in d)] for d in diffs])  # lifted rows


def exact_signs(name, P):
    """Exact sign of the determinant per lane of the (n, dim) arrays ``P``."""
    rows = [a.tolist() for a in P]
    out = []
    for lane in range(P[0].shape[0]):
        d = exact_det(name, [r[lane] for r in rows])
        out.append((d > 0) - (d < 0))
    return np.array(out)
