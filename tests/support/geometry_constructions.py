"""The adversarial configurations of each predicate (:func:`construct`): near-degenerate
points placed in tolerance units — within 0.1–10 tolerances of edges, faces and each
other, on the T−/T+ band edges, coplanar and collinear, tiny elements just above σ̂, long
ones spanning L — from the shapes of :mod:`geometry_cases`, driven by a
:class:`~geometry_cases.Source`. The verdicts are :mod:`geometry_exact`'s, on the rounded
coordinates (:func:`~geometry_cases.place`).
"""
from __future__ import annotations

import math

import numpy as np

from geometry_cases import (TET_EDGES, TET_FACES, Source, Units, across, along, bary,
                            cos_rn, in_plane_point, normal, perp, rand_dir, segment,
                            sin_rn, triangle, triangle_big, unit)
from geometry_exact import _dot
from predicates.portable import norm as _norm  # fixed order, not BLAS

#: points of each predicate's configuration
_NPTS = {"vertex_vertex": 2, "edge_vertex": 3, "edge_edge": 4, "triangle_vertex": 4,
         "triangle_edge": 5, "tetrahedron_vertex": 5}


def construct(name: str, src: Source, u: Units, big: bool | None = None) -> list:
    """A configuration for predicate ``name`` (list of points in the unit box, floats).

    ``big``: use :func:`construct_big` (None: with probability 1/2 when the tolerances
    are coarse, σ > 0.02·L, else 1/6)."""
    dim = u.dim
    if big is None:
        big = src.integer(0, 5) < (3 if u.t["sigma"] > 0.02 else 1)
    if big:
        return construct_big(name, src, u)
    if src.integer(0, 9) == 0:  # plain random configuration
        return [np.array([src.uniform(0, 1) for _ in range(dim)]) for _ in range(_NPTS[name])]
    build = _PLANAR.get(name) if dim == 2 else None
    if build is None and name not in _BUILDERS:
        raise KeyError(name)
    return (build or _BUILDERS[name])(src, u)


def construct_big(name: str, src: Source, u: Units) -> list:
    """Large elements (spanning the box) with a near-degenerate probe well inside them:
    the configurations that stay non-degenerate even when the tolerances are a sizeable
    fraction of L (3D at 17 bits: σ ≈ 0.34·L)."""
    dim = u.dim
    mid = lambda: src.choice((src.uniform(0.3, 0.7), src.uniform(0.05, 0.95)))
    if name == "vertex_vertex":
        return construct(name, src, u, big=False)
    if name == "edge_vertex":
        A, B = across(src, dim)
        return [A, B, A + mid() * (B - A) + u.near(src, "tau") * perp(src, B - A)]
    if name == "edge_edge":
        A, B = across(src, dim)
        X = A + mid() * (B - A)
        uu = unit(B - A)
        e = perp(src, uu)
        ang = src.choice((src.uniform(0.3, math.pi - 0.3), src.uniform(0.02, 0.3)))
        v = cos_rn(ang) * uu + sin_rn(ang) * e
        if dim == 3:
            n = unit(np.cross(uu, v))
            Y = X + src.sign() * u.near(src, "gamma") * n
        else:
            Y = X + (u.near(src, "tau") * perp(src, v) if src.integer(0, 2) == 0 else 0.0)
        h = [src.uniform(0.2, 0.6) for _ in range(2)]
        return [A, B, Y - h[0] * v, Y + h[1] * v]
    tri = triangle_big(src, dim)
    if name == "triangle_vertex" and dim == 2:
        return tri + [in_plane_point(src, tri, u)]
    if name == "triangle_vertex":
        foot = in_plane_point(src, tri, u)
        return tri + [foot + src.sign() * u.near(src, "delta") * normal(tri)]
    if name == "triangle_edge":
        X = in_plane_point(src, tri, u)
        n = normal(tri)
        e = perp(src, n)
        phi = src.choice((src.uniform(0.3, math.pi / 2), src.uniform(0.02, 0.3)))
        d = cos_rn(phi) * e + sin_rn(phi) * n
        arms = [min(src.choice((u.near(src, "delta") / sin_rn(phi), src.uniform(0.1, 0.5))),
                    0.7) for _ in range(2)]
        return tri + [X - arms[0] * d, X + arms[1] * d]
    if name == "tetrahedron_vertex":
        base = [np.array(p, dtype=float) for p in ((0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1))]
        tet = [np.clip(p + np.array([src.uniform(-0.1, 0.1) for _ in range(3)]), 0, 1)
               for p in base]
        mode = src.integer(0, 2)
        if mode == 0:  # around the centroid: inside, or outside across a face
            return tet + [sum(tet) / 4 + src.uniform(0, 0.6) * rand_dir(src, 3)]
        f = [tet[i] for i in TET_FACES[src.integer(0, 3)]]
        n = normal(f)
        inward = n if _dot(n, sum(tet) / 4 - f[0]) > 0 else -n
        foot = in_plane_point(src, f, u)
        if mode == 1:  # within 0.1–10 δ of a face, either side
            return tet + [foot + src.choice((1, 1, -1)) * u.near(src, "delta") * inward]
        # beyond the face's δ window, either side
        return tet + [foot + src.sign() * src.uniform(1.0, 3.0) * u.t["delta"] * inward]
    raise KeyError(name)


