"""Pictures of a virtual-node split (docs/split.md), with matplotlib (Agg backend).

2D: the new cells filled, coloured by piece, the pieces moved apart (``explode``).
3D: the boundary faces of every piece (faces of its new cells that no other cell of the
piece shares, by node ids), Lambert-shaded, coloured by piece, moved apart; ``clip``
keeps only the cells whose original centroid lies on one side of an axis-aligned plane,
to look inside (a cube cut by a sphere). Cells cut into fragments are drawn lighter.
Every new cell is drawn whole, virtual corners included, as the virtual node algorithm
simulates it; the cut surface embedded in them
(:mod:`~predicates.registration.split.surface`: its polygons, 2D segments) is drawn
over the pieces in dark red, each polygon moved with the piece behind it
(:func:`surface_pieces`, docs/split.md "Pictures"). 3D is projected by an exact rotation
and drawn back to front on plain 2D axes (:mod:`~predicates.registration.pictures.view`):
the same pixels on every machine.
"""
from __future__ import annotations

import numpy as np

from predicates.registration.levels.complex import single_rows

__all__ = ["draw_pieces", "plot_split", "surface_pieces"]

#: face colours of the pieces (cycled)
PIECE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple",
                 "tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:gray")


def _keep(sm, clip):
    if clip is None:
        return np.ones(len(sm.cells), dtype=bool)
    axis, value, sign = clip
    X = sm.points.astype(np.float64)[sm.cells].mean(axis=1)  # node copies sit on originals
    return sign * (X[:, axis] - value) >= 0


def _boundary_faces(cells: np.ndarray, frag: np.ndarray):
    """Faces (triangles, by node ids) of a set of tetrahedra that belong to one only,
    and whether that tetrahedron is a fragment of a cut cell."""
    faces = np.concatenate([np.delete(cells, k, axis=1) for k in range(4)])
    once = single_rows(np.sort(faces, axis=1))
    return faces[once], np.tile(frag, 4)[once]


def _behind_pieces(sm, surface) -> np.ndarray:
    """(Q,) the piece behind each cut polygon where one of its points decides it, else
    −1. A point decides when it is a crossing of a simulation edge (u, v) with the
    interior of the polygon's cutting cell, the only registered point on that edge, u
    and v off the cut: the edge's end strictly on the side the cutting cell's normal
    points away from (2D: left of the segment, as in docs/split.md "Volumes and
    moments"), by exact orientation on the stored coordinates
    (``tetra_faces.positive``), reaches the polygon without crossing the cut; its piece
    (the piece of its one material node) is behind the polygon."""
    from predicates.registration.split.tetra_faces import positive

    d, Q, src = sm.dim, len(surface), sm.source
    out = np.full(Q, -1, dtype=np.int64)
    if Q == 0 or src is None:
        return out
    on_edge = (surface.sim >= 0).sum(axis=1) == 2
    ends = np.sort(surface.sim[:, :2], axis=1)
    _, inv, cnt = np.unique(ends[on_edge], axis=0, return_inverse=True, return_counts=True)
    once = np.zeros(len(ends), dtype=bool)
    once[np.flatnonzero(on_edge)] = cnt[inv.ravel()] == 1
    u, v = surface.sim[:, 0], surface.sim[:, 1]
    decides = once & (surface.cut >= 0).all(axis=1) & ~sm.on_cut[u] & ~sm.on_cut[v]
    q = np.repeat(np.arange(Q), surface.sizes())
    h = surface.index
    q, h = q[decides[h]], h[decides[h]]
    if len(h) == 0:
        return out
    Y = np.asarray(src.cut_points, dtype=np.float64)
    X = np.concatenate([Y, np.asarray(src.sim_points, dtype=np.float64)])
    cutting = np.asarray(src.cut_cells, dtype=np.int64)[surface.cut_cell[q]]
    su = positive(np.column_stack([cutting, len(Y) + u[h]]), X)
    sv = positive(np.column_stack([cutting, len(Y) + v[h]]), X)
    if d == 2:  # behind is left of the segment: positive in 2D
        su, sv = -su, -sv
    vertex_piece = np.full(len(sm.on_cut), -1, dtype=np.int64)
    slot = sm.material
    vertex_piece[sm.node_origin[sm.cells[slot]]] = np.broadcast_to(
        sm.piece[:, None], slot.shape)[slot]
    end = np.where(su < 0, u[h], v[h])
    ok = su * sv < 0
    lo, hi = np.full(Q, sm.n_pieces), np.full(Q, -1, dtype=np.int64)
    np.minimum.at(lo, q[ok], vertex_piece[end[ok]])
    np.maximum.at(hi, q[ok], vertex_piece[end[ok]])
    out[hi == lo] = hi[hi == lo]
    return out


