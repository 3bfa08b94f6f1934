"""Pictures of the conforming tetrahedralization of the split (docs/split.md, "The
conforming tetrahedralization"), with matplotlib (Agg backend): the boundary triangles of
every piece (faces of its simplices no other simplex of the piece shares), Lambert-shaded
(elementwise, in a fixed order), the cut faces in a lighter tone of their piece,
the pieces moved apart — pieces whose centroids nearly coincide (a ball in its cavity)
side by side along x. ``clip`` keeps the simplices of some pieces on one side of an
axis-aligned plane only, to look into a cavity. 2D: the triangles filled by piece. 3D is
projected by an exact rotation and drawn back to front on plain 2D axes
(:mod:`~predicates.registration.pictures.view`): the same pixels on every machine."""
from __future__ import annotations

import numpy as np

from predicates.registration.split.plot import PIECE_COLOURS, _figure

__all__ = ["draw_conforming", "plot_conforming", "sphere_out_of_cube"]


def _offsets(cm, factor: float) -> np.ndarray:
    X = cm.points
    cen = np.stack([np.bincount(cm.piece, X[cm.cells][:, :, k].mean(axis=1), cm.n_pieces)
                    for k in range(cm.dim)], 1)
    cen /= np.maximum(np.bincount(cm.piece, minlength=cm.n_pieces), 1)[:, None]
    mid = X.mean(axis=0)
    off = factor * (cen - mid)
    ext = X.max(axis=0) - X.min(axis=0)
    nested = np.sqrt(((cen - mid) ** 2).sum(axis=1)) < 0.05 * np.sqrt((ext ** 2).sum())
    if factor and nested.sum() > 1:
        off[nested] = 0.0
        off[nested, 0] = np.arange(nested.sum()) * (1 + factor) * ext[0]
    return off


def _piece_boundary(cells: np.ndarray):
    faces = np.concatenate([cells[:, [1, 2, 3]], cells[:, [0, 3, 2]], cells[:, [0, 1, 3]],
                            cells[:, [0, 2, 1]]])
    _, inv, cnt = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                            return_counts=True)
    return faces[cnt[inv.ravel()] == 1]


def draw_conforming(ax, cm, explode: float = 0.3, clip=None, light=(-0.4, -0.8, 0.6),
                    view=None) -> None:
    """Draw ``cm`` into a plain 2D matplotlib axis; 3D in ``view`` (default mplot3d's
    default angles, projected by exact rotations: pictures/view.py). ``clip``: (pieces, axis,
    value): the simplices of those pieces whose centroid has coordinate ``axis`` ≥
    ``value`` only."""
    from matplotlib.colors import to_rgb

    off = _offsets(cm, explode)
    keep = np.ones(len(cm.cells), dtype=bool)
    if clip is not None:
        pieces, axis, value = clip
        cen = cm.points[cm.cells][:, :, axis].mean(axis=1)
        keep &= ~(np.isin(cm.piece, pieces) & (cen < value))
    if cm.dim == 2:
        from matplotlib.collections import PolyCollection

        for p in range(cm.n_pieces):
            sel = cm.cells[keep & (cm.piece == p)]
            ax.add_collection(PolyCollection(cm.points[sel] + off[p], edgecolors="k",
                                             facecolors=PIECE_COLOURS[p % 10],
                                             linewidths=0.3, alpha=0.8))
        ax.set_aspect("equal")
        ax.autoscale_view()
        return
    from predicates.registration.pictures.view import DEFAULT_VIEW, draw_faces, fit, lambert

    cut = {tuple(sorted(f)) for f in cm.cut_faces.tolist()}
    faces, colours = [], []
    for p in range(cm.n_pieces):
        sel = cm.cells[keep & (cm.piece == p)]
        if len(sel) == 0:
            continue
        ids = _piece_boundary(sel)
        F = cm.points[ids] + off[p]
        shade = 0.4 + 0.6 * lambert(F, light)
        rgb = np.clip(np.outer(shade, to_rgb(PIECE_COLOURS[p % 10])), 0, 1)
        on_cut = np.array([tuple(sorted(f)) in cut for f in ids.tolist()])
        rgb[on_cut] = 0.6 * rgb[on_cut] + 0.4
        faces.append(F)
        colours.append(np.column_stack([rgb, np.ones(len(rgb))]))
    ax.set_axis_off()
    if not faces:
        return
    v = view or DEFAULT_VIEW
    F = np.concatenate(faces)
    draw_faces(ax, v, F, np.concatenate(colours), edgecolors=(0, 0, 0, 0.15),
               linewidths=0.1)
    fit(ax, v.project(F)[0])


def plot_conforming(cm, path: str, explode: float = 0.3, clip=None,
                    title: str | None = None) -> None:
    """Write a picture of ``cm`` to ``path`` (png, pdf or svg)."""
    plt, fig, (ax,) = _figure(cm.dim)
    draw_conforming(ax, cm, explode, clip)
    ax.set_title(title or f"conforming: {cm.n_pieces} piece"
                          f"{'s' if cm.n_pieces != 1 else ''}, {len(cm.cells)} simplices, "
                          f"{len(cm.cut_faces)} cut faces (explode {explode:g})")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def sphere_out_of_cube(path: str, n: int = 8, subdivisions: int = 2):
    """The demo picture: the cube (Kuhn n) cut by an icosphere, conforming; the cube with
    its cavity (cut open at y = ½, the half towards the viewer removed) beside the ball. Returns the ConformingMesh."""
    from predicates import intersect
    from predicates.registration.examples import cube_grid, icosphere

    cm = intersect(*cube_grid(n), *icosphere(subdivisions)).split().tetrahedralize()
    outer = int(np.argmax(cm.piece_volumes()))
    plot_conforming(cm, path, explode=0.3, clip=([outer], 1, 0.5),
                    title=f"sphere cut out of a cube, conforming\n(Kuhn {n} x icosphere "
                          f"{subdivisions}: {len(cm.cells)} positive tetrahedra)")
    return cm
