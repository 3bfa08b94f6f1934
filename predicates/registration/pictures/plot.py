"""Pictures of a registration (section 1 of the paper) with matplotlib (Agg backend):
a 2D result, a 2D degenerate case robust beside naive with the naive run's
inconsistencies marked, and the cut cells of a 3D result (projected by an exact rotation
on plain 2D axes: :mod:`~predicates.registration.pictures.view`).

Kinds get a colour AND a marker shape/size (larger markers drawn first), so that
coincident points of different kinds stay visible.
"""
from __future__ import annotations

import os

import numpy as np

from predicates.registration.levels.complex import single_rows

__all__ = ["COLOURS", "MARKERS", "plot_2d", "plot_3d_cells", "plot_robust_naive"]

#: one colour per kind (matplotlib tab10), by registration order in 2D and 3D
COLOURS = {"vertex_vertex": "tab:red", "vertex_edge": "tab:orange", "edge_vertex": "tab:purple",
           "edge_edge": "tab:blue", "triangle_vertex": "tab:green",
           "vertex_triangle": "tab:brown", "edge_triangle": "tab:cyan",
           "triangle_edge": "tab:olive", "tetrahedron_vertex": "tab:pink"}
#: (marker, size): the most degenerate kinds largest, so that smaller ones show on top
MARKERS = {"vertex_vertex": ("o", 90), "vertex_edge": ("s", 60), "edge_vertex": ("D", 45),
           "edge_edge": ("^", 30), "triangle_vertex": ("v", 30), "vertex_triangle": ("s", 40),
           "edge_triangle": ("^", 20), "triangle_edge": ("v", 20),
           "tetrahedron_vertex": ("o", 20)}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _draw_2d(ax, res, title: str) -> None:
    from matplotlib.collections import LineCollection

    sp = res.sim_points.astype(np.float64)
    cp = res.cut_points.astype(np.float64)
    ax.triplot(sp[:, 0], sp[:, 1], res.sim_cells, color="0.78", lw=0.6, zorder=1)
    ax.add_collection(LineCollection(cp[res.cut_cells], colors="k", linewidths=1.0, zorder=2))
    shrink = float(np.clip(np.sqrt(150 / max(res.total, 1)), 0.2, 1.0))  # dense: smaller
    for z, kind in enumerate(res.kinds):
        p = res[kind]
        if len(p):
            X = p.points()
            m, s = MARKERS[kind]
            ax.scatter(X[:, 0], X[:, 1], s=s * shrink, marker=m, facecolors=COLOURS[kind],
                       edgecolors="k", linewidths=0.4, zorder=3 + z, alpha=0.9,
                       label=f"{kind} ({len(p)})")
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title(title, fontsize=10)


