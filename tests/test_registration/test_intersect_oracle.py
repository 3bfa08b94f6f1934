"""Exact-arithmetic oracle for :func:`predicates.intersect`, and its own sanity tests.

:func:`check_exact` re-derives, independently of the implementation, every primitive of
both meshes and every pair of every kind whose boxes are within 2σ+ (a plain numpy
all-pairs test: farther pairs cannot meet any T+ condition), evaluates each pair's
geometric condition exactly (coordinates as integers, tolerances at 3000+ bits with
mpmath), and checks the paper's guarantee (section 3, eq. (1)) for every pair that has
no registered sub-pair:

    exactly inside with T−   ⇒  registered,
    registered              ⇒  exactly inside with T+,

and that no registered pair has a registered sub-pair. "Inside with T" per kind:

* vertex-vertex: ‖A − B‖ ≤ σ;
* edge-vertex (both roles): distance from P to line AB ≤ τ and P projects strictly
  inside AB (0 < â < m²);
* 2D edge-edge, 2D triangle-vertex, triangle-edge (both roles), tetrahedron-vertex:
  a proper crossing / strict containment (every area or volume of the algorithm
  non-zero with the required signs) — their tolerances are error margins only;
* 3D edge-edge: non-parallel, line distance ≤ γ, both closest points strictly inside;
* 3D triangle-vertex (both roles): distance to the plane ≤ δ, projection strictly
  inside (â, b̂, ĉ > 0).

It also checks the returned weights: in [0, 1], summing to 1, and the intersection
points on the two primitives within σ+ of each other.
"""
from __future__ import annotations

import itertools
from fractions import Fraction

import mpmath
import numpy as np
import pytest

from predicates.tolerance_table import TABLES
from predicates.registration.examples import example
import predicates

KIND_DIMS = {2: {"vertex_vertex": (0, 0), "vertex_edge": (0, 1), "edge_vertex": (1, 0),
                 "edge_edge": (1, 1), "triangle_vertex": (2, 0)},
             3: {"vertex_vertex": (0, 0), "vertex_edge": (0, 1), "edge_vertex": (1, 0),
                 "edge_edge": (1, 1), "vertex_triangle": (0, 2), "triangle_vertex": (2, 0),
                 "edge_triangle": (1, 2), "triangle_edge": (2, 1),
                 "tetrahedron_vertex": (3, 0)}}


# -- exact vector algebra on integer tuples ---------------------------------------------------
def sub(p, q):
    return tuple(a - b for a, b in zip(p, q))


def dot(p, q):
    return sum(a * b for a, b in zip(p, q))


def cross(p, q):
    if len(p) == 2:
        return p[0] * q[1] - p[1] * q[0]
    return (p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0])


def sq(c):
    return c * c if isinstance(c, int) else dot(c, c)


def sgn(x):
    return (x > 0) - (x < 0)


def all_same_strict(*xs):
    s = {sgn(x) for x in xs}
    return len(s) == 1 and 0 not in s


def opposite_strict(x, y):
    return sgn(x) * sgn(y) == -1


# -- the exact conditions (T is a dict name -> mpf threshold in integer units) --------------
def vv(A, B, T):
    return sq(sub(A, B)) <= T["sigma"] ** 2


def ev(A, B, P, T):
    u, w = sub(B, A), sub(P, A)
    m2 = dot(u, u)
    if m2 == 0:
        return False
    a = dot(u, w)
    return sq(cross(u, w)) <= T["tau"] ** 2 * m2 and 0 < a < m2


def ee2(A, B, P, Q, T):
    BA, QP = sub(B, A), sub(Q, P)
    return (opposite_strict(cross(sub(P, A), BA), cross(sub(Q, A), BA))
            and opposite_strict(cross(sub(A, P), QP), cross(sub(B, P), QP)))


def tv2(A, B, C, P, T):
    return all_same_strict(cross(sub(B, P), sub(C, P)), cross(sub(P, A), sub(C, A)),
                           cross(sub(B, A), sub(P, A)))


def ee3(A, B, P, Q, T):
    u, v, w = sub(B, A), sub(Q, P), sub(P, A)
    r = cross(u, v)
    m2 = dot(r, r)
    if m2 == 0:
        return False
    d = dot(r, w)
    n = cross(r, w)
    a, b = dot(n, v), dot(n, u)
    return d * d <= T["gamma"] ** 2 * m2 and 0 < a < m2 and 0 < b < m2


def tv3(A, B, C, P, T):
    u, v, w = sub(B, A), sub(C, A), sub(P, A)
    r = cross(u, v)
    m2 = dot(r, r)
    if m2 == 0:
        return False
    d = dot(r, w)
    n = cross(r, w)
    b, c = dot(n, v), -dot(n, u)
    a = m2 - b - c
    return d * d <= T["delta"] ** 2 * m2 and a > 0 and b > 0 and c > 0


def triple(p, q, r):
    return dot(cross(p, q), r)