def _vertex_vertex(src: Source, u: Units) -> list:
    dim = u.dim
    A = np.array([src.uniform(0.2, 0.8) for _ in range(dim)])
    return [A, A + u.near(src, "sigma") * rand_dir(src, dim)]


def _edge_vertex(src: Source, u: Units) -> list:
    dim = u.dim
    A, B = segment(src, u)
    if src.integer(0, 3) == 0:  # near an endpoint
        P = src.choice((A, B)) + u.near(src, "sigma") * rand_dir(src, dim)
    else:
        t = along(src, _norm(B - A), u)
        P = A + t * (B - A) + u.near(src, "tau") * perp(src, B - A)
    return [A, B, P]


def _edge_edge_2d(src: Source, u: Units) -> list:
    dim = u.dim
    A, B = segment(src, u)
    mode = src.integer(0, 3)
    if mode == 0:  # collinear (up to a shift of 0.1–10 τ)
        t1, t2 = src.uniform(-0.5, 1.5), src.uniform(-0.5, 1.5)
        n = perp(src, B - A) * (u.near(src, "tau") if src.integer(0, 1) else 0.0)
        return [A, B, A + t1 * (B - A) + n, A + t2 * (B - A) + n]
    if mode == 1:  # a vertex of PQ near AB
        t = along(src, _norm(B - A), u)
        P = A + t * (B - A) + u.near(src, "tau") * perp(src, B - A)
        Q = np.array([src.uniform(0, 1) for _ in range(dim)])
        return [A, B, P, Q] if src.integer(0, 1) else [P, Q, A, B]
    # crossing at X with an angle (possibly tiny), short or long arms, optional shift
    X = A + along(src, _norm(B - A), u) * (B - A)
    ang = src.choice((src.uniform(0, math.pi), src.loguniform(1e-12, 1e-2), 0.0,
                      math.pi / 2))
    e = unit(B - A) if _norm(B - A) > 0 else np.array([1.0, 0.0])
    c, s = cos_rn(ang), sin_rn(ang)
    d = np.array([c * e[0] - s * e[1], s * e[0] + c * e[1]])
    arms = [src.choice((u.near(src, "tau"), src.uniform(0.02, 0.5),
                        u.t["sigma"] * src.uniform(0.5, 3))) for _ in range(2)]
    shift = perp(src, d) * (u.near(src, "tau") if src.integer(0, 2) == 0 else 0.0)
    return [A, B, X - arms[0] * d + shift, X + arms[1] * d + shift]


def _triangle_vertex_2d(src: Source, u: Units) -> list:
    tri = triangle(src, u)
    return tri + [in_plane_point(src, tri, u)]


def _edge_edge_3d(src: Source, u: Units) -> list:
    """3D: closest points X (on AB) and Y = X + k·γ·n."""
    A, B = segment(src, u)
    mode = src.integer(0, 4)
    if mode == 0:  # collinear-ish / parallel
        v = B - A
        off = perp(src, v) * src.choice((0.0, u.near(src, "gamma"), u.near(src, "tau")))
        t1, t2 = src.uniform(-0.5, 1.5), src.uniform(-0.5, 1.5)
        return [A, B, A + t1 * v + off, A + t2 * v + off]
    if mode == 1:  # an endpoint of PQ near AB
        t = along(src, _norm(B - A), u)
        P = A + t * (B - A) + u.near(src, "tau") * perp(src, B - A)
        Q = P + src.uniform(0.05, 0.6) * rand_dir(src, 3)
        return [A, B, P, Q] if src.integer(0, 1) else [P, Q, A, B]
    uu = unit(B - A) if _norm(B - A) > 0 else np.array([1.0, 0, 0])
    X = A + along(src, _norm(B - A), u) * (B - A)
    e = perp(src, uu)
    ang = src.choice((src.uniform(0, math.pi), src.loguniform(1e-12, 1e-2), math.pi / 2))
    v = cos_rn(ang) * uu + sin_rn(ang) * e
    n = unit(np.cross(uu, v)) if ang > 0 else perp(src, uu)
    Y = X + src.sign() * u.near(src, "gamma") * n
    arms = [src.choice((u.near(src, "tau"), src.uniform(0.02, 0.5),
                        u.t["sigma"] * src.uniform(0.5, 3))) for _ in range(2)]
    return [A, B, Y - arms[0] * v, Y + arms[1] * v]


