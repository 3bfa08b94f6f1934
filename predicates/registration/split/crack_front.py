"""Filling a region around a crack front (docs/split.md, "The conforming
tetrahedralization"): a cell with a partial slit — the cut ends inside it, so the two
sides of its cut polygons are distinct boundary triangles with the same points and
opposite orientations, joined along the front. No cone from one apex fills it (of two
twin triangles, one cone simplex is negative or flat whatever the apex), and a search
over ear tetrahedra from boundary points alone may find none (the material beyond the
front is a thin wedge seen by no boundary point).

Two interior points are added, p₊ above the crack's plane Π and p₋ below it, both over
a point x₀ of Π beyond the front (the uncut part of the cell's section). The boundary S
is split into T₊ (the upper side of the slit and the boundary triangles whose centroid
lies above Π) and T₋ (the rest), and filled by

- the cone from p₊ over T₊ and the cone from p₋ over T₋, and
- for each edge (x, y) of the loop ∂T₊ (the front, then around the cell near Π), the
  bridge tetrahedron (x, p₊, y, p₋), which closes the two cones' side faces.

As chains these simplices have boundary S; the caller keeps them only if every one has
positive exact orientation (``predicates.classic``'s filtered orient3d on the stored,
rounded coordinates) and their faces pair up to exactly S (:func:`~.search.paired`): a
complex of positive tetrahedra with paired faces covers the region once, the slit's two
sides included. The geometry here only proposes x₀ and the heights (a few candidates
from the front's edges); it decides nothing.

Two other shapes of front. A front running inside the cell from face to face along an
arc no point of the uncut part sees (the disc of radius h/2 in Kuhn 4): the front is
closed by a path on the cell's faces, the boundary split into the two sides of that loop
(:func:`_sides_of`), and the region cut by the fan from a point of the path
(:func:`_along_paths`). A closed front (a crack entirely inside the cell, its region
joined to the cell's by :func:`merge_floating`): a bipyramid over the crack and the shell
around it (:func:`_floating_fill`). docs/split.md, "Regions around a crack front".
"""
from __future__ import annotations

from collections import Counter

import numpy as np

__all__ = ["PEELS", "crack_front_fill", "merge_floating", "slit_twins"]

#: the parts of a region peeled at most in the last pass (each may cost a second)
PEELS = 8


def _canon(face) -> tuple:
    """A face up to rotation, orientation kept: a triangle's cyclic rotations are one
    face; a directed segment (2D) is its own key (its rotation is its reversal)."""
    if len(face) == 2:
        return tuple(face)
    k = face.index(min(face))
    return tuple(face[k:]) + tuple(face[:k])


def slit_twins(tris) -> list:
    """Indices of the boundary triangles whose reverse is also a boundary triangle (the
    two sides of a slit)."""
    keys = Counter(_canon(tuple(t)) for t in tris)
    return [i for i, t in enumerate(tris) if keys[_canon(tuple(t)[::-1])] > 0]


def merge_floating(tris_of: dict) -> dict:
    """The regions of one cell {region: outward triangles} with a crack entirely inside
    the cell — a region bounded only by the two sides of a slit (zero volume, no cone
    fills it) — joined to the region around it, when the cell has exactly one other
    region (then that one holds it). Unchanged otherwise (a refusal names the cell)."""
    floating = [f for f, t in tris_of.items()
                if t and len(slit_twins([tuple(x) for x in t])) == len(t)]
    solid = [f for f in tris_of if f not in floating]
    if not floating or len(solid) != 1:
        return tris_of
    return {solid[0]: list(tris_of[solid[0]]) + [t for f in floating for t in tris_of[f]]}


def _normals(tris, Z: np.ndarray) -> np.ndarray:
    P = Z[np.array(tris, dtype=np.int64)]
    return np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])


def _front_edges(tris, twins: set, lower: list) -> list:
    """Directed edges (a, b, c) of the lower side's triangles (a, b, c) that lie on the
    front: used by exactly two boundary triangles, both sides of the slit."""
    uses = Counter(frozenset(e) for t in tris
                   for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])))
    users: dict = {}
    for i, t in enumerate(tris):
        for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            users.setdefault(frozenset(e), []).append(i)
    out = []
    for i in lower:
        t = tris[i]
        for k in range(3):
            a, b, c = t[k], t[(k + 1) % 3], t[(k + 2) % 3]
            key = frozenset((a, b))
            if uses[key] == 2 and all(j in twins for j in users[key]):
                out.append((a, b, c))
    return out


