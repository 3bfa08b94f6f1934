"""The result of :func:`predicates.registration.intersect` (section 1 of the paper):
registered pairs per kind, readable summary, consistency counts, analysis and export
(meshio/ParaView, dict/JSON, pandas)."""
from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from predicates.registration.result import consistency, export
from predicates.registration.result.pairs import KIND_CODES, KindPairs, any_corner

__all__ = ["KIND_CODES", "IntersectionResult", "KindPairs"]

def _input_units(tol, e: int, dim: int):
    """The :class:`~predicates.Tolerances` ``tol`` (for coordinates scaled by 2^-e) in
    the input's units: T·2^(e·p), L·2^e (float64; inf/0 if that overflows/underflows
    binary64 — the registration itself never does)."""
    from predicates.tolerance_table import TABLES
    from predicates.tolerances import Tolerances

    table = getattr(tol, "table", None)
    with np.errstate(all="ignore"):
        vals = {name: float(np.ldexp(np.float64(tol.values[name]), e * spec.p))
                for name, spec in (table or TABLES[dim]).items() if name in tol.values}
        L = float(np.ldexp(np.float64(tol.L), e))
    return Tolerances(tol.dim, L, tol.eps, tol.ctx, vals, table)


@dataclass(eq=False)
class IntersectionResult(Mapping):
    """Registered intersections of a simulation mesh with a cutting mesh.

    A mapping from kind name to :class:`KindPairs`: ``res.kinds`` (registration order),
    ``res[kind]``, ``len(res)`` (number of kinds), ``for kind in res``. ``res.counts``:
    {kind: number registered}; ``res.tolerances``: the :class:`predicates.Tolerances`
    used, in the INPUT's units (the run used them on coordinates scaled exactly by
    ``2**-res.scale_exponent``); ``res.intersected_cells()``: the cut simulation cells;
    ``res.notes``: what was done to the input (second-order cells, boundaries, regions).
    ``str(res)``: a readable summary; ``res.to_meshio()`` / ``res.sim_mesh()``: for
    ParaView; ``res.to_dict()`` / ``res.to_dataframe()``: for analysis.

    ``res.sim_points`` is the validated simulation points (N, dim) in the working dtype
    (points no cell uses are 0) — a numpy array, or, for pieces read by the workers
    (docs/partitioned.md 6), a dask array computed where the points are: nothing of
    size N reaches the client until asked (``np.asarray``, a pair's coordinates,
    ``to_meshio``), while the scheduler that holds them is open; ``res.sim_cells`` is
    likewise a dask array when the cells stayed on the workers.
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
    notes: list = field(default_factory=list)
    plane: float | None = None
    #: what the run resolves (a predicates.registration.plan.resolution.Resolution) and the
    #: cutting mesh's refinement (refine.Refinement: cut_origin, input_weights), or None;
    #: with a refinement, cut_points / cut_cells are the refined mesh the ids refer to
    resolution: object = None
    refinement: object = None

    def __post_init__(self):
        # constructed with the tolerances of the scaled run; the public attribute is in
        # the input's units, the scaled values stay private
        self._scaled_tolerances = self.tolerances
        self.tolerances = _input_units(self.tolerances, self.scale_exponent, self.dim)
        self.notes = list(self.notes)
        if hasattr(self.sim_points, "to_dask"):  # points kept on the workers (pieces)
            self.sim_points = self.sim_points.to_dask()
        for p in self.pairs.values():
            p._points = (self.sim_points, self.cut_points)
            p._sim_cells = self.sim_cells

    # arrays make field-wise equality meaningless: a result equals only itself
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    # -- mapping over kinds ----------------------------------------------------------
    def __getitem__(self, kind: str) -> KindPairs:
        try:
            return self.pairs[kind]
        except (KeyError, TypeError):
            raise KeyError(f"no kind {kind!r} in {self.dim}D; kinds: {', '.join(self.kinds)}") \
                from None

    def __iter__(self):
        return iter(self.kinds)

    def __len__(self):
        return len(self.kinds)

    def __contains__(self, kind) -> bool:
        return kind in self.pairs

    def items(self):
        """[(kind, KindPairs)] in registration order (a list, as before; ``dict(res)``
        and the rest of ``collections.abc.Mapping`` work too)."""
        return [(k, self.pairs[k]) for k in self.kinds]

    @property
    def counts(self) -> dict:
        return {k: len(self.pairs[k]) for k in self.kinds}

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def tolerances_input_units(self) -> dict:
        """``res.tolerances`` as {name: float} with ``L`` (kept for older callers)."""
        return {"L": float(self.tolerances.L),
                **{k: float(v) for k, v in self.tolerances.values.items()}}

    # -- analysis ----------------------------------------------------------------------
    def _kinds(self, kind) -> list:
        if kind is None:
            return list(self.kinds)
        ks = [kind] if isinstance(kind, str) else list(kind)
        for k in ks:
            self[k]  # raises a KeyError naming the kinds
        return ks

    def intersected_cells(self, kind=None) -> np.ndarray:
        """Indices (sorted) of the simulation cells with at least one registered pair on
        one of their faces (vertex, edge, face or the cell itself); ``kind``: only pairs
        of that kind (a name or a list of names)."""
        return np.flatnonzero(self._cut_mask(self._kinds(kind)))

    def _cut_mask(self, kinds) -> np.ndarray:
        """(C,) bool: cells with a registered simulation primitive of ``kinds`` on one of
        their faces."""
        masks = self.cut_masks(kinds)
        return np.logical_or.reduce(list(masks.values())) if masks else \
            np.zeros(len(self.sim_cells), dtype=bool)

    def cut_masks(self, kinds) -> dict:
        """{kind: (C,) bool} for every kind of ``kinds`` with pairs. Only the cells with a
        vertex on a registered primitive are examined (one gather over the cells), and
        each face width is formed once for all kinds: the cost follows the cut. Kept
        for the next call (``intersected_cells`` and ``sim_mesh`` both need it); a
        result's pairs are not meant to change, but new arrays are noticed."""
        key = tuple((x, id(self.pairs[x].sim), len(self.pairs[x].sim)) for x in kinds)
        cache = self.__dict__.setdefault("_cut_masks", {})
        if key not in cache:
            cache.clear()
            cache[key] = self._cut_masks_of(kinds)
        return dict(cache[key])

    def _cut_masks_of(self, kinds) -> dict:
        cells = self.sim_cells
        prims = {x: self.pairs[x].sim for x in kinds if len(self.pairs[x].sim)}
        if not prims:
            return {}
        on = np.zeros(len(self.sim_points), dtype=bool)
        for p in prims.values():
            on[p.ravel()] = True
        near = np.flatnonzero(any_corner(on, cells))
        # faces of sorted rows are sorted (np.asarray: cells on Dask workers, near rows)
        sub, k = np.sort(np.asarray(cells[near]), axis=1), cells.shape[1]
        faces = {}
        out = {}
        for kind, p in prims.items():
            r = p.shape[1]
            if r not in faces:
                combos = list(itertools.combinations(range(k), r))
                faces[r] = sub[:, combos].reshape(-1, r)
            found = consistency.rows_in(faces[r], np.sort(p, axis=1))
            out[kind] = np.zeros(len(cells), dtype=bool)
            out[kind][near] = found.reshape(len(sub), -1).any(axis=1)
        return out

    def to_dict(self, pairs: bool = False) -> dict:
        """Plain data (JSON-ready): sizes, counts per kind, tolerances in input units,
        notes, timings (and with ``pairs=True`` the ids, weights, simulation cell and
        points of every pair). A ``resolution`` report is included when the run made one."""
        return export.to_dict(self, pairs)

    def to_dataframe(self):
        """One row per registered pair, flat columns: ``kind`` (categorical),
        ``sim_cell``, ``sim_0..sim_d`` and ``cut_0..cut_{d-1}`` (vertex ids, −1 padded),
        ``w_sim_*`` / ``w_cut_*`` (weights, 0 padded), the point's ``x, y (, z)`` and, on a
        refined cutting mesh, ``cut_input_cell`` / ``w_cut_input_*`` (:meth:`cut_input`).
        Needs pandas (not a dependency of fperr)."""
        return export.to_dataframe(self)

    # -- consistency -----------------------------------------------------------------
    def location_counts(self, side: str = "cut") -> np.ndarray:
        """For every point of the ``side`` mesh ("cut" or "sim"): in how many registered
        pairs that vertex is itself the primitive (vertex_vertex, edge_vertex,
        triangle_vertex, ... for "cut"; vertex_* for "sim"). In a consistent registration
        a cutting vertex inside the simulation mesh is located exactly once."""
        return consistency.location_counts(self, side)

    def mislocated(self, inside) -> int:
        """Inconsistency count: cutting vertices marked ``inside`` (a bool per cutting
        point: known to lie inside the simulation mesh) that are not located exactly
        once — registered with no simulation primitive (the cut falls through a crack)
        or with several (counted twice). A consistent registration gives 0. With a
        refined cutting mesh, ``inside`` may cover the input points only (the vertices
        the refinement appended count as unknown)."""
        return len(self.mislocated_vertices(inside))

    def mislocated_vertices(self, inside) -> np.ndarray:
        """The ids (into ``cut_points``) counted by :meth:`mislocated`."""
        used = np.zeros(len(self.cut_points), dtype=bool)
        used[np.unique(self.cut_cells)] = True
        bad = self.cut_point_mask(inside) & used & (self.location_counts("cut") != 1)
        return np.flatnonzero(bad)

    def cut_point_mask(self, mask) -> np.ndarray:
        """A bool per point of ``cut_points`` from ``mask``, a bool per point of the
        cutting mesh as given or as registered. With a refined cutting mesh the input
        points come first with their ids (:class:`~.refine.Refinement`), so an input mask
        is extended with False for the points the refinement appended (unknown)."""
        mask = np.asarray(mask, dtype=bool).ravel()
        n, n_in = len(self.cut_points), self.input_cut_points
        if len(mask) == n:
            return mask
        if len(mask) == n_in:
            return np.concatenate([mask, np.zeros(n - n_in, dtype=bool)])
        raise ValueError(f"the mask has {len(mask)} entries; the cutting mesh has {n_in} "
                         f"points as given and {n} as registered (refined)")

    @property
    def input_cut_points(self) -> int:
        """How many points the cutting mesh had as given: the first ids of
        ``cut_points``, which may continue with the refinement's midpoints."""
        ref = self.refinement
        return len(self.cut_points) if ref is None else int(ref.input_points)

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
        shared vertex, edge or face. Vectorised (:mod:`~predicates.registration.result.consistency`)."""
        return consistency.broken_walks(self)

    # -- export ------------------------------------------------------------------------
    def kind_legend(self) -> dict:
        """{kind name: code} of this dimension's kinds (:data:`KIND_CODES`)."""
        return {k: KIND_CODES[k] for k in self.kinds}

    def to_meshio(self):
        """The intersection points as a ``meshio.Mesh`` of vertex cells (for ParaView),
        with point data ``kind`` (code of :data:`KIND_CODES`, the same in 2D and 3D; its
        legend is the field data {kind name: [code]}), ``is_<kind>`` (0/1 per kind, to
        colour or threshold by name), ``sim_ids`` / ``cut_ids`` (vertex ids of the pair's
        primitives, −1 padded), ``sim_weights`` / ``cut_weights`` and ``sim_cell``
        (:attr:`KindPairs.sim_cell`). Points are Σ wᵢ·xᵢ on the simulation primitive, in
        3D (a 2D mesh in its plane z = c). When the cutting mesh was refined
        (:attr:`cut_refined`), ``cut_ids`` number the refined mesh's points, and
        ``cut_input_cell`` / ``cut_input_weights`` give each point on the cutting mesh as
        given (:meth:`cut_input`)."""
        return export.to_meshio(self)

    @property
    def cut_refined(self) -> bool:
        """True when the registration ran on a refined cutting mesh (``cut_ids`` then
        number the refined mesh's points; :meth:`cut_input` maps back)."""
        return self.refinement is not None and bool(self.refinement.refined)

    def cut_input(self, kind: str) -> tuple[np.ndarray, np.ndarray]:
        """For each pair of ``kind``: (the cutting cell as given (m,) int64 that holds the
        pair's cutting primitive, the point's barycentric weights on that cell's vertices
        (m, dim) float64). Without refinement: the first input cell with that primitive
        and the pair's weights spread on its vertices."""
        p = self.pairs[kind]
        ref = self.refinement
        if ref is None:  # refinement off: the input is the registered mesh
            from predicates.registration.plan.refine import Refinement

            k = self.cut_cells.shape[1]
            ref = Refinement(self.cut_points, self.cut_cells,
                             np.arange(len(self.cut_cells)),
                             np.broadcast_to(np.eye(k), (len(self.cut_cells), k, k)), 0,
                             len(self.cut_cells), len(self.cut_points))
        return ref.input_weights(p.cut, p.cut_weights)

    def sim_mesh(self):
        """The simulation mesh as a ``meshio.Mesh`` with cell data to threshold on:
        ``cut`` (1 for the cells of :meth:`intersected_cells`), ``cut_kinds`` (bit
        code−1 set for every kind cutting the cell) and ``cut_by_<kind>`` (0/1 per kind);
        field data: the kind legend {name: [code]}."""
        return export.sim_mesh(self)

    # -- text --------------------------------------------------------------------------
    def status_notes(self) -> list:
        """Notes on what the run found: an empty cutting mesh, no intersections and why."""
        if len(self.cut_cells) == 0:
            return ["the cutting mesh is empty: nothing to register"]
        if self.total:
            return []
        box = [(p[np.unique(c)].min(axis=0), p[np.unique(c)].max(axis=0))
               for p, c in ((self.sim_points, self.sim_cells), (self.cut_points, self.cut_cells))]
        apart = np.any(box[0][1] < box[1][0]) or np.any(box[1][1] < box[0][0])
        return ["no intersections: the meshes' bounding boxes do not overlap" if apart else
                "no intersections: the meshes do not meet"]

    def __repr__(self):
        dt = np.dtype(self.dtype).name
        naive = ", naive" if self.tolerance_scale != 1 else ""
        return (f"<IntersectionResult {self.dim}D {dt}{naive}: {self.total} pairs "
                f"({', '.join(f'{k} {n}' for k, n in self.counts.items() if n) or 'none'}); "
                f"{len(self.sim_cells)} simulation cells, {len(self.cut_cells)} cutting "
                "cells>")

    def split(self):
        """The virtual-node split of the simulation mesh along the cut
        (:func:`predicates.registration.split.mesh.split_mesh`; rules in docs/split.md)."""
        from predicates.registration.split.mesh import split_mesh  # lazy: the split is a layer on top of the result

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
        lines += [f"note: {n}" for n in self.notes + self.status_notes()]
        tu = self.tolerances_input_units()
        lines.append(f"L_a = {self.L_a:.6g}, L_b = {self.L_b:.6g}, L = {tu['L']:.6g}; "
                     f"coordinates × 2^{-self.scale_exponent} (exact; scale_exponent = "
                     f"{self.scale_exponent}: input = used × 2^scale_exponent)")
        lines.append("tolerances (input units): " + ", ".join(
            f"{n} = {v:.4g}" for n, v in tu.items() if n != "L"))
        if self.resolution is not None:
            lines.extend(self.resolution.lines())
        w = max(len(k) for k in self.kinds)
        lines.append(f"{'kind':<{w}}  {'candidates':>10}  {'suppressed':>10}  "
                     f"{'tested':>10}  {'registered':>10}")
        for k, p in self.items():
            lines.append(f"{k:<{w}}  {p.candidates:>10}  {p.suppressed:>10}  {p.tested:>10}  "
                         f"{len(p):>10}")
        lines.append(f"{'total':<{w}}  {'':>10}  {'':>10}  {'':>10}  {self.total:>10}")
        if "total" in self.timings:
            lines.append(f"time: {self.timings['total']:.3f} s")
        lines += _partition_lines(self.timings.get("partitions"))
        return "\n".join(lines)


def _partition_lines(parts) -> list[str]:
    """A partitioned run's tasks, workers and their peak memory (``timings["partitions"]``
    of :mod:`~predicates.registration.partition.run`), for ``str(result)``."""
    if not parts:
        return []
    peak: dict = {}
    for p in parts:  # a worker process: its host and pid; its peak over its tasks
        key = (p.get("host"), p["pid"])
        peak[key] = max(peak.get(key, 0.0), p["peak_rss_mib"])
    lo, hi = min(peak.values()), max(peak.values())
    mem = f"{lo:.0f} MiB" if round(lo) == round(hi) else f"{lo:.0f}–{hi:.0f} MiB"
    sent = sum(p["bytes_in"] for p in parts) / 1e6
    back = sum(p["bytes_out"] for p in parts) / 1e6
    tasks = f"{len(parts)} task{'s' if len(parts) != 1 else ''}"
    workers = f"{len(peak)} worker process{'es' if len(peak) != 1 else ''}"
    return [f"partitions: {tasks} on {workers}, peak memory "
            f"per worker {mem}; {sent:.3g} MB sent to them, {back:.3g} MB back "
            f"(candidates, suppressed, tested: summed over the partitions)"]
