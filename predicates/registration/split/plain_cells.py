"""The boundary simplices of the fragments of the *plain* split cells, vectorised over
all of them (docs/split.md, "Volumes and moments"): the same simplices the per-cell
rules of :mod:`~predicates.registration.split.regions` give, without forming the face
regions (2D: :func:`plain_triangle_rows`).

A tetrahedron is plain when no corner lies on the cut, no polygon of the cut lies in a
face, every edge holds at most one registered point and holds one exactly when its two
ends are in two fragments, every chord chain in a face runs from one edge point to
another (each point inside a face on two chords of that face, each edge point on one
chord in each of its two faces), and the cut polygons in the cell form a surface: each
of their edges inside the cell shared by two polygons traversing it both ways. The rest
go through the per-cell rules (at W1 none; the cells with a corner on the cut or an
edge crossed twice, in general).

In a plain cell each face's boundary segment belongs to the fragment of its corner,
and a chord z→p ending at an edge point p (the face's outward cycle running
x→p→y) is traversed by the region owning p→y, so the polygon it belongs to has that
fragment in front and the fragment of x behind; the polygons joined by shared edges
take the same sides (all their chords must agree). A face region is a star from its
face's smallest vertex, one triangle per region edge, so the face is the sum over its
segments (each to its owner) and its chords (a→b to the polygon's front, b→a to its
back), with no region formed. All combinatorial; nothing here is floating point.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.split import rules as R

__all__ = ["plain_cell_rows", "plain_triangle_rows"]

_EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
_EDGE_OF = {frozenset(map(int, e)): i for i, e in enumerate(_EDGES)}
_FACES = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]  # face k: opposite corner k


def _face_cycles(positive: bool) -> np.ndarray:
    """(4, 3, 2) local corners of the outward directed edges of every face."""
    faces = _FACES if positive else [f[::-1] for f in _FACES]
    return np.array([[(f[i], f[(i + 1) % 3]) for i in range(3)] for f in faces])


def _bits(cells_c: np.ndarray, sim_h: np.ndarray) -> np.ndarray:
    """Which corners of each row's cell the row's simulation primitive holds."""
    bits = np.zeros(len(cells_c), dtype=np.int64)
    for k in range(4):
        corner = cells_c[:, k]
        held = corner == sim_h[:, 0]
        for j in range(1, sim_h.shape[1]):
            held |= corner == sim_h[:, j]
        bits |= held.astype(np.int64) << k
    return bits


def _held(cs) -> np.ndarray:
    """(H,) the number of simulation vertices of every point's primitive."""
    out = (cs.sim[:, 0] >= 0).astype(np.int64)
    for j in range(1, cs.sim.shape[1]):
        out += cs.sim[:, j] >= 0
    return out


def _edge_points(cs, cells, cand, n):
    """(C, 6) the registered point inside each local edge of the candidates (−1: none;
    an edge with several is crossed twice, not a candidate)."""
    eh = np.flatnonzero(_held(cs) == 2)
    lo = np.minimum(cs.sim[eh, 0], cs.sim[eh, 1])
    hi = np.maximum(cs.sim[eh, 0], cs.sim[eh, 1])
    key = lo * n + hi
    o = np.argsort(key, kind="stable")
    key, eh = key[o], eh[o]
    c_ids = np.flatnonzero(cand)
    a, b = cells[c_ids][:, _EDGES[:, 0]], cells[c_ids][:, _EDGES[:, 1]]
    want = np.minimum(a, b) * n + np.maximum(a, b)
    i = np.minimum(np.searchsorted(key, want), max(len(key) - 1, 0))
    found = (key[i] == want) if len(key) else np.zeros(want.shape, dtype=bool)
    pts = np.full((len(cells), 6), -1, dtype=np.int64)
    pts[c_ids] = np.where(found, eh[i] if len(key) else -1, -1)
    return pts