def plot_2d(res, path: str | os.PathLike, title: str | None = None) -> None:
    """Draw a 2D result: the simulation mesh, the cutting segments and the
    intersection points by kind (colour and marker)."""
    if res.dim != 2:
        raise ValueError("plots are drawn for 2D meshes only")
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 7))
    naive = " (naive: zero tolerances)" if res.tolerance_scale == 0 else ""
    _draw_2d(ax, res, title or f"{res.total} intersections registered{naive}")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, title="kind")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_robust_naive(robust, naive, inside, path: str | os.PathLike, title: str = "",
                      zoom=None) -> None:
    """A 2D degenerate case twice, robust (left) beside naive (right), with each run's
    inconsistencies marked: cutting vertices inside the mesh not located exactly once
    (red rings) and cutting edges whose events are not a walk (red, thick). ``inside``:
    a bool per cutting point, as given or as registered (refined).
    ``zoom``: ((x0, x1), (y0, y1)) to show a detail."""
    from matplotlib.collections import LineCollection

    from predicates.registration.result.consistency import broken_edges

    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.8))
    for ax, res, name in ((axes[0], robust, "robust (the paper's tolerances)"),
                          (axes[1], naive, "naive (zero tolerances)")):
        edges = broken_edges(res)
        bad = res.mislocated_vertices(inside)  # inside may cover the input points only
        _draw_2d(ax, res, f"{name}: {res.total} pairs, {len(edges) + len(bad)} "
                          "inconsistencies")
        cp = res.cut_points.astype(np.float64)
        if len(edges):
            ax.add_collection(LineCollection(cp[edges], colors="red", linewidths=3.5,
                                             alpha=0.6, zorder=2.5, label=
                                             f"broken walk ({len(edges)} edges)"))
        if len(bad):
            ax.scatter(cp[bad, 0], cp[bad, 1], s=260, facecolors="none", edgecolors="red",
                       linewidths=2, zorder=20, label=f"vertex not located once ({len(bad)})")
        if zoom is not None:
            ax.set_xlim(*zoom[0])
            ax.set_ylim(*zoom[1])
        ax.legend(loc="lower right", fontsize=7, framealpha=0.9)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_3d_cells(res, path: str | os.PathLike, title: str = "", max_cells: int = 2500,
                  view=None) -> None:
    """A 3D result: the cut tetrahedra (:meth:`intersected_cells`, coloured by height)
    with the cutting surface: the cut cells with x below a threshold (at most half of
    them and at most ``max_cells``, so that the inside shows and the picture draws
    quickly), their outer faces only, and the cutting triangles beyond the threshold.
    ``view``: a :class:`~predicates.registration.pictures.view.View` (default mplot3d's
    default angles), projected by an exact rotation on plain 2D axes, faces back to front
    (pictures/view.py: the same pixels on every machine)."""
    from matplotlib.colors import to_rgb

    from predicates.registration.pictures.view import DEFAULT_VIEW, draw_faces, draw_frame, lambert

    if res.dim != 3:
        raise ValueError("plot_3d_cells draws 3D results")
    plt = _plt()
    v = view or DEFAULT_VIEW
    P = res.sim_points.astype(np.float64)
    ids = res.intersected_cells()
    cells = res.sim_cells[ids]
    centre = P[cells].mean(axis=1)[:, 0]
    order = np.argsort(centre, kind="stable")
    keep = order[: min(len(order) // 2 + 1, max_cells)]
    cut_x = centre[keep].max() if len(keep) else 0.0
    cells = cells[keep]
    tri = cells[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3)
    faces = P[tri[single_rows(np.sort(tri, axis=1))]]  # the outer faces of the shown cells
    colours = np.zeros((0, 4))
    if len(faces):
        z = faces[:, :, 2].mean(axis=1)
        colours = plt.get_cmap("viridis")((z - z.min()) / max(np.ptp(z), 1e-300))
        colours[:, 3] = 0.85
    C = res.cut_points.astype(np.float64)
    beyond = C[res.cut_cells[C[res.cut_cells].mean(axis=1)[:, 0] > cut_x]]
    red = np.zeros((0, 4))
    if len(beyond):  # shaded, as mplot3d shaded its surface
        red = np.outer(0.55 + 0.45 * lambert(beyond), to_rgb("tab:red"))
        red = np.column_stack([np.clip(red, 0, 1), np.full(len(beyond), 0.35)])
    fig, ax = plt.subplots(figsize=(8, 7.5))
    # cells and cutting surface in one painter's order: each hides what lies behind it
    draw_faces(ax, v, np.concatenate([faces.reshape(-1, 3, 3), beyond]),
               np.concatenate([colours, red]),
               edgecolors=[(0, 0, 0, 1)] * len(faces) + [(0, 0, 0, 0)] * len(beyond),
               linewidths=0.15)
    draw_frame(ax, v, P.min(axis=0), P.max(axis=0))
    ax.set_title(title or f"{len(ids)} cut tetrahedra ({len(keep)} shown) and the "
                          "cutting surface (red)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
