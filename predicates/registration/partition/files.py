"""Files of a partitioned mesh (docs/partitioned.md): one output file per partition
(``-o 'hits_{part}.vtu'``) and a simulation mesh stored as several pieces read as one."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["owners_of", "part_paths", "read_pieces", "vertex_owners", "write_parts"]


def part_paths(pattern: str | os.PathLike, k: int) -> list[str]:
    """The k file names ``pattern.format(part=r)`` (e.g. ``"hits_{part}.vtu"``);
    ValueError when ``pattern`` has no ``{part}`` or other braces."""
    pattern = os.fspath(pattern)
    if "{part}" not in pattern:
        raise ValueError(f"{pattern}: a per-partition file name must contain '{{part}}' "
                         f"(one file per partition, e.g. hits_{{part}}.vtu)")
    try:
        return [pattern.format(part=r) for r in range(k)]
    except (KeyError, IndexError, ValueError) as e:
        raise ValueError(f"{pattern}: only '{{part}}' may stand in braces in a "
                         f"per-partition file name ({type(e).__name__}: {e})") from None


def write_parts(res, k: int, pattern: str | os.PathLike) -> list[str]:
    """Write ``res`` (an IntersectionResult) as k files, ``pattern.format(part=r)``
    (e.g. ``"hits_{part}.vtu"``), file r holding the pairs owned by partition r of k
    (the run's rule — the smallest-id vertex of the simulation primitive — over all
    simulation cells).
    Every pair is in exactly one file; each file is what ``res.to_meshio()`` writes,
    restricted to its pairs, with the same kind legend (field data), written atomically
    as the merged output is; every path is checked before any is written. Returns the
    paths (a file is written even when empty)."""
    from dataclasses import replace

    from predicates.registration.io.files import check_output
    from predicates.registration.io.write import write_meshio
    from predicates.registration.partition.counts import count_partitions

    k = count_partitions(k, None, len(res.sim_cells))
    paths = part_paths(pattern, k)
    for path in paths:
        check_output(path, "mesh")
    owner = vertex_owners(res.sim_points, res.sim_cells, k)
    for r, path in enumerate(paths):
        sub = {}
        for kind in res.kinds:
            p = res[kind]
            keep = owner[p.sim.min(axis=1)] == r if len(p) else np.zeros(0, dtype=bool)
            sub[kind] = replace(p, sim=p.sim[keep], cut=p.cut[keep],
                                sim_weights=p.sim_weights[keep], cut_weights=p.cut_weights[keep])
        write_meshio(path, replace(res, pairs=sub).to_meshio())
    return paths


def vertex_owners(points: np.ndarray, cells, k: int, scheduler=None) -> np.ndarray:
    """Each vertex's owner among k partitions of all ``cells`` (the rule of
    :func:`~predicates.registration.partition.assign.assign`). ``cells`` may be a dask
    array (cells on the workers, docs/partitioned.md 6): each chunk's first vertices'
    hull, Morton codes and first cell per vertex are computed where the chunk is (the
    default Dask scheduler: a Client while one is open), and the client holds 8 bytes
    per cell (the codes) and their order, not the cells; the same owners bit for bit.
    ``scheduler``: the run's (a Client or a local scheduler's name; None: Dask's
    default)."""
    from predicates.registration.partition import assign as A

    if not hasattr(cells, "to_delayed"):
        return A.assign(points, cells, k)[1]
    import dask

    offsets = np.concatenate([[0], np.cumsum(cells.chunks[0])]).astype(np.int64)
    m, n = int(offsets[-1]), len(points)
    rows = [(p, o) for p, o, size in zip(cells.rechunk({1: -1}).to_delayed().ravel(),
                                         offsets, cells.chunks[0]) if size]
    parts, offsets = [p for p, _ in rows], [o for _, o in rows]
    pts = dask.delayed(np.asarray(points))  # one key: sent once, not per task
    run = {} if scheduler is None else {"scheduler": scheduler}
    hulls = dask.compute(*[dask.delayed(_first_hull)(p, pts) for p in parts], **run)
    lo = np.min([h[0] for h in hulls], axis=0)[:, None]  # min and max: exact, any order
    hi = np.max([h[1] for h in hulls], axis=0)[:, None]
    got = dask.compute(*[dask.delayed(_codes_and_first)(p, pts, lo, hi, int(o), m)
                         for p, o in zip(parts, offsets)], **run)
    first = np.full(n, m, dtype=np.int64)
    for _, f in got:
        np.minimum(first, f, out=first)
    pos = A.order_of(np.concatenate([c for c, _ in got]))
    return A.owners_from(pos, first, k)


def _first_hull(chunk, points):
    """A chunk's first vertices' per-axis minimum and maximum (on a worker)."""
    from predicates.registration.partition.assign import first_vertices

    c = first_vertices(points, np.asarray(chunk))
    return c.min(axis=1), c.max(axis=1)


def _codes_and_first(chunk, points, lo, hi, offset: int, m: int):
    """A chunk's Morton codes and, per vertex, its smallest global cell index (m where
    none) (on a worker)."""
    from predicates.registration.partition.assign import (
        first_cells, first_vertices, morton_codes)

    chunk = np.asarray(chunk)
    codes = morton_codes(first_vertices(points, chunk), lo, hi)
    return codes, first_cells(chunk, len(points), offset, none=m)


def owners_of(points: np.ndarray, cells, k: int, wanted: np.ndarray,
              scheduler=None) -> np.ndarray:
    """:func:`vertex_owners` of the vertices ``wanted`` (a bool per point; −1 for the
    others), for a run that writes one file per partition (:mod:`.outputs`: the run's
    vertices only). With ``cells`` a dask array the client sorts nothing: each chunk
    returns, per wanted vertex, its first cell there and that cell's Morton code; then,
    per distinct first cell, how many of the chunk's cells precede it in the (code,
    index) order — summed, its position in the Morton order of all cells. The client
    holds 8 bytes per point and ~24 per wanted vertex, not 24 per cell."""
    if not hasattr(cells, "to_delayed"):
        return np.where(wanted, _assign_owners(points, cells, k), -1)
    import dask

    run = {} if scheduler is None else {"scheduler": scheduler}
    offsets = np.concatenate([[0], np.cumsum(cells.chunks[0])]).astype(np.int64)
    m = int(offsets[-1])
    rows = [(p, int(o)) for p, o, size in zip(cells.rechunk({1: -1}).to_delayed().ravel(),
                                              offsets, cells.chunks[0]) if size]
    pts = _shared(dask, points, scheduler)
    hulls = dask.compute(*[dask.delayed(_first_hull)(p, pts) for p, _ in rows], **run)
    lo = np.min([h[0] for h in hulls], axis=0)[:, None]  # min and max: exact, any order
    hi = np.max([h[1] for h in hulls], axis=0)[:, None]
    ids = np.flatnonzero(wanted)
    firsts = dask.compute(*[dask.delayed(_wanted_first)(p, pts, lo, hi, o, m, ids)
                            for p, o in rows], **run)
    first = np.full(len(ids), m, dtype=np.int64)
    code = np.zeros(len(ids), dtype=np.uint64)
    for f, c in firsts:  # the smallest cell index wins, with its code
        better = f < first
        first[better], code[better] = f[better], c[better]
    cell, at = np.unique(first, return_inverse=True)  # (m last: wanted but in no cell)
    cell_code = np.zeros(len(cell), dtype=np.uint64)
    cell_code[at] = code
    before = dask.compute(*[dask.delayed(_cells_before)(p, pts, lo, hi, o, m, cell,
                                                        cell_code) for p, o in rows], **run)
    pos = np.sum(before, axis=0, dtype=np.int64)[at]
    out = np.full(len(points), -1, dtype=np.int64)
    out[ids] = np.where(first < m, pos * k // m, -1)
    return out


def _shared(dask, points, scheduler):
    """The points as one input of the tasks: on a Client scattered once to every worker
    (not in each graph: three computes would send them three times, with distributed's
    "large graph" warning), else one delayed key."""
    if hasattr(scheduler, "scatter"):
        return scheduler.scatter(np.asarray(points), broadcast=True, hash=False)
    return dask.delayed(np.asarray(points))


def _assign_owners(points, cells, k):
    """assign's vertex owners (numpy cells)."""
    from predicates.registration.partition.assign import assign

    return assign(points, cells, k)[1]


