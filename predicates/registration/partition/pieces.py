"""A simulation mesh stored in pieces that the workers read (docs/partitioned.md, section
6, "Pieces with global point ids"): the cells never pass through the client.

Format: each piece is a mesh file meshio reads (.vtu is what ParaView's partitioned
writers produce) holding some of the mesh's cells — tetrahedra (3D) or triangles (2D,
points with z or in a plane z = c), converted as a whole file is
(:func:`~predicates.registration.io.convert.convert_sim`) — and, as point data named
:data:`GLOBAL_IDS` (ParaView's name), the global id of each of its points: integers
0 … N − 1, every id used by some piece, a point shared by pieces having bit-identical
coordinates in each. The mesh is: point g at its coordinates, the cells of the pieces
in the order the pieces are given, each piece's in its file's order, in global ids.

Each worker reads its pieces once; the client receives per piece a few numbers. The
points stay on the workers (:mod:`.points`: exchanged there into ranges of global ids,
the shared points compared where they meet; the plan checks them and scales the run's
vertices there, only those coming back); the cells stay on the workers as the chunks
of a dask array, which the plan's per-chunk passes (:mod:`.remote`, on each piece's own
points) and the split's gather of the cells that can meet use.
"""
from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from predicates.registration.io.convert import Converted
from predicates.registration.io.read import MeshFileError
from predicates.registration.partition.points import points_on_workers

__all__ = ["GLOBAL_IDS", "NoGlobalIds", "Piece", "read_piece", "read_pieces_on_workers"]

#: the point-data array holding each point's global id (ParaView's GlobalNodeIds)
GLOBAL_IDS = "GlobalNodeIds"


class NoGlobalIds(MeshFileError):
    """A piece without :data:`GLOBAL_IDS`: the workers cannot place its points (the
    command line then reads the pieces on the client, merging shared points)."""


class Piece(NamedTuple):
    """One piece as read on a worker: its points' global ids and coordinates, its cells
    in global ids (int64), the mesh's dimension, its plane (2D stored with z), notes
    and its cells in its own point numbering (``local``: the plan's per-chunk box
    passes read the piece's own coordinates, :mod:`.remote`)."""

    ids: np.ndarray
    points: np.ndarray
    cells: np.ndarray
    dim: int
    plane: float | None
    notes: list
    local: np.ndarray | None = None


def read_piece(path: str | os.PathLike, region=None) -> Piece:
    """Read one piece (on a worker): converted as a whole simulation file is, its cells
    renumbered to global ids through its :data:`GLOBAL_IDS`. Errors name the file."""
    from predicates.registration.io.convert import convert_sim
    from predicates.registration.io.read import read_mesh

    mesh = read_mesh(path)
    try:
        dim, conv = convert_sim(mesh, region)
    except (ValueError, TypeError) as e:
        raise MeshFileError(path, e) from None
    ids = (mesh.point_data or {}).get(GLOBAL_IDS)
    if ids is None:
        raise NoGlobalIds(path, f"a piece read by the workers needs its points' global "
                                  f"ids as point data '{GLOBAL_IDS}' (docs/partitioned.md "
                                  f"section 6); without them give the pieces to the "
                                  f"client's reader (several SIM files, without workers)")
    ids = np.asarray(ids).reshape(len(conv.points), -1)
    if ids.shape[1] != 1 or ids.dtype.kind not in "iu" or (len(ids) and ids.min() < 0):
        raise MeshFileError(path, f"point data '{GLOBAL_IDS}' must be one non-negative "
                                  f"integer per point, got dtype {ids.dtype} shape "
                                  f"{ids.shape}" + (f", minimum {ids.min()}" if
                                                    ids.dtype.kind in "iu" else ""))
    ids = ids[:, 0].astype(np.int64)
    cells = np.asarray(conv.cells)
    if cells.size and (cells.min() < 0 or cells.max() >= len(ids)):
        bad = cells.min() if cells.min() < 0 else cells.max()
        raise MeshFileError(path, f"a cell refers to point {bad} of a piece with "
                                  f"{len(ids)} points")
    # its own numbering as int32 when it fits: half the bytes kept beside the global ids
    local = cells.astype(np.int32) if len(ids) < 2 ** 31 else cells
    return Piece(ids, np.asarray(conv.points, dtype=np.float64), ids[cells], dim,
                 conv.plane, conv.notes, local)


