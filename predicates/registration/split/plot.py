"""Pictures of a virtual-node split (docs/split.md), with matplotlib (Agg backend).

2D: the new cells filled, coloured by piece, the pieces moved apart (``explode``).
3D: the boundary faces of every piece (faces of its new cells that no other cell of the
piece shares, by node ids), Lambert-shaded, coloured by piece, moved apart; ``clip``
keeps only the cells whose original centroid lies on one side of an axis-aligned plane,
to look inside (a cube cut by a sphere). Cells cut into fragments are drawn lighter.
Every new cell is drawn whole, virtual corners included, as the virtual node algorithm
simulates it; the cut surface embedded in them
(:mod:`~predicates.registration.split.surface`: its polygons, 2D segments) is drawn
over the pieces in dark red. 3D is projected by an exact rotation and drawn back to
front on plain 2D axes (:mod:`~predicates.registration.pictures.view`): the same pixels
on every machine.
"""
from __future__ import annotations

import numpy as np

__all__ = ["draw_pieces", "plot_split"]

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
    key = np.sort(faces, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = cnt[inv.ravel()] == 1
    return faces[once], np.tile(frag, 4)[once]


def _surface_polygons(sm, surface, explode, clip):
    """The cut polygons (2D: segments) as coordinate lists, each moved with the
    highest-numbered piece among the fragments of the cells its cutting cell passes
    through (one side for the whole surface when it bounds a piece: the inner one of
    nested pieces; a cell the cut only grazes, whose fragments are all one piece, does
    not pull its polygon over the other piece), clipped like the cells."""
    off = sm.explode_offsets(explode)
    top = np.zeros(int(sm.cell_origin.max(initial=-1)) + 1, dtype=np.int64)
    np.maximum.at(top, sm.cell_origin, sm.piece)  # the last piece among the cell's fragments
    by_cut = np.zeros(int(surface.cut_cell.max(initial=-1)) + 1, dtype=np.int64)
    np.maximum.at(by_cut, surface.cut_cell, top[surface.cell])
    move = off[by_cut[surface.cut_cell]]
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
    pieces (dark red; moved with the highest-numbered piece of its cell's fragments)."""
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
