"""The boundary of every fragment of one split cell, combinatorially (docs/split.md,
"Volumes and moments"; the rules in :mod:`~predicates.registration.split.volume`): the
regions of the cell's faces cut by the chords of the cut polygons, each given to the
fragment of its off-cut corners, and the cut polygons with the side each bounds.
Nodes are ("v", vertex) for off-cut corners and ("h", point) for registered points.
Raises :class:`Unresolved` where the rules do not apply."""
from __future__ import annotations

__all__ = ["Unresolved", "cell_pieces"]


CROSSING = ("the cut crosses itself in a face (two chains of cut chords cross, or one "
            "returns to its start): the cutting surface meets itself or another of its "
            "sheets inside the cell, at a point no registered pair gives; cut with one "
            "sheet, then cut the conforming mesh again with the other (fperr cut --then, "
            "split.progressive.recut)")


class Unresolved(Exception):
    """The cell's fragments cannot be given their own boundaries."""


def _pairs(cycle):
    return zip(cycle, cycle[1:] + cycle[:1])


def _prim(node, T):
    return frozenset((node[1],)) if node[0] == "v" else T.prim[node[1]]


def _node(v, on_cut, T):
    return ("h", T.vertex_hit[v]) if on_cut[v] else ("v", v)


def _path(a, b, on_cut, T):
    """The nodes of edge a→b: a, its registered points in order, not b."""
    return [_node(a, on_cut, T)] + [("h", h) for h in T.edge(a, b)]


def _polylines(cycle, chords):
    """Chain the chords of a face through its inner nodes into polylines from one node
    of the boundary cycle to another (undirected)."""
    bset = set(cycle)
    nxt = {a: b for a, b in _pairs(cycle)}
    adj: dict = {}
    for a, b in chords:
        if nxt.get(a) == b or nxt.get(b) == a:
            continue  # a chord along the face's boundary splits nothing
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    used, lines = set(), []
    for p in cycle:
        for nb in adj.get(p, []):
            if frozenset((p, nb)) in used:
                continue
            used.add(frozenset((p, nb)))
            line, cur = [p], nb
            while cur not in bset:
                line.append(cur)
                rest = [x for x in adj[cur] if frozenset((cur, x)) not in used]
                if len(rest) != 1:
                    raise Unresolved("a chord chain ends or branches inside a face")
                used.add(frozenset((cur, rest[0])))
                cur = rest[0]
            lines.append(line + [cur])
    if sum(len(v) for v in adj.values()) != 2 * len(used):
        raise Unresolved("a closed chord chain inside a face")
    return lines


def _split(cycle, lines):
    regions = [list(cycle)]
    for line in lines:
        p, q = line[0], line[-1]
        for k, r in enumerate(regions):
            if p in r and q in r and p != q:
                i, j = r.index(p), r.index(q)
                pq = r[i:j + 1] if i < j else r[i:] + r[:j + 1]
                qp = r[j:i + 1] if j < i else r[j:] + r[:i + 1]
                inner = line[1:-1]
                regions[k:k + 1] = [pq + inner[::-1], qp + inner]
                break
        else:
            # another chain separates p from q along the face's boundary: the chains
            # cross at a point no registered pair gives (two sheets of the cut meet)
            raise Unresolved(CROSSING)
    return regions


def _owner(region, frag):
    """The fragment of a region's off-cut corners; None for a region with none (material
    the virtual-node split gives no fragment of this cell: an edge crossed twice)."""
    f = {frag[n[1]] for n in region if n[0] == "v"}
    if len(f) > 1:
        raise Unresolved("a face region with corners of several fragments")
    return f.pop() if f else None


def _sides(polys, owner):
    """[front, back] fragment of every polygon (None where unknown): from the regions
    along its chords, then across the edges it shares with other polygons."""
    side = [[None, None] for _ in polys]
    by_edge = {}
    for i, P in enumerate(polys):
        for a, b in _pairs(P):
            by_edge[a, b] = i
            for k, e in ((0, (a, b)), (1, (b, a))):
                if side[i][k] is None and e in owner:
                    side[i][k] = owner[e]
    todo = [i for i, s in enumerate(side) if s != [None, None]]
    while todo:
        i = todo.pop()
        for a, b in _pairs(polys[i]):
            j = by_edge.get((b, a))
            if j is None:
                continue
            new = [x if x is not None else y for x, y in zip(side[j], side[i])]
            if new != side[j]:
                side[j] = new
                todo.append(j)
    return side


