"""Pictures of the conforming tetrahedralization of the split (docs/split.md, "The
conforming tetrahedralization"), with matplotlib (Agg backend): the boundary triangles of
every piece (faces of its simplices no other simplex of the piece shares), Lambert-shaded
(elementwise, in a fixed order), the cut faces in a lighter tone of their piece,
the pieces moved apart — pieces whose centroids nearly coincide (a ball in its cavity)
side by side along x. ``clip`` keeps the simplices of some pieces on one side of an
axis-aligned plane only, to look into a cavity. A crack (cut faces with one piece on
both sides, so on no piece's boundary) is drawn in the cut colour over its piece. 2D:
the triangles filled by piece. 3D is projected by an exact rotation and drawn back to
front on plain 2D axes (:mod:`~predicates.registration.pictures.view`): the same pixels
on every machine."""
from __future__ import annotations

import numpy as np

from predicates.portable import unit_rows
from predicates.registration.levels.complex import single_rows
from predicates.registration.split.plot import PIECE_COLOURS, _figure

__all__ = ["crack_faces", "crack_sides", "draw_conforming", "plot_conforming",
           "sphere_out_of_cube"]

#: the cut's colour, as split/plot.py draws the cut surface (dark red)
CUT_RGB = (0.8, 0.15, 0.1)
#: how far each side of a crack is moved off it in the picture (× the mesh's extent)
CRACK_GAP = 0.004


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


def _hiding(cm, off: np.ndarray) -> np.ndarray:
    """The pieces that hide an island drawn in place (3D): a piece every boundary face of
    which is cut lies inside the piece on the other side of those faces; unless the two
    were set apart (:func:`_offsets`: by more than the mesh's extent), that piece is
    drawn see-through so the island shows."""
    cut = {tuple(sorted(f)) for f in cm.cut_faces.tolist()}
    ext = float((cm.points.max(axis=0) - cm.points.min(axis=0)).max())
    sides = cm.piece[cm.cut_sides]
    out = set()
    for p in range(cm.n_pieces):
        faces = _piece_boundary(cm.cells[cm.piece == p]).tolist()
        if not faces or any(tuple(sorted(f)) not in cut for f in faces):
            continue
        for q in set(sides[(sides == p).any(axis=1)].ravel().tolist()) - {p}:
            if np.abs(off[q] - off[p]).max() < ext:
                out.add(q)
    return np.array(sorted(out), dtype=np.int64)


def _piece_boundary(cells: np.ndarray):
    faces = np.concatenate([cells[:, [1, 2, 3]], cells[:, [0, 3, 2]], cells[:, [0, 1, 3]],
                            cells[:, [0, 2, 1]]])
    return faces[single_rows(np.sort(faces, axis=1))]


def draw_conforming(ax, cm, explode: float = 0.3, clip=None, light=(-0.4, -0.8, 0.6),
                    view=None) -> None:
    """Draw ``cm`` into a plain 2D matplotlib axis; 3D in ``view`` (default mplot3d's
    default angles, projected by exact rotations: pictures/view.py). ``clip``: (pieces, axis,
    value): the simplices of those pieces whose centroid has coordinate ``axis`` ≥
    ``value`` only. A crack (:func:`crack_faces`) is drawn in the cut colour over its
    piece: 3D opened (:func:`crack_sides`), the piece see-through; 2D its segments
    (docs/split.md, "Pictures")."""
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
        cracks = crack_faces(cm, keep)
        if len(cracks):  # a crack's segments, else drawn as any inner edge
            from matplotlib.collections import LineCollection

            move = off[cm.piece[cm.cut_sides[cracks, 0]]][:, None, :]
            ax.add_collection(LineCollection(cm.points[cm.cut_faces[cracks]] + move,
                                             colors=[CUT_RGB], linewidths=1.6, zorder=3))
        ax.set_aspect("equal")
        ax.autoscale_view()
        return
    from predicates.registration.pictures.view import DEFAULT_VIEW, draw_faces, fit

    v = view or DEFAULT_VIEW
    cracks = crack_faces(cm, keep)
    pale = np.concatenate([cm.piece[cm.cut_sides[cracks, 0]], _hiding(cm, off)])
    F, rgba, edges = _piece_faces(cm, keep, off, light, pale)
    ax.set_axis_off()
    if len(F) == 0:
        return
    draw_faces(ax, v, F, rgba, edgecolors=edges, linewidths=0.1)
    # the crack over its see-through piece (as split/plot.py draws the cut surface), the
    # side facing away from the viewer first, so the near side is never striped by it
    for z, (side, colours) in enumerate(_crack_layers(cm, cracks, off, light, v), start=2):
        draw_faces(ax, v, side, colours, edgecolors=(0.3, 0, 0, 0.3), linewidths=0.1,
                   zorder=z)
    fit(ax, v.project(F)[0])


def crack_faces(cm, keep: np.ndarray | None = None) -> np.ndarray:
    """Indices of the cut faces with a simplex on each side in one piece (both kept):
    a crack inside that piece (docs/split.md, "Pictures"). They are no face of the
    piece's boundary, so only :func:`crack_sides` draws them."""
    keep = np.ones(len(cm.cells), dtype=bool) if keep is None else keep
    s = cm.cut_sides
    both = (s >= 0).all(axis=1)
    s = np.where(both[:, None], s, 0)
    return np.flatnonzero(both & keep[s[:, 0]] & keep[s[:, 1]]
                          & (cm.piece[s[:, 0]] == cm.piece[s[:, 1]]))


