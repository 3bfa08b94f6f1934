"""Example meshes, generated (no download): used by ``fperr demo``, the tests and the
benchmarks.

Every generator returns ``(points, cells)`` as numpy arrays (float64 coordinates,
int64 vertex ids). Grid coordinates are computed once (``i / n``) and every mesh built on
the grid reuses exactly those numbers, so "a vertex on a grid vertex" means *the same
floating-point coordinates*, and "a vertex on a grid edge" is exact whenever the
arithmetic is (n a power of two).

2D (simulation mesh: triangles, cutting mesh: segments)
    :func:`square_grid` — n×n squares, two triangles each, split along the y = x diagonal;
    cuts :func:`circle_polygon`, :func:`diagonal_cut` (on mesh edges),
    :func:`zigzag_cut` (through grid vertices).
3D (simulation mesh: tetrahedra, cutting mesh: triangles)
    :func:`cube_grid` — n×n×n cubes, six tetrahedra each (Kuhn/Freudenthal);
    cuts :func:`icosphere`, :func:`grid_plane` (on grid vertices, or offset by half a
    cell).

:func:`example` bundles a simulation mesh and a cut by name (:data:`EXAMPLES`).
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from predicates.portable import cos_sin, unit_rows
from predicates.registration.levels.complex import unique_rows

__all__ = ["EXAMPLES", "circle_polygon", "cube_grid", "diagonal_cut", "example",
           "grid_coordinates", "grid_plane", "icosphere", "square_grid", "zigzag_cut"]


def grid_coordinates(n: int) -> np.ndarray:
    """The n + 1 grid coordinates i/n, i = 0..n (each correctly rounded)."""
    n = _positive(n, "n")
    return np.arange(n + 1, dtype=np.float64) / n


def _positive(n, name):
    if int(n) != n or n < 1:
        raise ValueError(f"{name} must be a positive integer, got {n!r}")
    return int(n)


# -- 2D -------------------------------------------------------------------------------
def square_grid(n: int):
    """The unit square as an n×n grid, each square split into two triangles along its
    y = x diagonal. Vertex (i, j) (x index i, y index j) has id i + (n + 1)·j."""
    x = grid_coordinates(n)
    X, Y = np.meshgrid(x, x, indexing="xy")
    points = np.stack([X.ravel(), Y.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    v00 = (i + (n + 1) * j).ravel()
    v10, v01, v11 = v00 + 1, v00 + n + 1, v00 + n + 2
    cells = np.concatenate([np.stack([v00, v10, v11], 1), np.stack([v00, v11, v01], 1)])
    return points, cells.astype(np.int64)


def _polyline(points, closed=False):
    k = len(points)
    a = np.arange(k if closed else k - 1)
    return np.asarray(points, dtype=np.float64), np.stack([a, (a + 1) % k], 1).astype(np.int64)


def circle_polygon(segments: int = 64, center=(0.5, 0.5), radius: float = 0.37):
    """A closed polygon with ``segments`` vertices on a circle."""
    segments = _positive(segments, "segments")
    t = 2 * np.pi * np.arange(segments) / segments
    c, s = cos_sin(t)  # correctly rounded: the same polygon on every machine
    pts = np.stack([center[0] + radius * c, center[1] + radius * s], 1)
    return _polyline(pts, closed=True)


def diagonal_cut(n: int, step: int = 1):
    """The diagonal y = x from (0, 0) to (1, 1), a vertex every ``step`` grid vertices
    (``n`` divisible by ``step``): its segments lie on the mesh's diagonal edges, and
    with ``step`` > 1 pass through grid vertices."""
    n, step = _positive(n, "n"), _positive(step, "step")
    if n % step:
        raise ValueError(f"n = {n} is not a multiple of step = {step}")
    x = grid_coordinates(n)[::step]
    return _polyline(np.stack([x, x], 1))


def zigzag_cut(n: int, dx: int = 1, dy: int = 1, j0: int | None = None,
               offset: bool = False):
    """A zig-zag through grid vertices: x index 0, dx, 2dx, ..., y index alternating
    j0, j0 + dy. With gcd(dx, dy) > 1 each segment also passes through grid vertices.
    ``offset=True`` moves every vertex half a cell along x, onto the midpoints of the
    grid's horizontal edges (cut vertices exactly on simulation edges)."""
    n, dx, dy = _positive(n, "n"), _positive(dx, "dx"), _positive(dy, "dy")
    j0 = (n - dy) // 2 if j0 is None else int(j0)
    if j0 < 0 or j0 + dy > n:
        raise ValueError(f"zig-zag rows {j0}..{j0 + dy} leave the {n}×{n} grid")
    y = grid_coordinates(n)
    ii = np.arange(0, n + (0 if offset else 1), dx)
    x = (2 * ii + 1) / (2 * n) if offset else y[ii]
    jj = np.where(np.arange(len(ii)) % 2 == 0, j0, j0 + dy)
    return _polyline(np.stack([x, y[jj]], 1))