def _regions_3d(corners, frag, on_cut, T, polys, faces):
    """The regions of every face, each [owner or None, node cycle, the face's smallest
    vertex]."""
    out = []
    edges = [(a, b, _prim(a, T) | _prim(b, T)) for P in polys for a, b in _pairs(P)]
    for face in faces:
        fverts = frozenset(corners[k] for k in face)
        cycle = []
        for i, k in enumerate(face):
            cycle += _path(corners[k], corners[face[(i + 1) % 3]], on_cut, T)
        chords = [(a, b) for a, b, pr in edges if pr <= fverts]
        apex = min(fverts)
        out += [[_owner(r, frag), r, apex] for r in _split(cycle, _polylines(cycle, chords))]
    return out


def _pieces_3d(corners, frag, on_cut, T, polys, faces):
    """A region with no off-cut corner (beyond an edge crossed twice) takes the side of
    the polygons along its chords — the fragment across the cell's interior — when they
    have one; otherwise it belongs to no fragment."""
    regions = _regions_3d(corners, frag, on_cut, T, polys, faces)
    by_edge = {e: i for i, P in enumerate(polys) for e in _pairs(P)}
    while True:
        owner = {e: f for f, r, _ in regions if f is not None for e in _pairs(r)}
        sides = _sides(polys, owner)
        changed = False
        for reg in regions:
            if reg[0] is not None:
                continue
            for u, w in _pairs(reg[1]):
                if (u, w) in by_edge:
                    reg[0] = sides[by_edge[u, w]][0]  # the region in front
                elif (w, u) in by_edge:
                    reg[0] = sides[by_edge[w, u]][1]  # the region behind
                if reg[0] is not None:
                    changed = True
                    break
        if not changed:
            break
    pieces = [(f, r, apex) for f, r, apex in regions]
    for P, (front, back) in zip(polys, sides):
        if front != back:
            pieces += [(back, P, None), (front, P[::-1], None)]
    return [p for p in pieces if p[0] is not None]


def _pieces_2d(corners, frag, on_cut, T, segs, ring):
    starts, pieces = {}, []
    for i in range(3):
        a, b = corners[ring[i]], corners[ring[(i + 1) % 3]]
        path = _path(a, b, on_cut, T) + [_node(b, on_cut, T)]
        for u, w in zip(path[:-1], path[1:]):
            f = _owner([u, w], frag)
            pieces.append((f, [u, w], None))
            starts[u] = f
    nxt = {}
    for a, b in segs:
        if a in nxt:
            raise Unresolved("two cut segments leave one point")
        nxt[a] = b
    heads = [a for a in nxt if a in starts]
    for p in heads:
        line, cur = [p], nxt[p]
        while cur not in starts and cur in nxt and len(line) <= len(segs):
            line.append(cur)
            cur = nxt[cur]
        if cur not in starts:
            continue  # a crack tip inside one fragment: bounds nothing
        line.append(cur)
        left, right = starts[cur], starts[p]
        if left != right:
            for u, w in zip(line[:-1], line[1:]):
                pieces += [(left, [u, w], None), (right, [w, u], None)]
    return [p for p in pieces if p[0] is not None]


def cell_pieces(corners, frag, on_cut, T, polys, outward):
    """[(fragment, boundary polygon of nodes, apex)] of one split cell; ``apex``: for a
    face region the smallest vertex of its face (None for cut polygons and in 2D), the
    apex both cells on the face triangulate the region from. ``corners``: its
    vertex ids; ``frag``: {off-cut vertex: its fragment}; ``polys``: its cut polygons
    (canonical registered points, cyclic); ``outward``: the faces as corner positions,
    oriented outward (3D), or the counter-clockwise ring of corners (2D)."""
    polys = [[("h", h) for h in P] for P in polys]
    if len(corners) == 3:
        return _pieces_2d(corners, frag, on_cut, T, [tuple(P) for P in polys], outward)
    return _pieces_3d(corners, frag, on_cut, T, polys, outward)
