"""Definitions shared by several test modules (so that no test module imports another).

* :func:`check_exact` and its helpers: the exact-arithmetic oracle for
  :func:`predicates.intersect` (its own sanity tests: test_registration/test_intersect_oracle.py);
* :func:`transformed` and :func:`plane_case`: registration inputs (randomly moved copies
  of the examples; a Kuhn grid cut by a rotated plane);
* :class:`Format`, :data:`FORMATS`, :data:`SCALES`, :data:`OFFSETS`, :data:`PREDICATES`,
  :func:`build`: the number systems and constructions of
  test_predicates/test_predicates_exact.py, also used by tests/fixtures/harvest.py.

The oracle:

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

import fperr
import predicates
from predicates import catalogue
from predicates.registration.examples import cube_grid
from predicates.portable import rotate, rotation, unit_rows
from proofs.tables import TABLES, sympy_spec
from geometry_cases import Units, place
from geometry_constructions import construct
from geometry_exact import frac

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
        spec = sympy_spec(spec)  # a run's table holds exact values, not sympy
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


# -- registration inputs ------------------------------------------------------------------------
def transformed(ex, rng, jitter=(0.1, 10.0), frac=0.5):
    """A random rotation, a non-power-of-two scale and a translation (the same map for
    both meshes, so coincident vertices stay coincident), then a jitter of
    jitter[0]..jitter[1] tolerances τ on a random fraction of each mesh's vertices."""
    dim = ex["dim"]
    # elementwise IEEE operations only: the same inputs on every machine (docs/design.md)
    Q = rotation(dim, int(rng.integers(1 << 30)))
    scale = float(rng.uniform(1.0, 2.0)) * 2.0 ** int(rng.integers(-11, 12))
    shift = rng.uniform(-1.0, 1.0, size=dim) * scale * rng.choice([0.0, 1.0, 100.0])

    def apply(p):
        return rotate(p, Q) * scale + shift

    sp, cp = apply(ex["sim"][0]), apply(ex["cut"][0])
    tau = predicates.intersect(sp, ex["sim"][1], cp, ex["cut"][1]) \
        .tolerances_input_units()["tau"]
    out = []
    for p in (sp, cp):
        p = p.copy()
        pick = rng.random(len(p)) < frac
        d = unit_rows(rng.uniform(-1.0, 1.0, size=(pick.sum(), dim)))
        p[pick] += d * (tau * rng.uniform(*jitter, size=pick.sum()))[:, None]
        out.append(p)
    return out[0], ex["sim"][1], out[1], ex["cut"][1]


def plane_case(n=10, half=1e4):
    """Kuhn grid n³ and a rotated plane as two triangles, offset so that every grid
    vertex is at least 0.02 away from it."""
    sp, sc = cube_grid(n)
    # normal ∝ (1, 1, 2): vertex heights lie on levels 1/(n√6) apart (0.041 for n = 10);
    # the plane halfway between two levels near the centre is ≥ 0.02 from every vertex
    nrm = np.array([1.0, 1.0, 2.0]) / np.sqrt(6.0)
    d = (2 * n - 0.5) / (n * np.sqrt(6.0))
    assert np.min(np.abs(sp @ nrm - d)) > 0.02
    u = unit_rows(np.cross(nrm, [1.0, 0, 0])[None])[0]
    v = np.cross(nrm, u)
    c = d * nrm
    cp = np.array([c + half * (a * u + b * v) for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])
    cc = np.array([[0, 1, 2], [0, 2, 3]])
    return sp, sc, cp, cc


# ---------------------------------------------------------------------------------
# number systems under test


class Format:
    """One number system: how to get its tolerances and run a predicate in it."""

    def __init__(self, name, bits, tol_dtype, kind, np_dtype=None):
        self.name, self.bits, self.tol_dtype, self.kind = name, bits, tol_dtype, kind
        self.np_dtype = np_dtype
        self.eps = Fraction(1, 2**bits)

    def __repr__(self):
        return self.name

    def tolerances(self, dim, L_a, L_b):
        return predicates.tolerances(dim, L_a, L_b, dtype=self.tol_dtype)

    def tol_call(self, dim, L_a, L_b) -> str:
        dt = {"f64": "float", "np64": "np.float64", "np32": "np.float32",
              "mp17": "'mp17'"}[self.name]
        return f"predicates.tolerances({dim}, {L_a!r}, {L_b!r}, dtype={dt})"

    def run(self, pred, configs, tol):
        """(hits, weights) of ``pred`` on exact configurations; weights as Fractions."""
        if not configs:
            return [], []
        if self.kind == "batch":
            arrs = [np.array([[float(c) for c in cfg[i]] for cfg in configs], dtype=self.np_dtype)
                    for i in range(len(configs[0]))]
            hit, w = pred(*arrs, tol)
            assert hit.dtype == bool and hit.shape == (len(configs),)
            assert w.dtype == self.np_dtype and w.shape == (len(configs), len(pred.weight_names))
            return [bool(h) for h in hit], [tuple(frac(x) for x in row) for row in w]
        hits, weights = [], []
        ctx = fperr.MpContext(17) if self.kind == "mp" else None
        for cfg in configs:
            pts = [tuple(float(c) for c in p) for p in cfg]
            h, w = pred(*pts, tol, ctx=ctx) if ctx else pred(*pts, tol)
            assert isinstance(h, bool) and len(w) == len(pred.weight_names)
            hits.append(h)
            weights.append(tuple(frac(x) for x in w))
        return hits, weights

    def degenerate(self, pred, configs, tol):
        """For each configuration: would a lower-level pair be registered?"""
        out = [False] * len(configs)
        for lower, idx in catalogue.sub_pairs(pred):
            todo = [k for k in range(len(configs)) if not out[k]]
            hits, _ = self.run(lower, [tuple(configs[k][i] for i in idx)
                                                     for k in todo], tol)
            for k, h in zip(todo, hits):
                out[k] = out[k] or h
        return out


FORMATS = {
    "f64": Format("f64", 53, float, "scalar"),
    "np64": Format("np64", 53, np.float64, "batch", np.float64),
    "np32": Format("np32", 24, np.float32, "batch", np.float32),
    "mp17": Format("mp17", 17, "mp17", "mp"),
}

#: (L_a, L_b) choices: exact in every format (short dyadics).
SCALES = [(1.0, 1.0), (0.75, 0.0), (3.0, 0.25), (0.00146484375, 0.0), (96.0, 32.0)]
#: where the configuration's box starts, in units of L (exact: L has a short significand)
OFFSETS = [0.0, -0.5, 3.0, 64.0]


PREDICATES = [p for d in (2, 3) for p in predicates.ALL[d]]


def build(pred, fmt: Format, src, tol, offset: float, attempts: int = 8):
    """One constructed configuration, exact in ``fmt`` (None when every attempt left the
    box)."""
    u = Units.of(tol)
    L = frac(tol.L)
    for _ in range(attempts):
        with np.errstate(all="ignore"):
            pts = construct(pred.name, src, u)
        cfg = place(pts, Fraction(offset) * L, L, fmt.bits)
        if cfg is not None:
            return cfg
    return None