def te(A, B, C, P, Q, T):
    PQ = sub(P, Q)
    AQ, BQ, CQ = sub(A, Q), sub(B, Q), sub(C, Q)
    vA, vB, vC = triple(BQ, CQ, PQ), triple(CQ, AQ, PQ), triple(AQ, BQ, PQ)
    vP, vQ = triple(sub(A, P), sub(B, P), sub(C, P)), triple(AQ, BQ, CQ)
    return all_same_strict(vA, vB, vC) and opposite_strict(vP, vQ)


def tetv(A, B, C, D, P, T):
    return all_same_strict(triple(sub(B, P), sub(C, P), sub(D, P)),
                           triple(sub(P, A), sub(C, A), sub(D, A)),
                           triple(sub(B, A), sub(P, A), sub(D, A)),
                           triple(sub(B, A), sub(C, A), sub(P, A)))


def inside(kind, dim, S, C, T):
    """Exact condition for simulation primitive S and cutting primitive C (tuples of
    integer points)."""
    if kind == "vertex_vertex":
        return vv(S[0], C[0], T)
    if kind == "vertex_edge":
        return ev(C[0], C[1], S[0], T)
    if kind == "edge_vertex":
        return ev(S[0], S[1], C[0], T)
    if kind == "edge_edge":
        return (ee2 if dim == 2 else ee3)(*S, *C, T)
    if kind == "triangle_vertex":
        return (tv2 if dim == 2 else tv3)(*S, *C, T)
    if kind == "vertex_triangle":
        return tv3(*C, S[0], T)
    if kind == "edge_triangle":
        return te(*C, *S, T)
    if kind == "triangle_edge":
        return te(*S, *C, T)
    if kind == "tetrahedron_vertex":
        return tetv(*S, C[0], T)
    raise ValueError(kind)


# -- primitives, independently ------------------------------------------------------------------
def simplices(cells):
    """{k: sorted list of k-simplices (sorted vertex tuples)} of every face of the cells."""
    out = {}
    for cell in np.asarray(cells).tolist():
        cell = sorted(cell)
        for k in range(len(cell)):
            out.setdefault(k, set()).update(itertools.combinations(cell, k + 1))
    return {k: sorted(v) for k, v in out.items()}


def faces(simplex):
    for r in range(1, len(simplex) + 1):
        yield from itertools.combinations(simplex, r)