def _wanted_first(chunk, points, lo, hi, offset: int, m: int, ids):
    """Per wanted vertex ``ids``, its smallest global cell index in this chunk (m where
    none) and that cell's Morton code (on a worker)."""
    from predicates.registration.partition.assign import (
        first_cells, first_vertices, morton_codes)

    chunk = np.asarray(chunk)
    first = first_cells(chunk, len(points), offset, none=m)[ids]
    has = first < m
    code = np.zeros(len(ids), dtype=np.uint64)
    rows = chunk[first[has] - offset]
    code[has] = morton_codes(first_vertices(points, rows), lo, hi)
    return first, code


def _cells_before(chunk, points, lo, hi, offset: int, m: int, cell, cell_code):
    """Per query cell (global index ``cell``, Morton code ``cell_code``), the number of
    this chunk's cells before it in the stable Morton order of all cells — (code,
    index) lexicographically (on a worker)."""
    from predicates.registration.partition.assign import first_vertices, morton_codes

    chunk = np.asarray(chunk)
    codes = morton_codes(first_vertices(points, chunk), lo, hi)
    order = np.argsort(codes, kind="stable")  # equal codes: ascending index
    sorted_codes = codes[order]
    # (group of equal codes, index) as one int64 key, sorted: < 2^63 for any mesh of
    # fewer than 3·10^9 cells
    group = np.concatenate([[0], np.cumsum(sorted_codes[1:] != sorted_codes[:-1])])
    key = group.astype(np.int64) * m + (order.astype(np.int64) + offset)
    left = np.searchsorted(sorted_codes, cell_code, side="left")
    present = left < len(codes)
    present[present] = sorted_codes[left[present]] == cell_code[present]
    qkey = group[np.minimum(left, len(codes) - 1)].astype(np.int64) * m + cell
    return np.where(present, np.searchsorted(key, qkey, side="left"), left)


