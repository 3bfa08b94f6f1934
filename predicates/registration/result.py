"""The result of :func:`predicates.registration.intersect` (section 1 of the paper):
registered pairs per kind, readable summary, consistency counts, export."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["IntersectionResult", "KindPairs"]


@dataclass
class KindPairs:
    """The registered pairs of one kind (e.g. ``"edge_triangle"``).

    ``sim`` (m, i+1) and ``cut`` (m, j+1): vertex ids (rows of the input point arrays)
    of the simulation and cutting primitives; ``sim_weights`` / ``cut_weights``: the
    barycentric weights of the intersection point on each primitive, column by column
    for the ids beside them (a vertex has weight [1]). Within a primitive, vertices are
    listed in lexicographic order of their coordinates (the order the predicate saw
    them), rows are sorted by ids.

    ``candidates``: pairs proposed by the broad phase; ``suppressed``: of those, pairs
    skipped because a sub-pair was registered at a lower level; the rest were tested.
    """

    kind: str
    sim: np.ndarray
    cut: np.ndarray
    sim_weights: np.ndarray
    cut_weights: np.ndarray
    candidates: int = 0
    suppressed: int = 0

    def __len__(self):
        return len(self.sim)

    @property
    def tested(self) -> int:
        return self.candidates - self.suppressed

    def keys(self) -> set:
        """The pairs as a set of (sorted sim ids, sorted cut ids) tuples."""
        s, c = np.sort(self.sim, axis=1), np.sort(self.cut, axis=1)
        return {(tuple(a), tuple(b)) for a, b in zip(s.tolist(), c.tolist())}

    def points(self, sim_points: np.ndarray, side: str = "sim") -> np.ndarray:
        """Intersection points Σ wᵢ·xᵢ on the simulation (``side="sim"``) or cutting
        primitive, in float64, from the given point array."""
        ids, w = (self.sim, self.sim_weights) if side == "sim" else (self.cut, self.cut_weights)
        X = np.asarray(sim_points, dtype=np.float64)[ids]
        return np.einsum("mk,mkd->md", w.astype(np.float64), X)


@dataclass
class IntersectionResult:
    """Registered intersections of a simulation mesh with a cutting mesh.

    ``res.kinds``: kind names in registration order; ``res[kind]``: a
    :class:`KindPairs`; ``res.counts``: {kind: number registered};
    ``res.tolerances``: the :class:`predicates.Tolerances` used (for the coordinates
    multiplied by ``2**-res.scale_exponent``, an exact power-of-two scaling);
    ``res.tolerances_input_units()``: the same in the input's units. ``str(res)`` is a
    readable summary, ``res.to_meshio()`` the intersection points for ParaView.
    """

    dim: int
    dtype: np.dtype
    kinds: tuple
    pairs: dict
    tolerances: object
    scale_exponent: int
    tolerance_scale: float
    L_a: float
    L_b: float
    sim_points: np.ndarray
    sim_cells: np.ndarray
    cut_points: np.ndarray
    cut_cells: np.ndarray
    rounded_inputs: bool = False
    timings: dict = field(default_factory=dict)
    #: what the run resolves (a predicates.registration.resolution.Resolution) and the
    #: cutting mesh's refinement (refine.Refinement: cut_origin, input_weights), or None;
    #: with a refinement, cut_points / cut_cells are the refined mesh the ids refer to
    resolution: object = None
    refinement: object = None

    def __getitem__(self, kind: str) -> KindPairs:
        try:
            return self.pairs[kind]
        except KeyError:
            raise KeyError(f"no kind {kind!r} in {self.dim}D; kinds: {', '.join(self.kinds)}") \
                from None

    def __iter__(self):
        return iter(self.kinds)

    @property
    def counts(self) -> dict:
        return {k: len(self.pairs[k]) for k in self.kinds}

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def tolerances_input_units(self) -> dict:
        """Every tolerance (and L) in the input's units: T·2^(e·p) (inf/0 if that
        overflows/underflows binary64; the registration itself never does)."""
        from ..tolerance_table import TABLES

        e = self.scale_exponent
        out = {"L": float(np.ldexp(np.float64(self.tolerances.L), e))}
        with np.errstate(all="ignore"):
            for name, spec in (self.tolerances.table or TABLES[self.dim]).items():
                out[name] = float(np.ldexp(np.float64(self.tolerances.values[name]),
                                           e * spec.p))
        return out

    def location_counts(self, side: str = "cut") -> np.ndarray:
        """For every point of the ``side`` mesh ("cut" or "sim"): in how many registered
        pairs that vertex is itself the primitive (vertex_vertex, edge_vertex,
        triangle_vertex, ... for "cut"; vertex_* for "sim"). In a consistent registration
        a cutting vertex inside the simulation mesh is located exactly once."""
        n = len(self.cut_points if side == "cut" else self.sim_points)
        counts = np.zeros(n, dtype=np.int64)
        for k in self.kinds:
            p = self.pairs[k]
            ids = p.cut if side == "cut" else p.sim
            if ids.shape[1] == 1:
                np.add.at(counts, ids[:, 0], 1)
        return counts

    def mislocated(self, inside) -> int:
        """Inconsistency count: cutting vertices marked ``inside`` (a bool per cutting
        point: known to lie inside the simulation mesh) that are not located exactly
        once — registered with no simulation primitive (the cut falls through a crack)
        or with several (counted twice). A consistent registration gives 0. With a
        refined cutting mesh, ``inside`` may cover the input points only (the vertices
        the refinement appended count as unknown)."""
        inside = np.asarray(inside, dtype=bool)
        if self.refinement is not None and len(inside) < len(self.cut_points):
            inside = np.concatenate([inside, np.zeros(len(self.cut_points) - len(inside), bool)])
        used = np.zeros(len(self.cut_points), dtype=bool)
        used[np.unique(self.cut_cells)] = True
        return int(np.sum(inside & used & (self.location_counts("cut") != 1)))

    def inconsistencies(self, inside) -> int:
        """:meth:`mislocated` + :meth:`broken_walks`: the inconsistency count used to
        compare the robust registration with the naive baseline. ``inside``: a bool per
        cutting point, True for vertices known to lie inside the simulation mesh.

        Meant for cuts that lie inside the simulation mesh and pass through its
        vertices, edges or faces exactly or to rounding (the degenerate examples): there
        the robust registration gives 0. (With perturbations at the tolerances' scale a
        vertex may legitimately be within τ of two edges meeting at a sharp angle.)"""
        return self.mislocated(inside) + self.broken_walks()

    def broken_walks(self) -> int:
        """Inconsistency count: cutting edges whose registered events do not form a
        walk through the simulation mesh.

        The events of a cutting edge PQ are the locations of P and Q (the simulation
        primitive each is registered with) and, ordered along PQ by their weights, the
        simulation vertices on it (vertex_edge) and the simulation edges (edge_edge) and
        faces (3D triangle_edge) it crosses. Between two consecutive events PQ runs
        inside one cell, so each consecutive pair of event primitives must lie in a
        common cell. Only edges with both endpoints located are checked. The robust
        registration gives 0; a naive one breaks walks where two cells disagree about a
        shared vertex, edge or face. (Pure Python: meant for examples, not for large
        meshes.)"""
        import itertools

        cells = set()
        for c in self.sim_cells.tolist():
            for r in range(1, len(c) + 1):
                cells.update(frozenset(x) for x in itertools.combinations(c, r))
        loc = {}
        events = {}
        for kind in self.kinds:
            p = self.pairs[kind]
            if p.cut.shape[1] == 1:
                for s, c in zip(p.sim.tolist(), p.cut[:, 0].tolist()):
                    loc.setdefault(c, []).append(frozenset(s))
            elif p.cut.shape[1] == 2:
                for s, c, w in zip(p.sim.tolist(), p.cut.tolist(), p.cut_weights.tolist()):
                    key = tuple(sorted(c))
                    t = w[1] if c[0] == key[0] else w[0]  # weight of the larger id
                    events.setdefault(key, []).append((t, frozenset(s)))
        broken = 0
        cut_edges = {tuple(sorted(e)) for c in self.cut_cells.tolist()
                     for e in itertools.combinations(c, 2)}
        for a, b in sorted(cut_edges):
            if len(loc.get(a, ())) != 1 or len(loc.get(b, ())) != 1:
                continue
            walk = [loc[a][0]] + [x for _, x in sorted(events.get((a, b), []),
                                                      key=lambda e: e[0])] + [loc[b][0]]
            if any(x | y not in cells for x, y in zip(walk, walk[1:])):
                broken += 1
        return broken

    def to_meshio(self):
        """The intersection points as a ``meshio.Mesh`` of vertex cells, with point data
        ``kind`` (index into ``res.kinds``), ``sim_ids`` / ``cut_ids`` (vertex ids of the
        pair's primitives, −1 padded) and ``sim_weights`` / ``cut_weights``. Points are
        Σ wᵢ·xᵢ on the simulation primitive, in 3D (z = 0 for 2D meshes)."""
        import meshio

        pts, kind, sid, cid, sw, cw = [], [], [], [], [], []
        ws, wc = self.dim + 1, self.dim
        for code, k in enumerate(self.kinds):
            p = self.pairs[k]
            m = len(p)
            pts.append(p.points(self.sim_points, "sim"))
            kind.append(np.full(m, code, dtype=np.int32))
            sid.append(_pad(p.sim, ws, -1))
            cid.append(_pad(p.cut, wc, -1))
            sw.append(_pad(p.sim_weights.astype(np.float64), ws, 0.0))
            cw.append(_pad(p.cut_weights.astype(np.float64), wc, 0.0))
        X = np.concatenate(pts) if pts else np.zeros((0, self.dim))
        if X.shape[1] == 2:
            X = np.column_stack([X, np.zeros(len(X))])
        cells = [("vertex", np.arange(len(X), dtype=np.int64)[:, None])]
        data = {"kind": np.concatenate(kind), "sim_ids": np.concatenate(sid),
                "cut_ids": np.concatenate(cid), "sim_weights": np.concatenate(sw),
                "cut_weights": np.concatenate(cw)}
        return meshio.Mesh(X, cells, point_data=data)

    def split(self):
        """The virtual-node split of the simulation mesh along the cut
        (:func:`predicates.registration.split.split_mesh`; rules in docs/split.md)."""
        from .split import split_mesh  # lazy: the split is a layer on top of the result

        return split_mesh(self)

    def __str__(self):
        dt = "binary64" if self.dtype == np.float64 else "binary32"
        cellname = {2: ("triangles", "segments"), 3: ("tetrahedra", "triangles")}[self.dim]
        lines = [f"{self.dim}D registration ({dt}): simulation mesh {len(self.sim_cells)} "
                 f"{cellname[0]}, cutting mesh {len(self.cut_cells)} {cellname[1]}"]
        if self.tolerance_scale != 1:
            lines.append(f"NAIVE BASELINE: tolerances × {self.tolerance_scale:g}")
        if self.rounded_inputs:
            lines.append(f"note: input coordinates were rounded to {self.dtype}")
        tu = self.tolerances_input_units()
        lines.append(f"L_a = {self.L_a:.6g}, L_b = {self.L_b:.6g}, L = {tu['L']:.6g}; "
                     f"coordinates scaled by 2^{-self.scale_exponent} (exact)")
        names = [n for n in tu if n != "L"]
        lines.append("tolerances (input units): " + ", ".join(
            f"{n} = {tu[n] * self.tolerance_scale:.4g}" for n in names))
        if self.resolution is not None:
            lines.extend(self.resolution.lines())
        w = max(len(k) for k in self.kinds)
        lines.append(f"{'kind':<{w}}  {'candidates':>10}  {'suppressed':>10}  "
                     f"{'tested':>10}  {'registered':>10}")
        for k in self.kinds:
            p = self.pairs[k]
            lines.append(f"{k:<{w}}  {p.candidates:>10}  {p.suppressed:>10}  {p.tested:>10}  "
                         f"{len(p):>10}")
        lines.append(f"{'total':<{w}}  {'':>10}  {'':>10}  {'':>10}  {self.total:>10}")
        if "total" in self.timings:
            lines.append(f"time: {self.timings['total']:.3f} s")
        return "\n".join(lines)


def _pad(a, width, fill):
    out = np.full((len(a), width), fill, dtype=a.dtype)
    out[:, : a.shape[1]] = a
    return out