def crack_sides(cm, faces: np.ndarray, gap: float) -> np.ndarray:
    """(2, k, 3, 3): each crack face ``faces`` (indices into ``cut_faces``) twice, moved
    by ``gap`` along its unit normal towards the simplex of ``cut_sides`` column 0
    (behind), then column 1 (in front): the crack drawn slightly opened, each side by
    its own material. Elementwise, in a fixed order (no BLAS)."""
    ids = cm.cut_faces[faces]
    F = cm.points[ids]
    n = unit_rows(np.cross(F[:, 1] - F[:, 0], F[:, 2] - F[:, 0]))
    out = []
    for col in (0, 1):
        cells = cm.cells[cm.cut_sides[faces, col]]
        apex = cells.sum(axis=1) - ids.sum(axis=1)  # the simplex's vertex off the face
        to_apex = cm.points[apex] - F[:, 0]
        towards = ((to_apex[:, 0] * n[:, 0] + to_apex[:, 1] * n[:, 1])
                   + to_apex[:, 2] * n[:, 2])
        out.append(F + (np.where(towards < 0, -gap, gap)[:, None] * n)[:, None, :])
    return np.stack(out)


def _piece_faces(cm, keep, off, light, cracked_pieces):
    """Every piece's boundary faces, their RGBA and edge colours: Lambert-shaded, cut
    faces lighter; the pieces in ``cracked_pieces`` pale and see-through, so the crack
    or the island inside shows."""
    from matplotlib.colors import to_rgb

    from predicates.registration.pictures.view import lambert

    cut = {tuple(sorted(f)) for f in cm.cut_faces.tolist()}
    cracked = np.zeros(cm.n_pieces, dtype=bool)
    cracked[cracked_pieces] = True
    faces, colours, edges = [], [], []
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
        alpha, edge_alpha = (0.15, 0.05) if cracked[p] else (1.0, 0.15)
        if cracked[p]:
            rgb = 0.5 * rgb + 0.5
        faces.append(F)
        colours.append(np.column_stack([rgb, np.full(len(rgb), alpha)]))
        edges.append(np.tile((0.0, 0.0, 0.0, edge_alpha), (len(rgb), 1)))
    if not faces:
        return np.zeros((0, 3, 3)), np.zeros((0, 4)), np.zeros((0, 4))
    return np.concatenate(faces), np.concatenate(colours), np.concatenate(edges)


def _crack_layers(cm, cracks, off, light, v):
    """The crack faces ``cracks`` opened (:func:`crack_sides`, by :data:`CRACK_GAP` of
    the mesh's extent) and moved with their piece, in the cut colour (the side behind
    the cut lighter than the dark red in front): [(the copies farther from the viewer,
    RGBA), (the nearer ones, RGBA)]; none without cracks."""
    from predicates.registration.pictures.view import lambert

    if len(cracks) == 0:
        return []
    extent = float((cm.points.max(axis=0) - cm.points.min(axis=0)).max())
    sides = crack_sides(cm, cracks, CRACK_GAP * extent)
    sides = sides + off[cm.piece[cm.cut_sides[cracks, 0]]][None, :, None, :]
    rgba = []
    for side, tone in zip(sides, (0.45, 0.0)):  # behind lighter, in front dark red
        shade = 0.35 + 0.65 * lambert(side, light)
        rgba.append(np.column_stack([(1 - tone) * np.outer(shade, CUT_RGB) + tone,
                                     np.ones(len(side))]))
    depth = v.project(sides)[1]  # (2, k, 3): summed per copy in a fixed order
    depth = (depth[..., 0] + depth[..., 1]) + depth[..., 2]
    near = (depth[1] > depth[0])[:, None, None]  # is the copy in front the nearer one
    far_faces, near_faces = np.where(near, sides[0], sides[1]), np.where(near, sides[1],
                                                                          sides[0])
    near = near[:, 0, :]
    return [(far_faces, np.where(near, rgba[0], rgba[1])),
            (near_faces, np.where(near, rgba[1], rgba[0]))]


def plot_conforming(cm, path: str, explode: float = 0.3, clip=None,
                    title: str | None = None) -> None:
    """Write a picture of ``cm`` to ``path`` (png, pdf or svg)."""
    plt, fig, (ax,) = _figure(cm.dim)
    draw_conforming(ax, cm, explode, clip)
    cracks = len(crack_faces(cm))
    how = "opened; the piece see-through" if cm.dim == 3 else "over the piece"
    inside = f"\n{cracks} of them a crack inside a piece (red, {how})" if cracks else ""
    if cm.dim == 3 and not inside and len(_hiding(cm, _offsets(cm, explode))):
        inside = "\nan island inside a piece (the piece see-through)"
    ax.set_title(title or f"conforming: {cm.n_pieces} piece"
                          f"{'s' if cm.n_pieces != 1 else ''}, {len(cm.cells)} simplices, "
                          f"{len(cm.cut_faces)} cut faces (explode {explode:g}){inside}")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def sphere_out_of_cube(path: str, n: int = 8, subdivisions: int = 2):
    """The demo picture: the cube (Kuhn n) cut by an icosphere, conforming; the cube with
    its cavity (cut open at y = ½, the half towards the viewer removed) beside the ball.
    Returns the ConformingMesh."""
    from predicates import intersect
    from predicates.registration.examples import cube_grid, icosphere

    cm = intersect(*cube_grid(n), *icosphere(subdivisions)).split().tetrahedralize()
    outer = int(np.argmax(cm.piece_volumes()))
    plot_conforming(cm, path, explode=0.3, clip=([outer], 1, 0.5),
                    title=f"sphere cut out of a cube, conforming\n(Kuhn {n} x icosphere "
                          f"{subdivisions}: {len(cm.cells)} positive tetrahedra)")
    return cm