def _corner_fragments(sm, start, nfrag, cand, m: int = 4):
    """(C, m) the fragment of every corner of the candidates; marks off a corner in no
    or several fragments."""
    C = len(start)
    f = np.flatnonzero(cand[sm.cell_origin])
    c = sm.cell_origin[f]
    mat = sm.material[f]
    frag = np.full((C, m), -1, dtype=np.int64)
    once = cand.copy()
    for k in range(m):
        frag[c[mat[:, k]], k] = f[mat[:, k]]
        once &= np.bincount(c[mat[:, k]], minlength=C) == 1
    return frag, cand & ~once


def _expand(size: np.ndarray):
    """(group, position) of the rows of groups of sizes ``size``."""
    owner = np.repeat(np.arange(len(size)), size)
    first = np.cumsum(size) - size
    return owner, np.arange(int(size.sum())) - first[owner]


def _polygons(cs, cells, cand):
    """The polygons of the candidates (not lying in a face) as flat vertex rows; marks
    off cells with a point the plain rules do not cover."""
    q = np.flatnonzero(~cs.on_face & cand[cs.cell])
    size = cs.offsets[q + 1] - cs.offsets[q]
    qi, pos = _expand(size)
    h = cs.index[cs.offsets[q][qi] + pos]
    c = cs.cell[q][qi]
    nsim = _held(cs)[h]
    bad = np.zeros(len(cells), dtype=bool)
    bad[c[nsim == 1]] = True
    nxt = np.arange(len(qi)) + np.where(pos == size[qi] - 1, 1 - size[qi], 1)
    return {"q": q, "qc": cs.cell[q], "size": size, "qi": qi, "pos": pos, "h": h, "c": c, "nxt": nxt,
            "bits": _bits(cells[c], cs.sim[h]), "nsim": nsim}, bad


_POP = np.array([bin(m).count("1") for m in range(16)])
_MISSING = np.array([(15 ^ m).bit_length() - 1 if _POP[m] == 3 else -1 for m in range(16)])
_LOW = np.array([(m & -m).bit_length() - 1 if m else -1 for m in range(16)])
_HIGH = np.array([m.bit_length() - 1 for m in range(16)])


def _groups(*cols):
    """Rows sorted by the key columns: (order, group of every sorted row, group sizes)."""
    span = [int(col.max()) + 1 if len(col) else 1 for col in cols]
    if np.prod(np.array(span, dtype=np.float64)) < 2.0 ** 62:  # one int64 key: faster
        key = cols[0].astype(np.int64)
        for col, m in zip(cols[1:], span[1:]):
            key = key * m + col
        o = np.argsort(key, kind="stable")
    else:
        o = np.lexsort(cols[::-1])
    diff = np.zeros(len(o), dtype=bool)
    diff[:1] = True
    for col in cols:
        srt = col[o]
        diff[1:] |= srt[1:] != srt[:-1]
    gid = np.cumsum(diff) - 1
    return o, gid, np.bincount(gid, minlength=int(gid[-1]) + 1 if len(o) else 0)


def _edges(P, C):
    """The polygons' edges: chords (in one face of the cell) and inner edges (shared by
    two polygons traversing them both ways), polygons joined through their inner edges;
    marks off cells where they are not a surface."""
    i, j = np.arange(len(P["h"])), P["nxt"]
    mask = P["bits"][i] | P["bits"][j]
    c, a, b = P["c"], P["h"][i], P["h"][j]
    bad = np.zeros(C, dtype=bool)
    bad[c[_POP[mask] <= 2]] = True
    inner = np.flatnonzero(_POP[mask] == 4)
    lo, hi = np.minimum(a[inner], b[inner]), np.maximum(a[inner], b[inner])
    o, gid, cnt = _groups(c[inner], lo, hi)
    e = inner[o]
    fwd = (a[e] < b[e]).astype(np.int64)
    two = cnt[gid] == 2
    bad[c[e[~two]]] = True
    first = np.flatnonzero(np.diff(np.append(-1, gid)) != 0)
    pair = first[cnt == 2]
    same = fwd[pair] == fwd[pair + 1]
    bad[c[e[pair[same]]]] = True
    root = R.components(len(P["q"]), P["qi"][e[pair]], P["qi"][e[pair + 1]])
    chord = np.flatnonzero(_POP[mask] == 3)
    return {"k": _MISSING[mask[chord]], "a": a[chord], "b": b[chord], "c": c[chord],
            "poly": P["qi"][chord], "bits_a": P["bits"][chord], "bits_b": P["bits"][j[chord]],
            "ns_a": P["nsim"][chord], "ns_b": P["nsim"][j[chord]]}, root, bad


