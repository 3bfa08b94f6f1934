"""The conforming tetrahedralization (2D: triangulation) of the split (docs/split.md,
"The conforming tetrahedralization"): every piece as simplices whose faces follow the
cut, built on the registered pairs only (paper, section 1).

Points are the simulation vertices, then the registered points (keyed by their pair: a
point shared by cells is one point), then one interior point per fragment where one is
used. Every fragment of a cell the cut touches (a registered point that is not a vertex
on its closure) gets its boundary from part 1 (:func:`~predicates.registration.split.
regions.cell_pieces`), triangulated by the global rule of
:mod:`~predicates.registration.split.polytri` (:mod:`~.tetra_faces`), and is filled by a
**cone**: the simplices (apex, boundary simplex). Cells the cut does not touch are kept.

Why a cone, and which apex. Let S be a fragment's triangulated boundary: a closed,
consistently oriented surface (checked: every edge once in each direction). For any
apex p, the signed cones from p over S add up to the winding number of S, i.e. the
indicator of the fragment; if every cone simplex has *positive* exact orientation on the
stored coordinates, no point is covered negatively, so the cones cover the fragment once
and nothing else: a tetrahedralization whose boundary is exactly S. The apex is first
the mean of the fragment's boundary points — strictly inside a convex fragment, and
every cone simplex then has height ≥ its distance to the boundary's planes, so only
rounding of a sliver can break it; if some simplex is not positive, each boundary point
in increasing id is tried as apex (its own boundary simplices, of zero measure, are
skipped; this is the fan from a vertex, valid for fragments star-shaped from it). A
fragment no apex fills is **refused** (:class:`NotConforming`, naming the cells): never a
silent inverted or zero-volume simplex. Since S is the same global triangulation on both
sides of every face, the simplices of neighbouring cells, and of the two fragments on
either side of a cut polygon, share their faces.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fperr.warnings import ResolutionError
from predicates.registration.split import rules as R
from predicates.registration.split.enclosed import cavity_fill, merge_enclosed
from predicates.registration.split.search import refusal_reason
from predicates.registration.split.tetra_faces import (OUTWARD, Points, cell_boundary,
                                                       on_cut_points, positive,
                                                       ring_pieces)

__all__ = ["ConformingMesh", "NotConforming", "conforming_mesh"]


class NotConforming(ResolutionError):
    """Some cells could not be tetrahedralized conformingly (the report names them): a
    refused run (``fperr cut --conforming`` exits 1), not bad input."""


@dataclass
class ConformingMesh:
    """The conforming simplices of the split (module docstring). ``points`` (N, d);
    ``point_kind`` (N,) 0 simulation vertex, 1 registered point, 2 interior point;
    ``point_hit`` (N,) the registered point (index into the cut surface's points) or −1.
    ``cells`` (T, d+1), positively oriented; per simplex ``cell_origin`` (original
    cell), ``fragment`` (the new cell of the split whose material corners the simplex's
    region holds, −1 for material the split gives no fragment: between two crossings of
    an edge), ``piece`` (the simplices connected through faces that are not cut),
    ``split_piece`` (the split's piece of ``fragment``), ``side`` (+1 in front of the
    cut, −1 behind, 0 not on it, 2 both).
    ``cut_faces`` (K, d) oriented like their cutting cell, ``cut_cell`` /
    ``input_cut_cell`` (K,) the cutting cell they lie on (registered / as given),
    ``cut_sides`` (K, 2) the simplex behind and in front; ``point_moved`` (N,) the
    degenerate registered points placed on their simulation primitive instead of the cut
    to fill regions their placement on the cut folded (:func:`_repair`)."""

    dim: int
    points: np.ndarray
    point_kind: np.ndarray
    point_hit: np.ndarray
    cells: np.ndarray
    cell_origin: np.ndarray
    fragment: np.ndarray
    piece: np.ndarray
    side: np.ndarray
    n_pieces: int
    cut_faces: np.ndarray
    cut_cell: np.ndarray
    input_cut_cell: np.ndarray
    cut_sides: np.ndarray
    split_piece: np.ndarray
    point_moved: np.ndarray | None = None
    surface: object = None  # the cut surface ``point_hit`` indexes (declump.py)

    def volumes(self) -> np.ndarray:
        """(T,) the simplices' volumes (areas), elementwise (no BLAS)."""
        from predicates.registration.split.volume import simplex_measure

        return simplex_measure(self.points[self.cells])[0]

    def piece_volumes(self) -> np.ndarray:
        return np.bincount(self.piece, self.volumes(), self.n_pieces)

    def separated(self):
        """(points, cells): the points copied once per piece that uses them, so that the
        pieces share no node (what a simulation of separate pieces needs)."""
        key = self.cells.astype(np.int64) * self.n_pieces + self.piece[:, None]
        u, inv = np.unique(key.ravel(), return_inverse=True)
        return self.points[u // self.n_pieces], inv.reshape(self.cells.shape)

    def opened(self):
        """(points, cells): the cut opened — a point gets one node per set of simplices
        around it joined through faces that are not cut faces, so the two sides of a
        crack separate while the material around its front stays connected
        (:func:`~.conform_parts.open_nodes`)."""
        from predicates.registration.split.conform_parts import open_nodes

        node = open_nodes(self.cells, self.cut_faces)
        pt = np.zeros(int(node.max(initial=-1)) + 1, dtype=np.int64)
        pt[node.ravel()] = self.cells.ravel()
        return self.points[pt], node

    def to_meshio(self, explode: float = 0.0):
        """The simplices as a ``meshio.Mesh`` (the cut opened, :meth:`opened`; moved apart by
        ``explode`` × (piece centroid − mesh centroid)), cell data ``piece``,
        ``cell_origin``, ``fragment``, ``side``; 2D points at z = 0."""
        import meshio

        X, cells = self.opened()
        if explode:
            cen = np.stack([np.bincount(self.piece, self.points[self.cells][:, :, k].mean(1),
                                        self.n_pieces) for k in range(self.dim)], 1)
            cen /= np.maximum(np.bincount(self.piece, minlength=self.n_pieces), 1)[:, None]
            node_piece = np.zeros(len(X), dtype=np.int64)
            node_piece[cells.ravel()] = np.repeat(self.piece, self.dim + 1)
            X = X + float(explode) * (cen - self.points.mean(axis=0))[node_piece]
        if self.dim == 2:
            X = np.column_stack([X, np.zeros(len(X))])
        cd = {k: [getattr(self, k).astype(np.int64)]
              for k in ("piece", "cell_origin", "fragment", "side")}
        return meshio.Mesh(X, [("tetra" if self.dim == 3 else "triangle",
                                cells.astype(np.int64))], cell_data=cd)

    def summary(self) -> dict:
        return {"dim": self.dim, "simplices": len(self.cells), "points": len(self.points),
                "interior_points": int((self.point_kind == 2).sum()),
                "pieces": self.n_pieces, "cut_faces": len(self.cut_faces),
                "moved_points": int(self.point_moved.sum()) if self.point_moved is not None
                else 0}


def _touched(cs, cells: np.ndarray, n: int) -> np.ndarray:
    """(C,) bool: cells with a registered point that is not a vertex on their closure."""
    big = np.flatnonzero((cs.sim >= 0).sum(axis=1) >= 2)
    out = np.zeros(len(cells), dtype=bool)
    if len(big):
        _, c = R.cell_hits(cells, cs.sim[big], n)
        out[c] = True
    return out


def _outward(sign: int, d: int):
    """The cell's faces oriented outward, from its exact orientation ``sign``."""
    if d == 2:
        return (0, 1, 2) if sign > 0 else (0, 2, 1)
    return list(OUTWARD) if sign > 0 else [f[::-1] for f in OUTWARD]


def _pieces(c, ctx):
    """[(local region, node cycle)] of cell c (:mod:`~.cell_regions`), its outward
    faces, and {local region: its fragment of the split, −1 when none}."""
    from predicates.registration.split.cell_regions import cell_regions
    from predicates.registration.split.slits import face_regions

    sm, T, cells, d = ctx["sm"], ctx["T"], ctx["cells"], ctx["d"]
    corners = cells[c].tolist()
    nf, s = int(ctx["nfrag"][c]), int(ctx["start"][c])
    polys = [[("h", h) for h in P] for P in T.polygons(ctx["cs"], c)]
    out = _outward(ctx["sign"][c], d)
    if d == 2:
        faces = [r for _, r in ring_pieces(corners, 0, sm.on_cut, T, out)]
    else:
        faces = face_regions(corners, sm.on_cut, T, polys, out, ctx["cs"])
    pieces = cell_regions(faces, polys, d)
    frag_of = {v: s + j for j in range(nf) for k, v in enumerate(corners)
               if sm.material[s + j, k] and not sm.on_cut[v]}
    owner = {}
    for r, cyc in pieces:
        for nd in cyc:
            if nd[0] == "v" and nd[1] in frag_of:
                owner[r] = min(owner.get(r, frag_of[nd[1]]), frag_of[nd[1]])
    if nf == 1:
        owner = {r: s for r, _ in pieces}
    return pieces, out, {r: owner.get(r, -1) for r, _ in pieces}


def _closed(tris) -> bool:
    """Every edge of the oriented boundary used as often in each direction (a slit, the
    two sides of a crack inside one region, uses its edges twice each way); 2D: every
    point entered as often as left."""
    d = len(tris[0])
    count: dict = {}
    for t in tris:
        for i in range(d if d == 3 else 1):
            e = (t[i], t[(i + 1) % d]) if d == 3 else (t[0], t[1])
            count[e] = count.get(e, 0) + 1
    if d == 2:
        bal: dict = {}
        for (a, b), k in count.items():
            bal[a] = bal.get(a, 0) + k
            bal[b] = bal.get(b, 0) - k
        return not any(bal.values())
    return all(count.get((b, a), 0) == k for (a, b), k in count.items())


def _cone(tris, apex: int, d: int):
    """Simplices (boundary simplex, apex), the triangle reversed in 3D: positive for an
    apex inside (an outward triangle sees the inside on its negative side; an edge of
    a counter-clockwise boundary has it on its left)."""
    return [(tuple(t[::-1]) if d == 3 else tuple(t)) + (apex,) for t in tris if apex not in t]


def _fill(frag_tris: dict, Y, d: int):
    """Cone every fragment from its mean point, falling back to its boundary points
    (module docstring). Returns ({fragment: simplices}, [fragments refused])."""
    out, bad, first = {}, [], {}
    for f, tris in frag_tris.items():
        first[f] = _cone(tris, Y.append(_mean(tris, Y)), d)
    allc = [s for f in first for s in first[f]]
    Z = Y.array
    sign = positive(np.array(allc, dtype=np.int64).reshape(-1, d + 1), Z)
    at = 0
    for f, simp in first.items():
        ok = bool(np.all(sign[at:at + len(simp)] > 0))
        at += len(simp)
        if ok:
            out[f] = simp
            continue
        cand = _fallback(frag_tris[f], Y, d)
        if cand is None:
            bad.append(f)
        else:
            out[f] = cand
    return out, bad


def _apex_cone(tris, Y, d: int, point):
    """The cone from ``point`` (appended to Y) if all its simplices are positive."""
    if point is None:
        return None
    Y.append(point)
    cand = _cone(tris, len(Y) - 1, d)
    if np.all(positive(np.array(cand, dtype=np.int64), Y.array) > 0):
        return cand
    Y.pop()
    return None


def _mean(tris, Y):
    pts = sorted({p for t in tris for p in t})
    acc = np.zeros(Y.buf.shape[1])
    for p in pts:
        acc = acc + Y[p]
    return acc / len(pts)


def _fallback(tris, Y, d: int):
    """2D, a region holding a slit (a crack tip inside the cell): its ear clipping
    (:mod:`~.slit_fill`). Otherwise the cone from a kernel point (:mod:`~.kernel`),
    else, in a region around a crack front, two cones on either side of the crack
    joined across the uncut part of the cell (:mod:`~.crack_front`), else the cone from a boundary point
    (:func:`~.search.fan_from_boundary`: the triangles through it are skipped, the others
    must all give positive simplices), else peeling (:mod:`~.peel`), else the
    backtracking search (:mod:`~.search`), else the crack front's region split and its
    parts peeled; None when none fills the fragment with positive simplices (every
    result is checked again by :func:`positive`)."""
    from predicates.registration.split.crack_front import crack_front_fill
    from predicates.registration.split.kernel import kernel_point
    from predicates.registration.split.peel import peel
    from predicates.registration.split.search import (fan_from_boundary, folded_triangle,
                                                      search_fill)

    if d == 2:
        # a slit (a crack tip or a crack inside the cell: both sides listed), which no
        # cone fills, or a boundary in pieces (a hole): ear clipping, bridged
        from predicates.registration.split.slit_fill import fill_slit_region

        if set(tris) & {t[::-1] for t in tris}:
            return fill_slit_region(tris, Y.array)
        return (_apex_cone(tris, Y, d, kernel_point(tris, Y))
                or fill_slit_region(tris, Y.array))
    cand = (_apex_cone(tris, Y, d, kernel_point(tris, Y))
            or _checked(cavity_fill(tris, Y.array), Y, tris))  # around an inclusion
    if cand is not None:
        return cand

    def try_cone(front):
        return (_apex_cone(front, Y, d, _mean(front, Y))
                or _apex_cone(front, Y, d, kernel_point(front, Y)))

    def fill_part(part, thorough: bool):  # a part of a crack front's region: no slit
        return (try_cone(part) or _checked(fan_from_boundary(part, Y.array), Y, part)
                or (_checked(peel(part, Y, try_cone), Y, part) if thorough else None))

    def crack_front(thorough: bool):
        return crack_front_fill(tris, Y, lambda tets: _checked(tets, Y, tris), fill_part,
                                thorough)

    found = (crack_front(False) or _checked(fan_from_boundary(tris, Y.array), Y, tris)
             or _checked(peel(tris, Y, try_cone), Y, tris))
    if found is None and folded_triangle(tris, Y.array) is None:  # else: no search helps
        found = _checked(search_fill(tris, Y.array), Y, tris) or crack_front(True)
    return found


def _checked(tets, Y, tris):
    """``tets`` if every one has positive exact orientation (classic.FILTERED) and their
    faces pair up to exactly the boundary ``tris``: each boundary triangle the outward
    face of one tetrahedron, every other face shared with opposite orientations. (Positive
    tetrahedra whose boundary is S only as a chain are not enough: the two sides of a slit
    cancel there, and tetrahedra crossing the crack would pass.)"""
    from predicates.registration.split.search import paired

    if not tets or not paired(tets, tris):
        return None
    ok = np.all(positive(np.array(tets, dtype=np.int64), Y.array) > 0)
    return tets if ok else None


def _collect(res, sm, cs, ctx):
    """Boundaries of the regions of the touched cells: ({region: outward simplices},
    cut records, {(cell, face): triangles}, region → (cell, fragment), problems)."""
    from predicates.registration.split.crack_front import merge_floating
    from predicates.registration.split.polytri import NoEar
    from predicates.registration.split.regions import Unresolved

    T, n = ctx["T"], ctx["n"]
    cut_cells = np.asarray(res.cut_cells, dtype=np.int64)
    tris_of, cuts, faces, where, problems = {}, [], {}, [], []
    for c in np.flatnonzero(ctx["touched"]).tolist():
        corners = ctx["cells"][c].tolist()
        q = T.poly_order[T.poly_bounds[c]:T.poly_bounds[c + 1]].tolist()
        polys = list(zip(q, T.polygons(cs, c)))
        try:
            pieces, out, owner = _pieces(c, ctx)
            base = len(where)
            pieces = [(base + r, cyc) for r, cyc in pieces]
            cb = cell_boundary(corners, pieces, polys, T, cs, cut_cells, n, out)
        except (Unresolved, NoEar, StopIteration, KeyError) as e:
            problems.append((c, f"{type(e).__name__}: {e}"))
            continue
        where += [(c, owner[r]) for r in range(len(owner))]
        for f, tris in merge_floating(cb.tris).items():  # a crack inside the cell
            if not tris or not _closed(tris):
                problems.append((c, f"region {f - base}: boundary not closed"))
            tris_of[f] = tris
        cuts += cb.cut
        for k, v in cb.faces.items():
            faces[c, k] = v
    return tris_of, cuts, faces, where, problems


def _context(res, sm, cs) -> dict:
    from predicates.registration.split.volume import _Tables

    d, cells = sm.dim, np.asarray(res.sim_cells, dtype=np.int64)
    X = np.asarray(res.sim_points, dtype=np.float64)
    n, C = len(X), len(cells)
    nfrag = np.bincount(sm.cell_origin, minlength=C)
    ctx = {"sm": sm, "cs": cs, "T": _Tables(cs, C), "cells": cells, "X": X, "d": d,
           "n": n, "nfrag": nfrag, "start": np.cumsum(nfrag) - nfrag,
           "touched": _touched(cs, cells, n) | (nfrag > 1)}
    # the touched cells' exact orientations in one filtered batch (not one call a cell)
    ctx["sign"] = np.zeros(C, dtype=np.int8)
    ctx["sign"][ctx["touched"]] = positive(cells[ctx["touched"]], X)
    return ctx


def conforming_mesh(res, sm, cs=None) -> ConformingMesh:
    """The conforming simplices of the split ``sm`` of ``res`` (module docstring);
    ``cs``: its cut surface (computed when not given). Raises :class:`NotConforming`
    naming the cells it cannot fill."""
    from predicates.registration.split.conform_parts import assemble
    from predicates.registration.split.declump import declump
    from predicates.registration.split.surface import cut_surface

    cs = cut_surface(res) if cs is None else cs
    ctx = _context(res, sm, cs)
    frag_tris, cuts, faces, where, problems = _collect(res, sm, cs, ctx)
    again = declump(res, cs, [c for c, _ in problems]) if problems else None
    if again is not None:  # merged crossings around a vertex, re-decided (declump.py)
        cs = again
        ctx = _context(res, sm, cs)
        frag_tris, cuts, faces, where, problems = _collect(res, sm, cs, ctx)
    if problems:
        raise NotConforming(_report(problems))
    X, n, d = ctx["X"], ctx["n"], ctx["d"]
    Y = Points(np.concatenate([X, on_cut_points(res, cs)]))
    frag_tris = merge_enclosed(frag_tris, where, Y.array, d)  # an island's surroundings
    filled, bad = _fill(frag_tris, Y, d)
    bad, moved = _repair(res, cs, frag_tris, Y, filled, bad, n, d)
    if bad:
        why = {}
        for f in bad:
            cell = [t for g, ts in frag_tris.items() if where[g][0] == where[f][0] for t in ts]
            why.setdefault(where[f][0], refusal_reason(frag_tris[f], Y.array, cell))
        raise NotConforming(_report(sorted(why.items())))
    fields = assemble(res, sm, cs, ctx, filled, Y.array, cuts, faces, where)
    hit = fields["point_hit"]
    fields["point_moved"] = np.zeros(len(hit), dtype=bool)
    fields["point_moved"][hit >= 0] = moved[hit[hit >= 0]]
    return ConformingMesh(**fields, surface=cs)


def _repair(res, cs, frag_tris: dict, Y, filled: dict, bad: list, n: int, d: int,
            rounds: int = 3):
    """Refill refused regions after moving their degenerate registered points onto their
    simulation primitives (:func:`~.tetra_faces.degenerate_on_sim`: the flaps of merged
    points placed on the cut), with every region through a moved point refilled and
    checked again; up to ``rounds`` times, a refused region's points moved each time.
    Only where a refusal needs it: elsewhere the cut faces stay exactly on the cut.
    Returns (regions still refused, (H,) bool the points moved)."""
    from predicates.registration.split.tetra_faces import degenerate_on_sim

    deg, on_sim = degenerate_on_sim(res, cs)
    moved = np.zeros(len(deg), dtype=bool)
    for _ in range(rounds):
        hits = {p - n for f in bad for t in frag_tris[f] for p in t if n <= p < n + len(deg)}
        new = np.array(sorted(h for h in hits if deg[h] and not moved[h]), dtype=np.int64)
        if not len(new):
            break
        moved[new] = True
        Y.buf[n + new] = on_sim[new]
        ids = set((n + new).tolist())
        redo = {f: tris for f, tris in frag_tris.items()
                if f in bad or any(p in ids for t in tris for p in t)}
        again, still = _fill(redo, Y, d)
        filled.update(again)
        for f in still:
            filled.pop(f, None)
        bad = sorted((set(bad) - set(again)) | set(still))
    return bad, moved


def _report(problems) -> str:
    """The refused cells grouped by reason (each reason said once, up to 8 cells named)."""
    by_why = {}
    for c, why in problems:
        by_why.setdefault(str(why), []).append(c)
    parts = []
    for why, cells in by_why.items():
        more = f" and {len(cells) - 8} more" if len(cells) > 8 else ""
        name = "cell" if len(cells) == 1 else "cells"
        parts.append(f"{name} {', '.join(map(str, cells[:8]))}{more}: {why}")
    return f"conforming tetrahedralization refused in {len(problems)} cell(s): " + "; ".join(parts)