def _tets(tris, upper: np.ndarray, hi: int, mid: int, lo: int) -> list:
    """The two cones and the bridge tetrahedra (module docstring) for the split of the
    boundary into T₊ = tris[upper] and T₋ = the rest."""
    tets = [(t[2], t[1], t[0], hi if up else lo) for t, up in zip(tris, upper.tolist())]
    edges = Counter((t[k], t[(k + 1) % 3]) for t, up in zip(tris, upper.tolist()) if up
                    for k in range(3))
    loop = [e for e, m in edges.items() for _ in range(m - edges.get(e[::-1], 0))]
    return tets + [s for x, y in loop if mid not in (x, y)
                   for s in ((x, hi, y, mid), (x, mid, y, lo))]


def _plausible(tets, Z: np.ndarray) -> bool:
    """Every tetrahedron's float orientation positive (a cheap screen before the
    caller's exact check: it only rejects)."""
    P = Z[np.array(tets, dtype=np.int64)]
    E = P[:, 1:] - P[:, :1]
    return bool(np.all((E[:, 0] * np.cross(E[:, 1], E[:, 2])).sum(axis=1) > 0))


def _section(tris, Z: np.ndarray, n, level: float, tol: float, twins: set):
    """The points where the non-slit boundary edges cross Π strictly (the section of the
    cell beyond the front, Q, apart from the front itself)."""
    dist = {p: float((Z[p] * n).sum()) - level for t in tris for p in t}
    out = []
    for e in {frozenset((t[k], t[(k + 1) % 3])) for i, t in enumerate(tris)
              if i not in twins for k in range(3)}:
        a, b = sorted(e)
        if (dist[a] > tol and dist[b] < -tol) or (dist[a] < -tol and dist[b] > tol):
            s = dist[a] / (dist[a] - dist[b])
            out.append(Z[a] + s * (Z[b] - Z[a]))
    return out, dist


def _apexes(front, tris, Z, n, level: float, twins: set):
    """Candidate (p₊, x₀, p₋): x₀ on Π among means of the front's points and the
    section's crossings (inside Q), p± on the segments from x₀ to the mean of the
    boundary points above / below Π (inside the convex parts of the cell on either side
    of Π when x₀ is in the cell)."""
    pts = np.array(sorted({p for t in tris for p in t}), dtype=np.int64)
    extent = float((Z[pts].max(axis=0) - Z[pts].min(axis=0)).max())
    tol = 1e-9 * extent
    cross, dist = _section(tris, Z, n, level, tol, twins)
    above = [p for p, d in dist.items() if d > tol]
    below = [p for p, d in dist.items() if d < -tol]
    if not cross or not above or not below:
        return
    top, bottom = Z[above].sum(axis=0) / len(above), Z[below].sum(axis=0) / len(below)
    fpts = sorted({p for e in front for p in e[:2]})
    fmean = Z[fpts].sum(axis=0) / len(fpts)
    cmean = np.sum(cross, axis=0) / len(cross)
    allm = (fmean * len(fpts) + cmean * len(cross)) / (len(fpts) + len(cross))
    centres = [allm, 0.5 * (fmean + cmean)]
    # Q may be a sliver near one front edge (the front passing close to a cell edge)
    centres += [(Z[a] + Z[b] + x) / 3.0 for a, b, _ in front for x in cross]
    for frac in (0.5, 0.2, 0.05):
        for x0 in centres:
            x0 = x0 - ((x0 * n).sum() - level) * n
            yield x0 + frac * (top - x0), x0, x0 + frac * (bottom - x0)