def _chains(ch, C):
    """Marks off cells whose chords do not chain, in every face, from one edge point to
    another through face points (each on two chords of its face; each edge point of
    the cell on one chord in each of its two faces)."""
    bad = np.zeros(C, dtype=bool)
    ends_c = np.concatenate([ch["c"], ch["c"]])
    ends_k = np.concatenate([ch["k"], ch["k"]])
    ends_h = np.concatenate([ch["a"], ch["b"]])
    o, gid, cnt = _groups(ends_c, ends_k, ends_h)
    kind = np.concatenate([ch["ns_a"], ch["ns_b"]])[o]
    want = np.where(kind == 2, 1, 2)
    bad[ends_c[o][(cnt[gid] != want) | ((kind != 2) & (kind != 3))]] = True
    # every edge point of the cell on a chord in each of its two faces
    node_c = ends_c[o][np.flatnonzero(np.diff(np.append(-1, gid)) != 0)]
    node_edge = (kind[np.flatnonzero(np.diff(np.append(-1, gid)) != 0)] == 2)
    have = np.bincount(node_c[node_edge], minlength=C)
    # chains closed inside a face: components of chord ends without an edge point
    m = len(ch["a"])
    node = np.empty_like(gid)
    node[o] = gid  # the node of every chord end, in chord order
    root = R.components(len(cnt), node[:m], node[m:])
    has_edge = np.zeros(len(cnt), dtype=bool)
    has_edge[root[np.flatnonzero(node_edge)]] = True
    bad[node_c[~has_edge[root]]] = True
    return bad, have


def _direction_table() -> np.ndarray:
    """(2, 4, 4, 4) bool: [positive, face k, u, v] is u→v an edge of face k's outward
    cycle."""
    t = np.zeros((2, 4, 4, 4), dtype=bool)
    for s in (0, 1):
        for k, cyc in enumerate(_face_cycles(bool(s))):
            for u, v in cyc:
                t[s, k, u, v] = True
    return t


_DIR = _direction_table()


def _sides(P, ch, root, frag, positive, C):
    """[front, back] fragment of every polygon (module docstring): from the chords ending
    at an edge point, equal over the polygons joined by inner edges; marks off cells
    where they disagree or are missing."""
    bad = np.zeros(C, dtype=bool)
    cand_f, cand_b, cand_p = [], [], []
    for side, arrive in (("b", True), ("a", False)):
        r = np.flatnonzero(ch["ns_" + side] == 2)
        c, k, bits = ch["c"][r], ch["k"][r], ch["bits_" + side][r]
        u, v = _LOW[bits], _HIGH[bits]
        d = _DIR[positive[c].astype(np.int64), k, u, v]
        x, y = np.where(d, u, v), np.where(d, v, u)  # the cycle runs x → point → y
        fx, fy = frag[c, x], frag[c, y]
        cand_f.append(fy if arrive else fx)
        cand_b.append(fx if arrive else fy)
        cand_p.append(root[ch["poly"][r]])
    cf, cb, cp = (np.concatenate(v) for v in (cand_f, cand_b, cand_p))
    n = len(root)
    lo_f, hi_f = np.full(n, np.iinfo(np.int64).max), np.full(n, -1)
    lo_b, hi_b = lo_f.copy(), hi_f.copy()
    np.minimum.at(lo_f, cp, cf)
    np.maximum.at(hi_f, cp, cf)
    np.minimum.at(lo_b, cp, cb)
    np.maximum.at(hi_b, cp, cb)
    ok = (hi_f >= 0) & (lo_f == hi_f) & (lo_b == hi_b)
    bad[P["qc"][~ok[root]]] = True
    return hi_f[root], hi_b[root], bad


