"""Drawing a 2D registration (section 1 of the paper) with matplotlib: the simulation
mesh, the cutting segments and the intersection points coloured by kind."""
from __future__ import annotations

import os

import numpy as np

__all__ = ["COLOURS", "plot_2d"]

#: one colour per kind (matplotlib tab10), by registration order in 2D and 3D
COLOURS = {"vertex_vertex": "tab:red", "vertex_edge": "tab:orange", "edge_vertex": "tab:purple",
           "edge_edge": "tab:blue", "triangle_vertex": "tab:green",
           "vertex_triangle": "tab:brown", "edge_triangle": "tab:cyan",
           "triangle_edge": "tab:olive", "tetrahedron_vertex": "tab:pink"}


def plot_2d(res, path: str | os.PathLike, title: str | None = None) -> None:
    """Draw a 2D result: the simulation mesh, the cutting segments and the
    intersection points coloured by kind (matplotlib, Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    if res.dim != 2:
        raise ValueError("plots are drawn for 2D meshes only")
    sp = res.sim_points.astype(np.float64)
    cp = res.cut_points.astype(np.float64)
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.triplot(sp[:, 0], sp[:, 1], res.sim_cells, color="0.75", lw=0.6)
    ax.add_collection(LineCollection(cp[res.cut_cells], colors="k", linewidths=1.2))
    for kind in res.kinds:
        p = res[kind]
        if len(p):
            X = p.points(sp, "sim")
            ax.scatter(X[:, 0], X[:, 1], s=22, color=COLOURS[kind], zorder=3,
                       label=f"{kind} ({len(p)})", edgecolors="k", linewidths=0.3)
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    naive = " (naive: zero tolerances)" if res.tolerance_scale == 0 else ""
    ax.set_title(title or f"{res.total} intersections registered{naive}")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