def _triangle_vertex_3d(src: Source, u: Units) -> list:
    """3D."""
    tri = triangle(src, u)
    foot = in_plane_point(src, tri, u)
    try:
        n = normal(tri)
    except FloatingPointError:
        n = rand_dir(src, 3)
    if not np.all(np.isfinite(n)):
        n = rand_dir(src, 3)
    return tri + [foot + src.sign() * u.near(src, "delta") * n]


def _triangle_edge(src: Source, u: Units) -> list:
    tri = triangle(src, u)
    X = in_plane_point(src, tri, u)
    n = normal(tri)
    if not np.all(np.isfinite(n)):
        n = rand_dir(src, 3)
    e = perp(src, n)
    mode = src.integer(0, 4)
    if mode == 0:  # coplanar segment (possibly shifted by 0.1–10 δ)
        off = n * src.choice((0.0, u.near(src, "delta")))
        return tri + [X - src.uniform(0, 0.5) * e + off, X + src.uniform(0, 0.5) * e + off]
    phi = src.choice((src.uniform(0.05, math.pi / 2), src.loguniform(1e-9, 0.05),
                      math.pi / 2))
    d = cos_rn(phi) * e + sin_rn(phi) * n
    arms = []
    for _ in range(2):
        k = src.integer(0, 2)
        if k == 0:  # endpoint within 0.1–10 δ of the plane (grazing: any length)
            a = u.near(src, "delta") / sin_rn(phi)
            arms.append(a if a < 0.7 else src.uniform(0.02, 0.5))
        elif k == 1:
            arms.append(src.uniform(0.02, 0.5))
        else:
            arms.append(u.t["sigma"] * src.uniform(0.5, 3))
    return tri + [X - arms[0] * d, X + arms[1] * d]


def _tetrahedron_vertex(src: Source, u: Units) -> list:
    mode = src.integer(0, 4)
    if mode == 0:  # regular-ish (corners of the box), jittered
        base = [np.array(p, dtype=float) for p in ((0, 0, 0), (1, 1, 0), (1, 0, 1), (0, 1, 1))]
        tet = [np.clip(p + np.array([src.uniform(-0.1, 0.1) for _ in range(3)]), 0, 1)
               for p in base]
    elif mode == 1:  # flat: D within 0.1–10 δ of the plane ABC (or on it)
        tri = triangle(src, u)
        n = normal(tri)
        if not np.all(np.isfinite(n)):
            n = rand_dir(src, 3)
        tet = tri + [in_plane_point(src, tri, u) + n * src.choice((0.0, u.near(src, "delta")))]
    elif mode == 2:  # tiny (edges just above σ̂)
        A = np.array([src.uniform(0.3, 0.7) for _ in range(3)])
        tet = [A] + [A + u.t["sigma_hat"] * src.uniform(1.0, 4.0) * rand_dir(src, 3)
                     for _ in range(3)]
    else:
        tet = triangle(src, u) + [np.array([src.uniform(0, 1) for _ in range(3)])]
    pmode = src.integer(0, 3)
    if pmode == 0:
        b = bary(src, 4)
        P = sum(bi * X for bi, X in zip(b, tet))
    elif pmode == 1:  # near a face: 0.1–10 δ inside or outside
        f = [tet[i] for i in TET_FACES[src.integer(0, 3)]]
        n = normal(f)
        if not np.all(np.isfinite(n)):
            n = rand_dir(src, 3)
        P = in_plane_point(src, f, u) + src.sign() * u.near(src, "delta") * n
    elif pmode == 2:  # near an edge
        i, j = TET_EDGES[src.integer(0, 5)]
        X, Y = tet[i], tet[j]
        t = along(src, _norm(Y - X), u)
        P = X + t * (Y - X) + u.near(src, "tau") * perp(src, Y - X if _norm(Y - X) else np.ones(3))
    else:
        P = tet[src.integer(0, 3)] + u.near(src, "sigma") * rand_dir(src, 3)
    return tet + [P]


_PLANAR = {"edge_edge": _edge_edge_2d, "triangle_vertex": _triangle_vertex_2d}
_BUILDERS = {"vertex_vertex": _vertex_vertex, "edge_vertex": _edge_vertex,
             "edge_edge": _edge_edge_3d, "triangle_vertex": _triangle_vertex_3d,
             "triangle_edge": _triangle_edge, "tetrahedron_vertex": _tetrahedron_vertex}
