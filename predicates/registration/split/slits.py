"""The regions of a cell's faces with crack fronts (docs/split.md, "The conforming
tetrahedralization"): part 1's face regions (:mod:`~predicates.registration.split.
regions`) split a face by chord chains running from its boundary to its boundary; where
the cut ends inside the face (a crack front crossing it) a chain ends at a point inside
the face. Such a dangling chain is kept as a *slit* of the region it starts in: the
region's cycle runs along the chain to its end and back (… b, p₁, …, p_k, …, p₁, b …),
so the cut polygons on the crack meet the face along edges of the face's triangles while
the material around the front stays one region. A chain with both ends inside the
face (the front crossing the face twice, a disc of radius 1.2 h at Kuhn 4) is bridged to
the face's region from a corner that sees it (:func:`_bridge`)."""
from __future__ import annotations

from predicates.registration.split.polytri import det_sign
from predicates.registration.split.regions import Unresolved, _path, _split

__all__ = ["face_regions"]


def _chains(cycle, chords):
    """Full chains (boundary to boundary) and dangling ones (boundary to inside)."""
    bset = set(cycle)
    nxt = {a: b for a, b in zip(cycle, cycle[1:] + cycle[:1])}
    adj: dict = {}
    for a, b in chords:
        if nxt.get(a) == b or nxt.get(b) == a:
            continue
        adj.setdefault(a, set()).add(b)
        adj.setdefault(b, set()).add(a)
    used, full, dangling, floating = set(), [], [], []
    for p in cycle:
        for nb in sorted(adj.get(p, ()), key=repr):
            if frozenset((p, nb)) in used:
                continue
            used.add(frozenset((p, nb)))
            line, cur = [p], nb
            while cur not in bset:
                line.append(cur)
                rest = [x for x in adj[cur] if frozenset((cur, x)) not in used]
                if len(rest) > 1:
                    raise Unresolved("a chord chain branches inside a face")
                if not rest:
                    break
                used.add(frozenset((cur, rest[0])))
                cur = rest[0]
            else:
                full.append(line + [cur])
                continue
            dangling.append(line)
    for p in sorted(adj, key=repr):  # a chain with both ends inside the face
        free = [x for x in adj[p] if frozenset((p, x)) not in used]
        if len(free) != 1 or any(frozenset((p, x)) not in used for x in adj[p] - {free[0]}):
            continue
        line, cur = [p], p
        while True:
            rest = sorted((x for x in adj[cur] if frozenset((cur, x)) not in used), key=repr)
            if not rest:
                break
            used.add(frozenset((cur, rest[0])))
            cur = rest[0]
            line.append(cur)
        floating.append(line)
    if sum(len(v) for v in adj.values()) != 2 * len(used):
        raise Unresolved("a closed chord chain inside a face")
    return full, dangling, floating


def _insert(regions, line):
    b = line[0]
    holders = [r for r in regions if b in r]
    if len(holders) != 1 or holders[0].count(b) != 1:
        raise Unresolved("a crack front chain from a point shared by several regions")
    r = holders[0]
    i = r.index(b)
    r[i + 1:i + 1] = line[1:] + line[-2::-1]


def _weights(nd, frame: list, cs) -> tuple:
    """A node's barycentric weights on the face's frame (sorted vertex ids)."""
    out = [0.0, 0.0, 0.0]
    if nd[0] == "v":
        out[frame.index(nd[1])] = 1.0
        return tuple(out)
    for i, w in zip(cs.sim[nd[1]].tolist(), cs.sim_weights[nd[1]].tolist()):
        if i >= 0:
            out[frame.index(i)] += float(w)
    return tuple(out)


def _clear(b, e, chords, w) -> bool:
    """The bridge segment b–e meets no chord of the face except at e, by exact signs in
    the frame (conservative: touching or collinear counts as meeting)."""
    for x, y in chords:
        if b in (x, y) or e in (x, y):
            o = y if x in (b, e) else x
            if o not in (b, e) and det_sign(w[b], w[e], w[o]) == 0:
                return False
            continue
        d1, d2 = det_sign(w[b], w[e], w[x]), det_sign(w[b], w[e], w[y])
        d3, d4 = det_sign(w[x], w[y], w[b]), det_sign(w[x], w[y], w[e])
        if d1 * d2 <= 0 and d3 * d4 <= 0:
            return False
    return True


def _bridge(region: list, line: list, chords, frame: list, cs) -> None:
    """Join a chain floating inside the face (both ends on the crack front: the front
    crosses the face twice) to the region by a bridge from a face corner to one of the
    chain's ends, walked there and back like a slit: the first (corner by id, then end
    by node) whose segment meets no chord of the face, decided by exact signs in the
    face's frame. Depends only on the face's shared data, so both cells of the face get
    the same cycle up to orientation, hence the same triangles."""
    nodes = {nd for ch in chords for nd in ch} | set(region)
    w = {nd: _weights(nd, frame, cs) for nd in nodes}
    for b in sorted((nd for nd in region if nd[0] == "v"), key=lambda nd: nd[1]):
        for e in sorted((line[0], line[-1]), key=repr):
            if _clear(b, e, chords, w):
                seq = line if e == line[0] else line[::-1]
                i = region.index(b)
                region[i + 1:i + 1] = seq + seq[-2::-1] + [b]
                return
    raise Unresolved("a crack front chain inside a face that no corner of it sees")


def face_regions(corners, on_cut, T, polys, faces, cs) -> list:
    """The node cycles of the regions of every face (outward), slits included."""
    out = []
    for face in faces:
        fverts = frozenset(corners[k] for k in face)
        cycle = []
        for i, k in enumerate(face):
            cycle += _path(corners[k], corners[face[(i + 1) % 3]], on_cut, T)
        chords = []
        for P in polys:
            for a, b in zip(P, P[1:] + P[:1]):
                pa = T.prim[a[1]] if a[0] == "h" else {a[1]}
                pb = T.prim[b[1]] if b[0] == "h" else {b[1]}
                if pa | pb <= fverts:
                    chords.append((a, b))
        full, dangling, floating = _chains(cycle, chords)
        regions = _split(cycle, full)
        for line in dangling:
            _insert(regions, line)
        for line in floating:
            if len(regions) != 1:
                raise Unresolved("a crack front chain floating in a face split by the cut")
            _bridge(regions[0], line, chords, sorted(fverts), cs)
        out += regions
    return out
