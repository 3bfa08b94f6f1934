"""The predicate catalogue: everything derived from the ``@predicate`` declarations.

Each predicate declares once (``predicates.core.predicate``) its points — the
simulation primitive's first (``sim``), the cutting primitive's after (``cut``) — its
weights, the paper's section, the tolerance bracketing its inside-test and its
broad-phase reach. From that alone this module derives:

* :func:`kinds`: the registration kinds of section 1 ("simulation primitive _ cutting
  primitive"), in registration order: by level (points − 2), then by algorithm, a
  kind whose cutting primitive plays the predicate's simulation role ("swapped", e.g.
  ``vertex_edge`` is Algorithm 3 with the cutting edge as AB) before the direct one;
* :func:`pair_predicate`: the predicate deciding a pair of faces of given sizes;
* :func:`sub_pairs`: the lower-level pairs between the two primitives of a predicate
  (line 2 of every algorithm, "degenerate intersection"), as the registration
  suppresses them and the tests and the audit enumerate them.

Reach: a registered pair is never farther apart than its predicate's T+ plus
rounding: vertex-vertex σ+ = 7/6.5·σ; edge-vertex τ+ (+ the error of â, ā: 5.5/4.5·τ);
3D edge-edge and triangle-vertex γ+, δ+ (2.5/2.25; we take 2.75/2.25); the others
register true crossings only (their sign tests are exact) and take τ as a margin.
Every reach is ≤ σ+, the paper's bound on the pairs processed (section 4.1).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from . import d2, d3
from .core import Predicate

__all__ = ["SIMPLEX", "Kind", "find", "kinds", "pair_predicate", "predicates", "sub_pairs"]

#: Name of the simplex with k + 1 points.
SIMPLEX = ("vertex", "edge", "triangle", "tetrahedron")

_BY_DIM = {2: (d2.vertex_vertex, d2.edge_vertex, d2.edge_edge, d2.triangle_vertex),
           3: (d3.vertex_vertex, d3.edge_vertex, d3.edge_edge, d3.triangle_vertex,
               d3.triangle_edge, d3.tetrahedron_vertex)}


def predicates(dim: int) -> tuple[Predicate, ...]:
    """Every predicate of dimension ``dim``, in the paper's order (Algorithms 2–5, 7–12)."""
    try:
        return _BY_DIM[dim]
    except KeyError:
        raise ValueError(f"dimension must be 2 or 3, got {dim!r}") from None


def find(dim: int, name: str) -> Predicate:
    """The ``dim``-D predicate called ``name`` (e.g. ``find(3, "edge_edge")``)."""
    for pred in predicates(dim):
        if pred.name == name:
            return pred
    raise ValueError(f"no {dim}D predicate named {name!r}; the {dim}D predicates are "
                     + ", ".join(p.name for p in predicates(dim)))


def _segment(t: np.ndarray) -> np.ndarray:
    return np.stack([t.dtype.type(1) - t, t], axis=1)


def _split_weights(pred: Predicate, w: np.ndarray, n: int):
    """The predicate's weights as full barycentric weights of its two primitives: a
    vertex has [1]; an edge's single parameter t is (1 − t, t); larger simplices carry
    one weight per point (Algorithms 5, 10, 11, 12)."""
    out, col = [], 0
    for part in (pred.sim, pred.cut):
        if len(part) == 1:
            out.append(np.ones((n, 1), dtype=w.dtype))
        elif len(part) == 2:
            out.append(_segment(w[:, col]))
            col += 1
        else:
            out.append(w[:, col: col + len(part)])
            col += len(part)
    assert col == w.shape[1], f"{pred.name}: weights do not match its points"
    return out


@dataclass(frozen=True)
class Kind:
    """A registration kind: simulation i-simplices against cutting j-simplices, decided
    by ``predicate`` (with the cutting primitive in the predicate's simulation role when
    ``swapped``)."""

    name: str
    i: int
    j: int
    predicate: Predicate
    swapped: bool

    @property
    def level(self) -> int:
        return self.i + self.j

    @property
    def reach(self) -> tuple[str, float]:
        return self.predicate.reach

    def evaluate(self, S: np.ndarray, C: np.ndarray, tol):
        """Run the predicate on simulation primitives ``S`` (n, i+1, d) and cutting
        primitives ``C`` (n, j+1, d) in batch mode. Returns (hit, sim_weights,
        cut_weights), each weight array (n, points of that primitive)."""
        first, second = (C, S) if self.swapped else (S, C)
        args = [first[:, k] for k in range(first.shape[1])]
        args += [second[:, k] for k in range(second.shape[1])]
        hit, w = self.predicate(*args, tol)
        w_first, w_second = _split_weights(self.predicate, w, len(S))
        return (hit, w_second, w_first) if self.swapped else (hit, w_first, w_second)


def kinds(dim: int) -> tuple[Kind, ...]:
    """The registration kinds of a ``dim``-D simulation mesh (simplices up to ``dim``)
    against a cutting mesh (simplices up to ``dim − 1``), in registration order."""
    out = []
    for pred in predicates(dim):
        i, j = len(pred.sim) - 1, len(pred.cut) - 1
        roles = [(j, i, True)] if i != j and i <= dim - 1 else []
        roles.append((i, j, False))
        for a, b, swapped in roles:
            out.append(Kind(f"{SIMPLEX[a]}_{SIMPLEX[b]}", a, b, pred, swapped))
    out.sort(key=lambda k: k.level)  # stable: algorithm order, swapped first, per level
    return tuple(out)


def pair_predicate(dim: int, n_first: int, n_second: int) -> tuple[Predicate, bool] | None:
    """The predicate deciding a face of ``n_first`` points against one of ``n_second``
    points, and whether the faces go in swapped (second face in the predicate's
    simulation role). None when no predicate of ``dim`` decides such a pair."""
    for pred in predicates(dim):
        if (len(pred.sim), len(pred.cut)) == (n_first, n_second):
            return pred, False
        if (len(pred.sim), len(pred.cut)) == (n_second, n_first):
            return pred, True
    return None


def sub_pairs(pred: Predicate) -> list[tuple[Predicate, tuple[int, ...]]]:
    """Every lower-level pair between the predicate's two primitives (never within one):
    (lower predicate, indices of its points among ``pred.points``), faces of the
    simulation primitive against faces of the cutting primitive, the pair itself
    excluded, in order of level."""
    ns, nc = len(pred.sim), len(pred.cut)
    out = []
    for a in range(1, ns + 1):
        for b in range(1, nc + 1):
            if (a, b) == (ns, nc):
                continue
            found = pair_predicate(pred.dim, a, b)
            if found is None:
                continue
            lower, swapped = found
            for f in itertools.combinations(range(ns), a):
                for g in itertools.combinations(range(ns, ns + nc), b):
                    out.append((lower, (g + f) if swapped else (f + g)))
    out.sort(key=lambda e: len(e[1]))
    return out
