"""Cutting meshes for the tests of the cut (docs/split.md): surfaces along grid faces
(a box, a square), built on grid vertices with exact float64 coordinates."""
from __future__ import annotations

import numpy as np


def box_surface(n: int, lo: int, hi: int, flip: bool = False):
    """The surface of the box [lo/n, hi/n]³ on the vertices of the n-grid, each unit
    square of its faces split in two along the Kuhn diagonal (``flip``: the other one),
    oriented outward. Returns (points, triangles)."""
    idx = {}
    pts, tris = [], []

    def vid(p):
        if p not in idx:
            idx[p] = len(pts)
            pts.append(p)
        return idx[p]

    m = hi - lo
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for val, outward in ((lo, -1), (hi, 1)):
            for i in range(lo, hi):
                for j in range(lo, hi):
                    q = {}
                    for di in (0, 1):
                        for dj in (0, 1):
                            p = [0, 0, 0]
                            p[axis], p[u], p[v] = val, i + di, j + dj
                            q[di, dj] = vid(tuple(p))
                    a, b, c, d = q[0, 0], q[1, 0], q[1, 1], q[0, 1]
                    two = [(a, b, c), (a, c, d)] if not flip else [(a, b, d), (b, c, d)]
                    # (u, v, axis) is right-handed for axis 0 and 2, left-handed for 1
                    ccw = (outward > 0) == (axis != 1)
                    tris += [t if ccw else t[::-1] for t in two]
    del m
    P = np.array(pts, dtype=np.float64) / n
    return P, np.array(tris, dtype=np.int64)


def square_loop(n: int, lo: int, hi: int):
    """The boundary of the square [lo/n, hi/n]² along grid edges, counter-clockwise."""
    ring = ([(i, lo) for i in range(lo, hi)] + [(hi, j) for j in range(lo, hi)]
            + [(i, hi) for i in range(hi, lo, -1)] + [(lo, j) for j in range(hi, lo, -1)])
    P = np.array(ring, dtype=np.float64) / n
    a = np.arange(len(P))
    return P, np.stack([a, (a + 1) % len(P)], 1)


def gmsh_box_in_box(h: float, inner=(0.25, 0.75)):
    """The unit cube meshed by gmsh with an inner box [a, b]³ (boolean fragment: the
    interface is conforming). Returns (points, tetrahedra, tag per tetrahedron (1 inner,
    0 outer), interface triangles). Needs the gmsh module."""
    import gmsh

    a, b = inner
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("box_in_box")
        outer = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        box = gmsh.model.occ.addBox(a, a, a, b - a, b - a, b - a)
        out, _ = gmsh.model.occ.fragment([(3, outer)], [(3, box)])
        gmsh.model.occ.synchronize()
        vols = [t for dim, t in out if dim == 3]
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        P = coords.reshape(-1, 3).astype(np.float64)
        tets, tag = [], []
        for v in vols:
            _, _, nodes = gmsh.model.mesh.getElements(3, v)
            T = index[np.asarray(nodes[0], dtype=np.int64).reshape(-1, 4)]
            lo, hi = gmsh.model.getBoundingBox(3, v)[:3], gmsh.model.getBoundingBox(3, v)[3:]
            is_inner = max(hi) - min(lo) < 0.99
            tets.append(T)
            tag.append(np.full(len(T), int(is_inner)))
        inner_vol = vols[int(np.argmax([t[0] for t in tag]))]
        faces = [t for dim, t in gmsh.model.getBoundary([(3, inner_vol)], oriented=False)]
        tris = []
        for f in faces:
            _, _, nodes = gmsh.model.mesh.getElements(2, abs(f))
            tris.append(index[np.asarray(nodes[0], dtype=np.int64).reshape(-1, 3)])
        used = np.unique(np.concatenate(tets))
        keep = np.full(len(P), -1, dtype=np.int64)
        keep[used] = np.arange(len(used))
        return (P[used], keep[np.concatenate(tets)], np.concatenate(tag),
                keep[np.concatenate(tris)])
    finally:
        gmsh.finalize()


def gmsh_box(h: float):
    """The unit cube meshed by gmsh with tetrahedra of size ``h``: (points,
    tetrahedra). Needs the gmsh module."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("box")
        v = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        _, _, nodes = gmsh.model.mesh.getElements(3, v)
        T = index[np.asarray(nodes[0], dtype=np.int64).reshape(-1, 4)]
        P = coords.reshape(-1, 3).astype(np.float64)
        used = np.unique(T)
        keep = np.full(len(P), -1, dtype=np.int64)
        keep[used] = np.arange(len(used))
        return P[used], keep[T]
    finally:
        gmsh.finalize()


def torus(m: int = 24, k: int = 12, R: float = 0.3, r: float = 0.12, center=(0.5, 0.5, 0.5)):
    """A closed, outward-oriented triangulated torus (m segments around, k around the
    tube), coordinates from predicates.portable.cos_sin (the same bits everywhere)."""
    from predicates.portable import cos_sin

    cu, su = cos_sin(2 * np.pi * np.arange(m) / m)
    cv, sv = cos_sin(2 * np.pi * np.arange(k) / k)
    i, j = (a.ravel() for a in np.meshgrid(np.arange(m), np.arange(k), indexing="ij"))
    rad = R + r * cv[j]
    P = np.stack([center[0] + rad * cu[i], center[1] + rad * su[i],
                  center[2] + r * sv[j]], axis=1)
    a = i * k + j
    b = ((i + 1) % m) * k + j
    c = ((i + 1) % m) * k + (j + 1) % k
    d = i * k + (j + 1) % k
    T = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return P, T.astype(np.int64)


def tiny_rotation(ulps: int = 2) -> np.ndarray:
    """The rotation by ``ulps`` ulp of 1 radian about (1, 2, 0)/√5 (portable: the same
    bits on every machine): a cut just off the grid's vertices and faces."""
    from predicates.portable import axis_rotation

    return axis_rotation([1.0, 2.0, 0.0], ulps * np.finfo(np.float64).eps)


def about_centre(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The points P rotated by R about the unit cube's centre (portable)."""
    from predicates.portable import rotate

    return rotate(P - 0.5, R) + 0.5


def disc_crack(radius: float, centre, segments: int = 24):
    """A flat disc of radius ``radius`` (a fan of ``segments`` triangles around its
    centre, vertex 0), tilted by a fixed rotation (portable): a crack ending inside the
    mesh."""
    from predicates.portable import cos_sin, rotate, rotation

    c, s = cos_sin(np.arange(segments) * (2.0 * np.pi / segments))
    Q = np.zeros((segments + 1, 3))
    Q[1:, 0], Q[1:, 1] = radius * c, radius * s
    Q = rotate(Q, rotation(3, 7)) + np.asarray(centre)
    K = np.array([[0, 1 + i, 1 + (i + 1) % segments] for i in range(segments)])
    return Q, K


def axis_plane(axis: int, c: float, m: int = 4):
    """The square [−0.1, 1.1]² as m × m × 2 triangles in the plane x_axis = c."""
    u = np.linspace(-0.1, 1.1, m + 1)
    U, V = np.meshgrid(u, u, indexing="xy")
    P = np.zeros((U.size, 3))
    a, b = [k for k in range(3) if k != axis]
    P[:, a], P[:, b], P[:, axis] = U.ravel(), V.ravel(), c
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="xy")
    v = (i + (m + 1) * j).ravel()
    return P, np.concatenate([np.stack([v, v + 1, v + m + 2], 1),
                              np.stack([v, v + m + 2, v + m + 1], 1)])