def crack_front_fill(tris, Y, checked, fill_part, thorough: bool = False):
    """Tetrahedra filling the closed outward boundary ``tris`` (ids into the growing
    point set ``Y``) of a region with a partial slit, with interior points appended to
    ``Y``; None when the region has no slit with a front or no candidate passes
    ``checked(tets)`` (the caller's exact check). ``fill_part(boundary, thorough)``: the
    caller's filling of a closed boundary without a slit (cheap ones only unless
    ``thorough``), or None; ``thorough``: only the split, its parts filled thoroughly
    (the caller tries the cheap candidates first, then its own fillings of the whole
    region, then this). Points appended for a failed
    candidate may stay in ``Y`` unused (the mesh keeps only the points its simplices
    use)."""
    tris = [tuple(int(v) for v in t) for t in tris]
    twins = slit_twins(tris)
    if not twins:
        return None
    Z = Y.array
    N = _normals([tris[i] for i in twins], Z)
    along = (N * N[0]).sum(axis=1) > 0
    lower = [i for i, a in zip(twins, along.tolist()) if a]  # outward along n: material below
    n = N[along].sum(axis=0)
    n = n / np.sqrt((n * n).sum())
    front = _front_edges(tris, set(twins), lower)
    if not front:
        return None
    if not _front_ends(front):  # a crack entirely inside the cell
        return _floating_fill(tris, twins, lower, Y, n, fill_part, checked)
    on_slit = np.array(sorted({p for i in twins for p in tris[i]}), dtype=np.int64)
    level = float((Z[on_slit] * n).sum(axis=1).mean())
    cen = Z[np.array(tris, dtype=np.int64)].sum(axis=1) / 3.0
    upper = (cen * n).sum(axis=1) >= level
    upper[lower] = False
    upper[[i for i in twins if i not in set(lower)]] = True
    cands = list(_apexes(front, tris, Z, n, level, set(twins)))
    centres = [pm for _, pm, _ in cands[:3]]
    if thorough:  # peeling is the cost of a refusal: at most PEELS parts each way
        found = _along_paths(tris, twins, upper, front, Y, _limited(fill_part), checked,
                             True)
        return found if found is not None else _split_fill(
            tris, upper, Y, centres, _limited(fill_part), checked, (True,))
    for ph, pm, pl in cands:  # the surface between the cones a fan from x₀ in Q
        hi, mid, lo = Y.append(ph), Y.append(pm), Y.append(pl)
        tets = _tets(tris, upper, hi, mid, lo)
        found = checked(tets) if _plausible(tets, Y.array) else None
        if found is not None:
            return found
        for _ in range(3):
            Y.pop()
    found = _split_fill(tris, upper, Y, centres, fill_part, checked, (False,))
    return found if found is not None else _along_paths(
        tris, twins, upper, front, Y, fill_part, checked, False)


def _along_paths(tris, twins, upper, front, Y, fill_part, checked, thorough: bool):
    """The region split along the front closed by a path on the cell's faces
    (:func:`_path_sides`), by the fan from each inner point of the path; the parts
    filled by ``fill_part`` (peeled only if ``thorough``)."""
    for sides, path in _path_sides(tris, twins, upper, front):
        found = _split_fill(tris, sides, Y, [], fill_part, checked, (thorough,), path[1:-1])
        if found is not None:
            return found
    return None


def _limited(fill_part):
    """``fill_part`` refusing after :data:`PEELS` calls (each may peel: about a second)."""
    left = [PEELS]

    def peeled(part, thorough: bool):
        left[0] -= 1
        return fill_part(part, thorough) if left[0] >= 0 else None

    return peeled


def _split_fill(tris, upper: np.ndarray, Y, centres: list, fill_part, checked, passes,
                apexes=None):
    """The region split by a fan D from a point of Q (an interior point x₀, or a point
    of the loop ∂T₊: a front passing close to a cell edge leaves Q a sliver around which
    no two apexes see D), the two parts — without a slit — filled by ``fill_part``."""
    up = upper.tolist()
    edges = Counter((t[k], t[(k + 1) % 3]) for t, u in zip(tris, up) if u for k in range(3))
    loop = [e for e, m in edges.items() for _ in range(m - edges.get(e[::-1], 0))]
    mids = [Y.append(x0) for x0 in centres] + (
        sorted({p for e in loop for p in e}) if apexes is None else list(apexes))
    for thorough in passes:
        for mid in mids:
            disc = [(x, mid, y) for x, y in loop if mid not in (x, y)]
            above = fill_part([t for t, u in zip(tris, up) if u] + disc, thorough)
            below = None if above is None else fill_part(
                [t for t, u in zip(tris, up) if not u] + [d[::-1] for d in disc], thorough)
            found = None if below is None else checked(above + below)
            if found is not None:
                return found
    return None


def _front_ends(front) -> list:
    """The ends of the front polyline (points on one front edge): where it meets the
    cell's boundary. Empty for a closed front (a crack entirely inside the cell)."""
    deg = Counter(p for e in front for p in e[:2])
    return sorted(p for p, k in deg.items() if k == 1)


