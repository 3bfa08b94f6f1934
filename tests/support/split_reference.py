"""The virtual-node split written the straightforward way (docs/split.md, rules 1–3 and
the numbering of "Implementation"): Python loops over cells, faces and slots, dicts and a
plain union-find, every cell processed (no "near the cut" zones, no sorting tricks). The
tests compare ``split_mesh`` with it field by field on small manifold meshes."""
from __future__ import annotations

import itertools

import numpy as np

from predicates.registration.split.cover import covered_faces
from predicates.registration.split.mesh import _hits


class _UnionFind:
    def __init__(self):
        self.parent: dict = {}

    def find(self, x):
        self.parent.setdefault(x, x)
        while self.parent[x] != x:
            self.parent[x] = self.parent[self.parent[x]]
            x = self.parent[x]
        return x

    def union(self, x, y):
        rx, ry = self.find(x), self.find(y)
        if rx != ry:
            self.parent[max(rx, ry)] = min(rx, ry)


def _fragments(cells, on_cut, severed_set):
    """Per cell, its components of off-cut corners through unsevered edges, ordered by
    their smallest corner (one all-material fragment when every corner is on the cut)."""
    out = []
    for c in cells:
        off = [k for k in range(len(c)) if c[k] not in on_cut]
        uf = _UnionFind()
        for a, b in itertools.combinations(off, 2):
            uf.find(a), uf.find(b)
            if frozenset((c[a], c[b])) not in severed_set:
                uf.union(a, b)
        comps = {}
        for k in off:
            comps.setdefault(uf.find(k), []).append(k)
        out.append(sorted(comps.values()) if off else [[]])
    return out


def reference_split(res) -> dict:
    """The fields of ``SplitMesh`` (``points`` … ``severed``) for the result ``res``."""
    d = int(res.dim)
    m = d + 1
    cells = np.asarray(res.sim_cells, dtype=np.int64).tolist()
    n = len(res.sim_points)
    on_cut = {int(p[0]) for k in res.kinds for p in res[k].sim.tolist() if len(p) == 1}
    severed_set = {frozenset(p) for k in res.kinds for p in res[k].sim.tolist() if len(p) == 2}
    local_edges = list(itertools.combinations(range(m), 2))
    severed = np.array([[frozenset((c[a], c[b])) in severed_set for a, b in local_edges]
                        for c in cells], dtype=bool).reshape(len(cells), len(local_edges))
    frags = _fragments(cells, on_cut, severed_set)
    cell_origin, frag_of, material, first = [], [], [], []
    for c, comps in enumerate(frags):
        first.append(len(cell_origin))
        fo = [-1] * m
        for comp in comps:
            for k in comp:
                fo[k] = len(cell_origin)
            material.append([k in comp or cells[c][k] in on_cut for k in range(m)])
            cell_origin.append(c)
        frag_of.append(fo)
    faces: dict = {}
    for k in range(m):  # occurrences in the order (omitted corner, cell)
        for c, row in enumerate(cells):
            faces.setdefault(frozenset(row[:k] + row[k + 1:]), []).append(c)
    slots = _UnionFind()
    for face, owners in faces.items():
        verts = sorted(face)
        for c1, c2 in zip(owners[:-1], owners[1:]):
            glued = [(frag_of[c1][cells[c1].index(v)], frag_of[c2][cells[c2].index(v)])
                     for v in verts if v not in on_cut]
            if not glued and not covered_faces(res, np.array([verts]))[0]:
                glued = [(first[c1], first[c2])]
            for g1, g2 in glued:
                for v in verts:
                    slots.union((g1 * m + cells[c1].index(v)),
                                (g2 * m + cells[c2].index(v)))
    classes: dict = {}
    for f, c in enumerate(cell_origin):
        for k in range(m):
            classes.setdefault(cells[c][k], {}).setdefault(slots.find(f * m + k), []).append(
                f * m + k)
    node_of_slot, node_origin = {}, []
    for v in range(n):
        for members in sorted(classes.get(v, {}).values(), key=min):
            for s in members:
                node_of_slot[s] = len(node_origin)
            node_origin.append(v)
    new_cells = [[node_of_slot[f * m + k] for k in range(m)] for f in range(len(cell_origin))]
    nodes = _UnionFind()
    for row in new_cells:
        for v in row[1:]:
            nodes.union(row[0], v)
    piece_of_root: dict = {}
    piece = [piece_of_root.setdefault(nodes.find(row[0]), len(piece_of_root))
             for row in new_cells]
    hp, hk, hs, hw = _hits(res, d)
    prims = [set(r[r >= 0].tolist()) for r in hs]
    offsets, index = [0], []
    for c in cell_origin:
        index += [h for h, p in enumerate(prims) if p <= set(cells[c])]
        offsets.append(len(index))
    return {"points": np.asarray(res.sim_points)[node_origin], "cells": np.array(new_cells),
            "cell_origin": np.array(cell_origin), "node_origin": np.array(node_origin),
            "material": np.array(material, dtype=bool), "piece": np.array(piece),
            "n_pieces": len(piece_of_root), "hit_points": hp, "hit_kind": hk, "hit_sim": hs,
            "hit_weights": hw, "hit_offsets": np.array(offsets), "hit_index": np.array(index),
            "on_cut": np.isin(np.arange(n), sorted(on_cut)), "severed": severed}