def _segment_rows(cells, pts, frag, positive, plain, n):
    """(fragment, apex, u, w): every face's boundary segments, each to the fragment of
    its corner, as a star from the face's smallest vertex (no triangle on an edge
    through it)."""
    c = np.flatnonzero(plain)
    apex = np.stack([cells[c][:, list(f)].min(axis=1) for f in _FACES], axis=1)
    out = []
    for s in (0, 1):
        i = np.flatnonzero(positive[c] == bool(s))
        cc = c[i]
        cyc = _face_cycles(bool(s)).reshape(12, 2)  # (face, edge) → its two corners
        x, y = cyc[:, 0], cyc[:, 1]
        e = np.array([_EDGE_OF[frozenset((int(u), int(v)))] for u, v in cyc])
        ap = apex[i][:, np.repeat(np.arange(4), 3)]
        p = pts[cc][:, e]
        vx, vy = cells[cc][:, x], cells[cc][:, y]
        hit = p >= 0
        out.append(np.stack([frag[cc][:, x], ap, vx, np.where(hit, n + p, vy)], -1)
                   .reshape(-1, 4))
        out.append(np.stack([frag[cc][:, y], ap, n + p, vy], -1)[hit])
    rows = np.concatenate(out) if out else np.zeros((0, 4), dtype=np.int64)
    return rows[(rows[:, 1] != rows[:, 2]) & (rows[:, 1] != rows[:, 3])]


def _chord_rows(cells, ch, front, back, plain, n):
    """Every chord a→b (polygon direction) to its polygon's front, b→a to its back, as
    stars from the face's smallest vertex: pairs (front, back, apex, a, b)."""
    r = np.flatnonzero(plain[ch["c"]])
    c, k = ch["c"][r], ch["k"][r]
    face = np.array(_FACES)[k]
    apex = np.take_along_axis(cells[c], face, axis=1).min(axis=1)
    a, b, p = n + ch["a"][r], n + ch["b"][r], ch["poly"][r]
    return np.stack([front[p], back[p], apex, a, b], 1)


def _fan_rows(P, front, back, plain, n):
    """Every cut polygon with two sides: a fan from its smallest point, as it is to the
    fragment behind it and reversed to the one in front."""
    keep = plain[P["qc"]] & (front != back)
    row = np.flatnonzero(keep[P["qi"]])
    qi, pos, h = P["qi"][row], P["pos"][row], P["h"][row]
    size = P["size"][qi]
    first = np.flatnonzero(np.diff(np.append(-1, qi)) != 0)
    m = np.minimum.reduceat(h, first) if len(first) else h[:0]
    grp = np.cumsum(np.diff(np.append(-1, qi)) != 0) - 1
    kmin = np.zeros(len(first), dtype=np.int64)
    at = h == m[grp]
    kmin[grp[at]] = pos[at]
    r = (pos - kmin[grp]) % size
    rot = np.empty_like(h)
    rot[first[grp] + r] = h
    tri = np.flatnonzero((pos >= 1) & (pos <= size - 2))  # rot: rotated in place
    g = grp[tri]
    p0, p1, p2 = n + m[g], n + rot[tri], n + rot[tri + 1]
    return np.stack([back[qi[tri]], front[qi[tri]], p0, p1, p2], 1)