def _boundary_paths(tris, twins: set, a: int, b: int, longest: int = 4) -> list:
    """Simple paths from a to b along edges of the boundary triangles that are not
    sides of the slit (the cell's faces), shortest first, at most ``longest`` edges."""
    nbr: dict = {}
    for i, t in enumerate(tris):
        if i not in twins:
            for k in range(3):
                x, y = t[k], t[(k + 1) % 3]
                nbr.setdefault(x, set()).add(y)
                nbr.setdefault(y, set()).add(x)
    out, todo = [], [[a]]
    while todo:
        path = todo.pop(0)
        for q in sorted(nbr.get(path[-1], ())):
            if q == b:
                out.append(path + [q])
            elif q not in path and len(path) < longest:
                todo.append(path + [q])
    return out


def _sides_of(tris, twins: set, cut: set, upper_twins: set):
    """(T,) bool: the boundary triangles on the upper side of the surface made of the
    slit and a loop ``cut`` (undirected edges): triangles joined across every other edge
    they share with opposite directions — at a chord (an edge of a face and of the slit,
    four uses) a face triangle to the slit side running it the other way. None unless
    this splits the boundary in two, the slit's upper side in one part."""
    uses: dict = {}
    for i, t in enumerate(tris):
        for k in range(3):
            x, y = t[k], t[(k + 1) % 3]
            uses.setdefault(frozenset((x, y)), []).append((i, x))
    parent = list(range(len(tris)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for e, us in uses.items():
        if e in cut:
            continue
        chord = any(i not in twins for i, _ in us) and any(i in twins for i, _ in us)
        for i, x in us:
            other = [j for j, y in us if y != x and set(tris[j]) != set(tris[i])
                     and (not chord or (j in twins) != (i in twins))]
            if len(us) not in (2, 4) or len(other) != 1:
                return None
            parent[root(i)] = root(other[0])
    lab = [root(i) for i in range(len(tris))]
    up = {lab[i] for i in upper_twins}
    if len(set(lab)) != 2 or len(up) != 1:
        return None
    return np.array([x in up for x in lab], dtype=bool)


def _path_sides(tris, twins, upper: np.ndarray, front) -> list:
    """Splits of the boundary (:func:`_sides_of`) by the front closed through the cell's
    faces along a path between its ends (a front whose arc no single point of the uncut
    part sees, the crack inside one cell: docs/split.md, "Regions around a crack
    front")."""
    ends = _front_ends(front)
    if len(ends) != 2:
        return []
    tw = set(twins)
    front_edges = {frozenset(e[:2]) for e in front}
    upper_twins = {i for i in twins if upper[i]}
    out = []
    for path in _boundary_paths(tris, tw, ends[0], ends[1]):
        cut = front_edges | {frozenset(e) for e in zip(path, path[1:])}
        sides = _sides_of(tris, tw, cut, upper_twins)
        if sides is not None and not any(np.array_equal(sides, s) for s, _ in out):
            out.append((sides, path))
    return out


def _floating_fill(tris, twins: list, lower: list, Y, n: np.ndarray, fill_part, checked):
    """A crack entirely inside the cell (a closed front): a bipyramid over it, the cones
    from p₊ just above the crack over its upper side and from p₋ below over its lower
    side, and the shell between the bipyramid and the rest of the boundary filled by
    ``fill_part`` (no slit left: its boundary is the cell's faces and the bipyramid's
    side faces, reversed) by a cone or fan, else the backtracking search (:mod:`~.search`;
    the caller checks the whole exactly)."""
    from predicates.registration.split.search import _apply, _canon as canon, search_fill

    Z = Y.array
    on_slit = np.array(sorted({p for i in twins for p in tris[i]}), dtype=np.int64)
    centre = Z[on_slit].sum(axis=0) / len(on_slit)
    size = float(np.sqrt(((Z[on_slit] - centre) ** 2).sum(axis=1).max()))
    low = set(lower)
    for frac in (0.2, 0.05, 0.5):
        hi, lo = Y.append(centre + frac * size * n), Y.append(centre - frac * size * n)
        cones = [(t[2], t[1], t[0], lo if i in low else hi)
                 for i, t in enumerate(tris) if i in set(twins)]
        shell = Counter(canon(tuple(t)) for t in tris)
        for tet in cones:
            shell = _apply(shell, tet)[0]
        shell = [t for t, m in shell.items() for _ in range(m)]
        rest = fill_part(shell, False) or search_fill(shell, Y.array, budget=400)
        found = None if rest is None else checked(cones + rest)
        if found is not None:
            return found
        Y.pop()
        Y.pop()
    return None