# -- 3D -------------------------------------------------------------------------------
#: Kuhn/Freudenthal: one tetrahedron per permutation of the axes, along the path
#: 0 → e_p0 → e_p0 + e_p1 → (1, 1, 1). Every cube face is split along the diagonal
#: through the cube's (0,0,0)–(1,1,1) corners' projections, so the mesh is conforming.
_KUHN = []
for _p in itertools.permutations(range(3)):
    _c = np.zeros(3, dtype=int)
    _path = [tuple(_c)]
    for _ax in _p:
        _c[_ax] += 1
        _path.append(tuple(_c))
    _KUHN.append(_path)


def cube_grid(n: int):
    """The unit cube as an n×n×n grid of cubes, six tetrahedra each (Kuhn). Vertex
    (i, j, k) has id i + (n + 1)·(j + (n + 1)·k)."""
    n = _positive(n, "n")
    x = grid_coordinates(n)
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    points = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    k, j, i = (a.ravel() for a in np.meshgrid(*(np.arange(n),) * 3, indexing="ij"))
    m = n + 1

    def vid(di, dj, dk):
        return (i + di) + m * ((j + dj) + m * (k + dk))

    cells = np.concatenate([np.stack([vid(*c) for c in path], 1) for path in _KUHN])
    return points, cells.astype(np.int64)


def _grid_triangles(nx: int, ny: int):
    """Triangles of an (nx+1)×(ny+1) vertex grid, split like the Kuhn cube faces."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy"))
    v00 = i + (nx + 1) * j
    v10, v01, v11 = v00 + 1, v00 + nx + 1, v00 + nx + 2
    return np.concatenate([np.stack([v00, v10, v11], 1),
                           np.stack([v00, v11, v01], 1)]).astype(np.int64)


def grid_plane(n: int, k: int | None = None, offset: bool = False):
    """The plane z = k/n across the unit cube, triangulated.

    ``offset=False``: vertices on the (n + 1)² grid vertices of that plane, triangles
    split like the cube faces (every cut primitive coincides with a simulation one).
    ``offset=True``: vertices at the n² cell centres ((i + ½)/n, (j + ½)/n, k/n), still
    exactly in the plane z = k/n: they lie on the grid's face diagonals.
    """
    n = _positive(n, "n")
    k = n // 2 if k is None else int(k)
    if not 0 <= k <= n:
        raise ValueError(f"k must be in 0..{n}, got {k}")
    z = grid_coordinates(n)[k]
    if offset:
        if n < 2:
            raise ValueError("the offset plane needs n >= 2")
        x = (2 * np.arange(n, dtype=np.float64) + 1) / (2 * n)
        nx = n - 1
    else:
        x = grid_coordinates(n)
        nx = n
    X, Y = np.meshgrid(x, x, indexing="xy")
    pts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z)], 1)
    return pts, _grid_triangles(nx, nx)


def icosphere(subdivisions: int = 2, center=(0.5, 0.5, 0.5), radius: float = 0.37):
    """A triangulated sphere: the icosahedron, each triangle split in four
    ``subdivisions`` times (20·4^s triangles), vertices projected onto the sphere."""
    s = int(subdivisions)
    if s < 0 or s != subdivisions:
        raise ValueError(f"subdivisions must be a non-negative integer, got {subdivisions!r}")
    t = (1 + math.sqrt(5.0)) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
                 dtype=np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    v = unit_rows(v)
    for _ in range(s):
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        e.sort(axis=1)
        ue, inv = unique_rows(e, len(v))  # np.unique(e, axis=0, ...)'s rows and map
        mid = v[ue[:, 0]] + v[ue[:, 1]]
        mid = unit_rows(mid)
        m = len(v) + inv.reshape(3, -1)  # midpoints of edges 01, 12, 20 per face
        v = np.concatenate([v, mid])
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        f = np.concatenate([np.stack([a, m[0], m[2]], 1), np.stack([b, m[1], m[0]], 1),
                            np.stack([c, m[2], m[1]], 1), np.stack([m[0], m[1], m[2]], 1)])
    return np.asarray(center, dtype=np.float64) + radius * v, f


# -- named examples -------------------------------------------------------------------
def example(name: str, n: int = 8, **kw):
    """A named example: ``{"sim": (points, cells), "cut": (points, cells), "dim": d}``.

    2D: ``"circle"`` (``segments=``), ``"diagonal"`` (``step=``), ``"zigzag"`` (``dx=``,
    ``dy=``, ``offset=``); 3D: ``"sphere"`` (``subdivisions=``), ``"plane"`` (``k=``),
    ``"plane_offset"`` (``k=``).
    """
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; choose from {', '.join(EXAMPLES)}")
    dim, make_sim, make_cut = EXAMPLES[name]
    return {"dim": dim, "sim": make_sim(n), "cut": make_cut(n, **kw)}


EXAMPLES = {
    "circle": (2, square_grid, lambda n, segments=64, **kw: circle_polygon(segments, **kw)),
    "diagonal": (2, square_grid, lambda n, step=1: diagonal_cut(n, step)),
    "zigzag": (2, square_grid,
               lambda n, dx=1, dy=1, j0=None, offset=False: zigzag_cut(n, dx, dy, j0, offset)),
    "sphere": (3, cube_grid, lambda n, subdivisions=2, **kw: icosphere(subdivisions, **kw)),
    "plane": (3, cube_grid, lambda n, k=None: grid_plane(n, k, offset=False)),
    "plane_offset": (3, cube_grid, lambda n, k=None: grid_plane(n, k, offset=True)),
}