def read_pieces(paths) -> tuple[np.ndarray, np.ndarray]:
    """A simulation mesh stored as several files (pieces, any format meshio reads) as one
    ``(points, cells)``: the pieces' points concatenated with bit-identical coordinates
    merged (pieces share their boundary vertices), cells renumbered
    (:func:`~predicates.registration.io.files.merge_pieces`). The partitioned and the
    serial run of this mesh agree (it is one mesh). ``fperr intersect`` reads pieces
    given as several SIM files the same way."""
    from predicates.registration.io.files import merge_pieces, read_mesh
    from predicates.registration.plan.inputs import from_meshio

    pts, cells = [], []
    for path in paths:
        m = read_mesh(path)
        p, c, _, _ = from_meshio(m, _dummy_cut(m))
        pts.append(p)
        cells.append(c)
    if not pts:
        raise ValueError("read_pieces needs at least one mesh file")
    P, C, _ = merge_pieces(pts, cells)
    return P, C


def _dummy_cut(mesh):
    """An empty cutting mesh of the right cell type, so that :func:`from_meshio` reads a
    piece with the same rules as a whole mesh."""
    import meshio

    tets = any(b.type == "tetra" for b in mesh.cells)
    return meshio.Mesh(np.zeros((0, 3)), [("triangle" if tets else "line",
                                           np.zeros((0, 3 if tets else 2), dtype=np.int64))])