def plain_cell_rows(cs, sm, cells: np.ndarray, n: int, start: np.ndarray,
                    nfrag: np.ndarray, positive: np.ndarray, todo: np.ndarray,
                    twice: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(plain (C,) bool, rows (k, 4) int64, pairs (j, 5) int64): the plain cells among
    ``todo`` (module docstring) and the triangles of their fragments' boundaries, each
    (fragment, three node ids: v for vertex v, n + h for point h), oriented outward;
    a pair (f, g, p, q, r) is the triangle (p, q, r) of f and (p, r, q) of g (a chord
    or a cut polygon's triangle, on the two sides). ``positive``: the
    cells with positive orientation; ``twice``: cells with an edge crossed twice."""
    C = len(cells)
    cut = np.flatnonzero(todo)
    cand = np.zeros(C, dtype=bool)
    cand[cut] = ~twice[cut] & ~sm.on_cut[cells[cut]].any(axis=1)
    cand[cs.cell[cs.on_face]] = False
    pts = _edge_points(cs, cells, cand, n)
    frag, bad_f = _corner_fragments(sm, start, nfrag, cand)
    fc, pc = frag[cut], pts[cut]
    bad_s = np.zeros(C, dtype=bool)
    bad_s[cut] = ((pc >= 0) == (fc[:, _EDGES[:, 0]] == fc[:, _EDGES[:, 1]])).any(axis=1)
    P, bad_p = _polygons(cs, cells, cand)
    ch, root, bad_g = _edges(P, C)
    bad_c, have = _chains(ch, C)
    bad_n = np.zeros(C, dtype=bool)
    bad_n[cut] = have[cut] != 2 * (pc >= 0).sum(axis=1)
    front, back, bad_d = _sides(P, ch, root, frag, positive, C)
    plain = cand & ~(bad_f | bad_s | bad_p | bad_g | bad_c | bad_n | bad_d)
    pairs = np.concatenate([_chord_rows(cells, ch, front, back, plain, n),
                            _fan_rows(P, front, back, plain, n)])
    return (plain, _segment_rows(cells, pts, frag, positive, plain, n).astype(np.int64),
            pairs.astype(np.int64, copy=False))


def plain_triangle_rows(cs, sm, cells: np.ndarray, n: int, start: np.ndarray,
                        nfrag: np.ndarray, positive: np.ndarray, todo: np.ndarray,
                        twice: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """2D :func:`plain_cell_rows`: (plain (C,) bool, rows (k, 3) int64 — fragment, two
    node ids of a boundary segment — and no pairs). A triangle is plain when no corner lies on the cut,
    no cut segment lies along an edge, every edge holds at most one point (one exactly
    where its ends are in two fragments) and its cut segments form one path from an edge
    point a to an edge point b through points inside (each the end of one segment and
    the start of the next). The ring of edges (counter-clockwise) gives each piece of
    an edge to the fragment of its corner; every segment of the path has on its left
    the fragment of the corner after b along the ring and on its right the one after a
    (:func:`~predicates.registration.split.regions.cell_pieces`)."""
    C = len(cells)
    cut = np.flatnonzero(todo)
    cand = np.zeros(C, dtype=bool)
    cand[cut] = ~twice[cut] & ~sm.on_cut[cells[cut]].any(axis=1)
    cand[cs.cell[cs.on_face]] = False
    pts = _edge_points_2d(cs, cells, cand, n, _EDGES_2D)
    frag, bad = _corner_fragments(sm, start, nfrag, cand, m=3)
    fc, pc = frag[cut], pts[cut]
    bad[cut] |= ((pc >= 0) == (fc[:, _EDGES_2D[:, 0]] == fc[:, _EDGES_2D[:, 1]])).any(axis=1)
    q = np.flatnonzero(~cs.on_face & cand[cs.cell])
    a, b, c = cs.index[cs.offsets[q]], cs.index[cs.offsets[q] + 1], cs.cell[q]
    head, tail, bad_p = _paths_2d(cs, c, a, b, (pts >= 0).sum(axis=1), C)
    plain = cand & ~bad & ~bad_p
    out = []
    ring = np.array([(0, 1), (1, 2), (2, 0)])
    for s in (0, 1):
        cc = np.flatnonzero(plain & (positive == bool(s)))
        for x, y in (ring if s else ring[::-1, ::-1]).tolist():
            p = pts[cc, _EDGE_2D[frozenset((x, y))]]
            vx, vy, hit = cells[cc, x], cells[cc, y], p >= 0
            out.append(np.stack([frag[cc, x], vx, np.where(hit, n + p, vy)], 1))
            out.append(np.stack([frag[cc, y], n + p, vy], 1)[hit])
    keep = plain[c]
    c, a, b = c[keep], a[keep], b[keep]
    left = _after_2d(positive, pts, frag, c, tail[c])
    right = _after_2d(positive, pts, frag, c, head[c])
    two = left != right
    out.append(np.stack([left, n + a, n + b], 1)[two])
    out.append(np.stack([right, n + b, n + a], 1)[two])
    return plain, np.concatenate(out).astype(np.int64, copy=False), np.zeros((0, 4), np.int64)


def _paths_2d(cs, c, a, b, n_edge_points, C):
    """Per cell, the first and last point (edge points) of the path its segments a→b
    form; marks off cells where they do not form one path from edge point to edge
    point through points inside."""
    held = _held(cs)
    bad = np.zeros(C, dtype=bool)
    cc, hh = np.concatenate([c, c]), np.concatenate([a, b])
    out = np.concatenate([np.ones(len(a)), np.zeros(len(b))])
    o, gid, cnt = _groups(cc, hh)
    n_out = np.bincount(gid, out[o], len(cnt)) if len(o) else np.zeros(0)
    first = np.flatnonzero(np.diff(np.append(-1, gid)) != 0)
    node_c, node_h = cc[o][first], hh[o][first]
    edge = held[node_h] == 2
    ok = np.where(edge, cnt == 1, (held[node_h] == 3) & (cnt == 2) & (n_out == 1))
    bad[node_c[~ok]] = True
    bad[np.flatnonzero(np.bincount(node_c[edge], minlength=C) != n_edge_points)] = True
    node = np.empty_like(gid)
    node[o] = gid
    m = len(a)
    root = R.components(len(cnt), node[:m], node[m:])
    has_edge = np.zeros(len(cnt), dtype=bool)
    has_edge[root[edge]] = True
    bad[node_c[~has_edge[root]]] = True
    head, tail = np.full(C, -1, dtype=np.int64), np.full(C, -1, dtype=np.int64)
    head[node_c[edge & (n_out == 1)]] = node_h[edge & (n_out == 1)]
    tail[node_c[edge & (n_out == 0)]] = node_h[edge & (n_out == 0)]
    return head, tail, bad


_EDGES_2D = np.array([(0, 1), (0, 2), (1, 2)])
_EDGE_2D = {frozenset((0, 1)): 0, frozenset((0, 2)): 1, frozenset((1, 2)): 2}


def _edge_points_2d(cs, cells, cand, n, edges):
    """(C, 3) the point inside each local edge of the candidates (−1: none)."""
    eh = np.flatnonzero(_held(cs) == 2)
    lo = np.minimum(cs.sim[eh, 0], cs.sim[eh, 1])
    key = lo * n + np.maximum(cs.sim[eh, 0], cs.sim[eh, 1])
    o = np.argsort(key, kind="stable")
    key, eh = key[o], eh[o]
    c_ids = np.flatnonzero(cand)
    u, v = cells[c_ids][:, edges[:, 0]], cells[c_ids][:, edges[:, 1]]
    want = np.minimum(u, v) * n + np.maximum(u, v)
    pts = np.full((len(cells), 3), -1, dtype=np.int64)
    if len(key):
        i = np.minimum(np.searchsorted(key, want), len(key) - 1)
        pts[c_ids] = np.where(key[i] == want, eh[i], -1)
    return pts


def _after_2d(positive, pts, frag, c, h):
    """The fragment of the corner after edge point h of cell c along its ring."""
    e = np.argmax(pts[c] == h[:, None], axis=1)
    u, v = _EDGES_2D[e, 0], _EDGES_2D[e, 1]
    ring_next = np.where(positive[c], (u + 1) % 3 == v, (v + 1) % 3 == u)
    # counter-clockwise ring 0→1→2→0 (positive) or 0→2→1→0: the edge runs u→v or v→u
    return frag[c, np.where(ring_next, v, u)]