# -- the check ----------------------------------------------------------------------------------
def _integer_coords(points):
    """(dict id -> integer tuple, K) with points·2^K integral."""
    K = 0
    fr = []
    for x in points.ravel().tolist():
        n, d = float(x).as_integer_ratio()
        fr.append((n, d))
        K = max(K, d.bit_length() - 1)
    ints = [n * (2 ** K // d) for n, d in fr]
    dim = points.shape[1]
    return [tuple(ints[i * dim:(i + 1) * dim]) for i in range(len(points))], K


def thresholds(res, K, which):
    """Tolerances T− (which=0), T (1) or T+ (2) in integer units, as mpf."""
    L = mpmath.mpf(Fraction(float(res._scaled_tolerances.L)).numerator) / \
        Fraction(float(res._scaled_tolerances.L)).denominator
    eps = mpmath.mpf(2) ** (-(np.finfo(res.dtype).nmant + 1))
    out = {}
    for name, spec in (res.tolerances.table or TABLES[res.dim]).items():
        coef = (spec.lo, spec.mid, spec.hi)[which]
        c = mpmath.mpf(str(coef.evalf(60)))
        q = mpmath.mpf(spec.q.p) / spec.q.q
        out[name] = c * eps ** q * (L * 2 ** K) ** spec.p
    return out


def check_exact(res, sim_points=None, cut_points=None, sim_cells=None, cut_cells=None):
    """Verify ``res`` against exact arithmetic; returns a dict of counters. Raises
    AssertionError listing the first violations."""
    dim, e = res.dim, res.scale_exponent
    sp = np.ldexp(res.sim_points, -e)
    cp = np.ldexp(res.cut_points, -e)
    allp = np.concatenate([sp, cp]).astype(np.float64)
    ints, K = _integer_coords(allp)
    Sx, Cx = ints[: len(sp)], ints[len(sp):]
    prec = 8 * (K + 40) + 200
    violations = []
    stats = {"pairs": 0, "registered": 0, "must_register": 0}
    reg = {k: res[k].keys() for k in res.kinds}
    reg_by_dims = {KIND_DIMS[dim][k]: v for k, v in reg.items()}
    Ss, Cs = simplices(res.sim_cells), simplices(res.cut_cells)
    with mpmath.workprec(prec):
        Tm, Tp = thresholds(res, K, 0), thresholds(res, K, 2)
        sigma_plus = float(thresholds(res, 0, 2)["sigma"])
        for kind in res.kinds:
            i, j = KIND_DIMS[dim][kind]
            A, B = Ss.get(i, []), Cs.get(j, [])
            if not A or not B:
                assert not reg[kind]
                continue
            XA, XB = sp[np.array(A)], cp[np.array(B)]
            lo_a, hi_a, lo_b, hi_b = XA.min(1), XA.max(1), XB.min(1), XB.max(1)
            pad = 2 * sigma_plus
            near = np.all((lo_b[None] - hi_a[:, None] <= pad) &
                          (lo_a[:, None] - hi_b[None] <= pad), axis=2)
            candidates = set(zip(*np.nonzero(near)))
            regset = reg[kind]
            index_a = {s: n for n, s in enumerate(A)}
            index_b = {s: n for n, s in enumerate(B)}
            for s, c in regset:  # registered pairs must be near and known primitives
                assert s in index_a and c in index_b, (kind, s, c)
                if (index_a[s], index_b[c]) not in candidates:
                    violations.append((kind, s, c, "registered but farther than 2σ+"))
            for a, b in candidates:
                s, c = A[a], B[b]
                stats["pairs"] += 1
                sub_registered = any(
                    (s2, c2) in reg_by_dims.get((len(s2) - 1, len(c2) - 1), ())
                    for s2 in faces(s) for c2 in faces(c) if (s2, c2) != (s, c))
                is_reg = (s, c) in regset
                if is_reg:
                    stats["registered"] += 1
                    if sub_registered:
                        violations.append((kind, s, c, "registered with a registered sub-pair"))
                if sub_registered:
                    continue
                S = tuple(Sx[v] for v in s)
                C = tuple(Cx[v] for v in c)
                if is_reg and not inside(kind, dim, S, C, Tp):
                    violations.append((kind, s, c, "registered but not inside with T+"))
                if not is_reg and inside(kind, dim, S, C, Tm):
                    stats["must_register"] += 1
                    violations.append((kind, s, c, "inside with T- but not registered"))
                elif is_reg:
                    stats["must_register"] += inside(kind, dim, S, C, Tm)
    violations += check_weights(res, sigma_plus)
    assert not violations, f"{len(violations)} violations, first: {violations[:5]}"
    return stats


def check_weights(res, sigma_plus_scaled):
    bad = []
    e = res.scale_exponent
    sp = np.ldexp(res.sim_points.astype(np.float64), -e)
    cp = np.ldexp(res.cut_points.astype(np.float64), -e)
    for kind in res.kinds:
        p = res[kind]
        if not len(p):
            continue
        for w, name in ((p.sim_weights, "sim"), (p.cut_weights, "cut")):
            w = w.astype(np.float64)
            if (w < 0).any() or (w > 1).any():
                bad.append((kind, f"{name} weights outside [0, 1]"))
            if np.abs(w.sum(1) - 1).max() > 1e-5 if res.dtype == np.float32 else \
                    np.abs(w.sum(1) - 1).max() > 1e-12:
                bad.append((kind, f"{name} weights do not sum to 1"))
        xs = p.points(sp, "sim")
        xc = p.points(cp, "cut")
        gap = np.linalg.norm(xs - xc, axis=1).max()
        if gap > sigma_plus_scaled * 1.01:
            bad.append((kind, f"points on the two primitives {gap} apart (σ+ = "
                              f"{sigma_plus_scaled})"))
    return bad


# -- sanity tests of the oracle itself -------------------------------------------------------------
def test_oracle_conditions_on_textbook_cases():
    T = {"sigma": 1, "tau": 1, "gamma": 1, "delta": 1}
    assert vv((0, 0), (1, 0), T) and not vv((0, 0), (2, 0), T)
    assert ev((0, 0), (10, 0), (5, 1), T) and not ev((0, 0), (10, 0), (11, 0), T)
    assert ee2((0, 0), (2, 2), (0, 2), (2, 0), T) and not ee2((0, 0), (2, 2), (3, 3), (4, 0), T)
    assert tv2((0, 0), (4, 0), (0, 4), (1, 1), T) and not tv2((0, 0), (4, 0), (0, 4), (2, 2), T)
    assert te((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, -1), (1, 1, 1), T)
    assert not te((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 0), (1, 1, 1), T)
    assert tetv((0, 0, 0), (4, 0, 0), (0, 4, 0), (0, 0, 4), (1, 1, 1), T)
    assert ee3((0, 0, 0), (4, 0, 0), (2, -2, 1), (2, 2, 1), T)
    assert not ee3((0, 0, 0), (4, 0, 0), (2, -2, 2), (2, 2, 2), T)
    assert tv3((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 1), T)
    assert not tv3((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 2), T)


def test_oracle_catches_a_wrong_registration():
    ex = example("diagonal", 4)
    res = predicates.intersect(*ex["sim"], *ex["cut"])
    check_exact(res)
    p = res["vertex_vertex"]
    p.sim = p.sim[::-1].copy()  # pair every cut vertex with the wrong simulation vertex
    with pytest.raises(AssertionError):
        check_exact(res)