def _head(piece: Piece):
    """What the client needs of a piece besides its points: (1 + its largest point id
    (0 if none), cell count, dim, plane, notes); its cells stay where it was read."""
    top = int(piece.ids.max()) + 1 if len(piece.ids) else 0
    return top, len(piece.cells), piece.dim, piece.plane, piece.notes


def _cells(piece: Piece) -> np.ndarray:
    return piece.cells


def _own(piece: Piece):
    """The piece's own points and cells: (coordinates, cells in local ids, cells in
    global ids) — what the plan's per-chunk passes read instead of every point."""
    return piece.points, piece.local, piece.cells


def read_pieces_on_workers(paths, scheduler, region=None):
    """The simulation mesh stored in ``paths`` (the format above) as a
    :class:`~predicates.registration.io.convert.Converted` (points, cells, notes,
    plane): points a :class:`~.points.RemotePoints` (held on the workers by ranges of
    global ids; ``np.asarray`` gathers them), cells a dask array with one chunk per
    piece, read by the workers of ``scheduler`` (a ``dask.distributed.Client``: each
    piece read once and kept there; a local Dask
    scheduler's name: read again wherever a chunk is needed). Pass both to
    :func:`predicates.intersect` with the same ``scheduler``: the run's plan and result
    are those of the mesh read serially (docs/partitioned.md section 6)."""
    import dask
    import dask.array as da

    paths = [os.fspath(p) for p in paths]
    if not paths:
        raise ValueError("no simulation piece given")
    client = None if isinstance(scheduler, str) else scheduler
    if client is not None:  # read once; the cells' chunks are views of what was read
        read = client.map(read_piece, paths, region=region, pure=False)
        heads = client.gather(client.map(_head, read, pure=False))
    else:
        read = [dask.delayed(read_piece, pure=True)(p, region) for p in paths]
        heads = dask.compute(*[dask.delayed(_head)(r) for r in read], scheduler=scheduler)
    check_heads(paths, heads)
    n = max((h[0] for h in heads), default=0)
    # the points stay on the workers, exchanged into ranges of global ids and checked
    # there (shared points compared where they meet): nothing per point on the client
    points = points_on_workers(paths, read, n, heads[0][2], client, scheduler)
    notes = [m for h in heads for m in h[4]]
    notes.append(f"{len(paths)} pieces read by the workers as one mesh ({n} points by "
                 f"their '{GLOBAL_IDS}', kept there)")
    dim, plane = heads[0][2], heads[0][3]
    chunks = [da.from_delayed(dask.delayed(_cells, pure=True)(r), shape=(h[1], dim + 1),
                              dtype=np.int64) for r, h in zip(read, heads) if h[1]]
    # no cells at all: the plan refuses the empty mesh
    cells = da.concatenate(chunks) if chunks else da.zeros((0, dim + 1), dtype=np.int64)
    own = [r for r, h in zip(read, heads) if h[1]]  # one per chunk, in the chunks' order
    if client is not None:  # the array holds its chunks' futures (the reads' are dropped)
        cells = client.persist(cells)
        own = client.map(_own, own, pure=False)  # views of what the workers read
    else:
        own = [dask.delayed(_own, pure=True)(r) for r in own]
    # the plan's per-chunk passes take each piece's own points from these (remote.py)
    cells.fperr_pieces = own
    return Converted(points, cells, notes, plane)


def check_heads(paths: list, heads: list) -> None:
    """Refuse, naming the piece, pieces whose dimensions or planes differ from the
    first's (before any coordinates are read): the pieces of one mesh share them."""
    dim, plane = heads[0][2], heads[0][3]
    for path, h in zip(paths, heads):
        if (h[2], h[3]) != (dim, plane):
            what = f"{h[2]}D" if h[2] != dim else f"in the plane z = {h[3]}"
            raise MeshFileError(path, f"this piece is {what}, the first piece {paths[0]} "
                                      f"is not: the pieces of one mesh share its "
                                      f"dimension and plane")