def _neighbour_pairs(surface) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of cut polygons sharing an edge (2D: segments sharing a point), both ways;
    points are shared between neighbouring cells, so this follows the surface."""
    Q, idx = len(surface), surface.index
    q = np.repeat(np.arange(Q), surface.sizes())
    if surface.dim == 3:
        nxt = np.arange(1, len(idx) + 1)
        nxt[surface.offsets[1:] - 1] = surface.offsets[:-1]  # cyclic within a polygon
        a, b = np.minimum(idx, idx[nxt]), np.maximum(idx, idx[nxt])
    else:
        a = b = idx
    o = np.lexsort((q, b, a))
    a, b, q = a[o], b[o], q[o]
    first = np.ones(len(q), dtype=bool)
    first[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1])
    head = q[np.flatnonzero(first)[np.cumsum(first) - 1]]  # a star per shared edge
    return np.concatenate([head, q]), np.concatenate([q, head])


def surface_pieces(sm, surface) -> np.ndarray:
    """(Q,) the piece each cut polygon is drawn with (docs/split.md, "Pictures"): the
    piece behind it (:func:`_behind_pieces`: the side its cutting cell's normal points
    away from, the inside of an outward closed surface), spread across shared edges to
    the polygons that do not decide it (a cap of the cut bulging into a cell with no
    corner behind it, several polygons in a cell), so a closed surface bounding one
    piece moves with it as a whole; a part of the surface where nothing decides keeps
    the highest-numbered piece among the fragments of the cells its cutting cell
    passes through."""
    piece = _behind_pieces(sm, surface)
    src, dst = _neighbour_pairs(surface)
    for _ in range(len(piece)):  # one ring of polygons a round
        ok = (piece[src] >= 0) & (piece[dst] < 0)
        if not ok.any():
            break
        cand = np.full(len(piece), -1, dtype=np.int64)
        np.maximum.at(cand, dst[ok], piece[src[ok]])
        piece = np.where(piece < 0, cand, piece)
    rest = piece < 0
    if rest.any():
        top = np.zeros(int(sm.cell_origin.max(initial=-1)) + 1, dtype=np.int64)
        np.maximum.at(top, sm.cell_origin, sm.piece)
        by_cut = np.zeros(int(surface.cut_cell.max(initial=-1)) + 1, dtype=np.int64)
        np.maximum.at(by_cut, surface.cut_cell, top[surface.cell])
        piece[rest] = by_cut[surface.cut_cell[rest]]
    return piece


def _surface_polygons(sm, surface, explode, clip):
    """The cut polygons (2D: segments) as coordinate lists, each moved with its piece
    (:func:`surface_pieces`), clipped like the cells."""
    move = sm.explode_offsets(explode)[surface_pieces(sm, surface)]
    polys = []
    for q in range(len(surface)):
        P = surface.points[surface.polygon(q)].astype(np.float64)
        if clip is not None:
            axis, value, sign = clip
            if sign * (P[:, axis].mean() - value) < 0:
                continue
        polys.append(P + move[q])
    return polys


def draw_pieces(ax, sm, explode: float = 0.3, clip=None, light=(-0.4, -0.8, 0.6),
                surface=None, view=None) -> None:
    """Draw ``sm`` (a :class:`~predicates.registration.split.mesh.SplitMesh`) into a plain
    2D matplotlib axis; 3D meshes in ``view`` (a
    :class:`~predicates.registration.pictures.view.View`, default mplot3d's default
    angles: projected by exact rotations, pictures/view.py). ``clip``: (axis, value,
    sign): keep cells with sign·(centroid[axis] − value) ≥ 0. ``surface``: the cut surface
    (:class:`~predicates.registration.split.surface.CutSurface`), drawn over the
    pieces (dark red; each polygon moved with the piece behind it, :func:`surface_pieces`)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_rgb

    X = sm.exploded_points(explode)
    keep = _keep(sm, clip)
    cut = sm.cut_cells
    polys = [] if surface is None else _surface_polygons(sm, surface, explode, clip)
    if sm.dim == 2:
        for p in range(sm.n_pieces):
            for frag, alpha in ((False, 0.9), (True, 0.35)):  # fragments: lighter
                sel = sm.cells[keep & (sm.piece == p) & (cut == frag)]
                ax.add_collection(PolyCollection(
                    X[sel], facecolors=PIECE_COLOURS[p % len(PIECE_COLOURS)],
                    edgecolors="k", linewidths=0.3, alpha=alpha))
        if polys:
            from matplotlib.collections import LineCollection

            ax.add_collection(LineCollection(polys, colors="darkred", linewidths=1.6))
        ax.set_aspect("equal")
        ax.autoscale_view()
        return
    from predicates.registration.pictures.view import DEFAULT_VIEW, draw_faces, draw_frame, lambert

    v = view or DEFAULT_VIEW
    faces, rgba = [], []
    for p in range(sm.n_pieces):
        sel = sm.cells[keep & (sm.piece == p)]
        if len(sel) == 0:
            continue
        ids, frag = _boundary_faces(sel, cut[keep & (sm.piece == p)])
        F = X[ids]
        shade = 0.45 + 0.55 * lambert(F, light)
        rgb = np.clip(np.outer(shade, to_rgb(PIECE_COLOURS[p % len(PIECE_COLOURS)])), 0, 1)
        rgb[frag] = 0.45 * rgb[frag] + 0.55  # faces of fragments (cut cells): lighter
        faces.append(F)
        rgba.append(np.column_stack([rgb, np.where(frag & bool(polys), 0.2, 1.0)]))
    if faces:  # one collection: every piece's faces back to front together
        draw_faces(ax, v, np.concatenate(faces), np.concatenate(rgba),
                   edgecolors=(0, 0, 0, 0.25), linewidths=0.2, zorder=1)
    if polys:  # the cut surface, over the pieces (the fragments' faces see-through)
        shade = 0.35 + 0.65 * lambert(polys, light)
        rgba = np.column_stack([np.outer(shade, (0.8, 0.15, 0.1)), np.full(len(polys), 0.95)])
        draw_faces(ax, v, polys, rgba, edgecolors=(0.3, 0, 0, 0.3), linewidths=0.15,
                   zorder=2)
    draw_frame(ax, v, X.min(axis=0), X.max(axis=0))


def _figure(dim, panels=1):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # 3D too: plain axes, projected by pictures/view.py (mplot3d's projection differs
    # in its last bits between BLAS kernels and CPUs)
    fig, axes = plt.subplots(1, panels, figsize=(6.5 * panels, 6.5))
    return plt, fig, np.atleast_1d(axes)


def plot_split(sm, path: str, explode: float = 0.3, clip=None, title: str | None = None,
               surface=None):
    """Write a picture of the split ``sm`` to ``path`` (png, pdf or svg); ``surface``:
    the cut surface, drawn over the pieces."""
    plt, fig, (ax,) = _figure(sm.dim)
    draw_pieces(ax, sm, explode, clip, surface=surface)
    ax.set_title(title or f"{sm.n_pieces} piece{'s' if sm.n_pieces != 1 else ''}, "
                          f"{len(sm.cells)} cells (explode {explode:g})")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
