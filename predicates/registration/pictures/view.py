"""A fixed orthographic view of 3D faces drawn on plain 2D matplotlib axes, the same
pixels on every machine (docs/design.md, "The same answer on every machine").

mplot3d projects through ``np.dot`` of 4×4 matrices (BLAS, whose last bits differ per
kernel) and the sines of its view angles (numpy's SIMD dispatch): its pictures differed
in a few hundred pixels between kernels. Here the view is a rotation with rational
entries — the elevation and azimuth as points of the unit circle ((1 − t²)/(1 + t²),
2t/(1 + t²)) for a rational t near tan(angle/2), each entry rounded once from its exact
fraction — applied by elementwise products summed left to right
(:func:`predicates.portable.rotate`); the faces are drawn back to front (painter's
order: a stable sort on their mean depth, ties kept in input order) as one
``PolyCollection``.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from predicates import portable

__all__ = ["DEFAULT_VIEW", "View", "draw_faces", "draw_frame", "fit", "lambert", "view"]

#: the largest denominator of the rational half-angle tangents (angles within ~0.01°)
HALF_TANGENT_DENOMINATOR = 1000


@dataclass(frozen=True)
class View:
    """Rows of an exact rotation: ``right`` and ``up`` span the picture, ``towards``
    points at the viewer (depth grows towards the viewer)."""

    elev: float
    azim: float
    rows: tuple  # ((right), (up), (towards)), each three floats

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """points (..., 3) → (picture coordinates (..., 2), depth (...))."""
        P = np.asarray(points, dtype=np.float64)
        rotated = portable.rotate(P.reshape(-1, 3), np.array(self.rows, dtype=np.float64))
        rotated = rotated.reshape(*P.shape[:-1], 3)
        return rotated[..., :2], rotated[..., 2]


def _unit_circle(degrees: float) -> tuple[Fraction, Fraction]:
    """(cos, sin) of a rational angle near ``degrees``: exact fractions on the unit circle
    from t = tan(angle/2), itself a fraction from the correctly rounded cosine and sine of
    angle/2 (:func:`predicates.portable.cos_sin`), so the same on every machine."""
    (c,), (s,) = portable.cos_sin(np.array([float(degrees)]) * (np.pi / 360))
    # cos(angle/2) is never 0 in floats (π/2 is not a float): t is finite
    t = (Fraction(s) / Fraction(c)).limit_denominator(HALF_TANGENT_DENOMINATOR)
    return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)


def view(elev: float = 30.0, azim: float = -60.0) -> View:
    """The view from elevation ``elev`` and azimuth ``azim`` (degrees, mplot3d's
    ``view_init`` convention, orthographic): the viewer at (cos e cos a, cos e sin a,
    sin e), the z axis up in the picture."""
    ce, se = _unit_circle(elev)
    ca, sa = _unit_circle(azim)
    exact = ((-sa, ca, Fraction(0)), (-se * ca, -se * sa, ce), (ce * ca, ce * sa, se))
    return View(float(elev), float(azim), tuple(tuple(float(x) for x in r) for r in exact))


#: mplot3d's default view (elevation 30°, azimuth −60°)
DEFAULT_VIEW = view()


def lambert(faces, light=(-0.4, -0.8, 0.6)) -> np.ndarray:
    """|n·l| per face (two-sided: orientation is arbitrary), n the unit normal of the
    first, second and last vertex, l the unit ``light``; elementwise, in a fixed order."""
    if isinstance(faces, np.ndarray):
        F = faces.astype(np.float64)
        n = np.cross(F[:, 1] - F[:, 0], F[:, -1] - F[:, 0])
    else:
        n = np.array([np.cross(f[1] - f[0], f[-1] - f[0]) for f in faces], dtype=np.float64)
    n = n.reshape(-1, 3) / np.maximum(portable.row_norms(n.reshape(-1, 3)), 1e-300)[:, None]
    L = np.asarray(light, dtype=np.float64)
    L = L / portable.norm(L)
    return np.abs(n[:, 0] * L[0] + n[:, 1] * L[1] + n[:, 2] * L[2])


def _mean_depth(depths) -> np.ndarray:
    if isinstance(depths, np.ndarray):  # (m, k): summed left to right
        acc = depths[:, 0].copy()
        for j in range(1, depths.shape[1]):
            acc = acc + depths[:, j]
        return acc / depths.shape[1]
    return np.array([sum(d.tolist()) / len(d) for d in depths], dtype=np.float64)


def _per_face(colours, order: np.ndarray):
    """``colours`` in painter's order when it gives one RGBA row per face."""
    if isinstance(colours, str):
        return colours
    c = np.asarray(colours, dtype=np.float64)
    return c[order] if c.ndim == 2 and len(c) == len(order) else colours


def draw_faces(ax, v: View, faces, facecolors, edgecolors="k", linewidths=0.2,
               zorder: float = 1):
    """Draw polygons ``faces`` ((m, k, 3) array, or a list of (kᵢ, 3) arrays) in the
    view ``v`` on the 2D axis ``ax``, back to front; ``facecolors``: one RGBA row per
    face (or one colour). Returns the ``PolyCollection`` (None for no faces)."""
    from matplotlib.collections import PolyCollection

    if len(faces) == 0:
        return None
    if isinstance(faces, np.ndarray):
        xy, depth = v.project(faces)
    else:
        projected = [v.project(f) for f in faces]
        xy, depth = [p[0] for p in projected], [p[1] for p in projected]
    order = np.argsort(_mean_depth(depth), kind="stable")  # far first; ties: input order
    facecolors, edgecolors = (_per_face(c, order) for c in (facecolors, edgecolors))
    polys = xy[order] if isinstance(xy, np.ndarray) else [xy[i] for i in order]
    collection = PolyCollection(polys, facecolors=facecolors, edgecolors=edgecolors,
                                linewidths=linewidths, zorder=zorder)
    ax.add_collection(collection)
    return collection


def draw_frame(ax, v: View, lo, hi, triad: bool = True, margin: float = 0.04) -> None:
    """The box [lo, hi] in light grey under everything and, below its left corner, the
    directions of the x, y and z axes in this view, named; equal aspect, limits around
    both, axis off (what mplot3d's panes and labels told)."""
    from matplotlib.collections import LineCollection

    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    corners = np.array([[(lo, hi)[(i >> k) & 1][k] for k in range(3)] for i in range(8)])
    edges = [(i, i | 1 << k) for i in range(8) for k in range(3) if not i >> k & 1]
    xy, _ = v.project(corners)
    ax.add_collection(LineCollection([xy[[a, b]] for a, b in edges], colors="0.75",
                                     linewidths=0.6, zorder=0))
    if not triad:
        fit(ax, xy, margin)
        return
    size = float((xy.max(axis=0) - xy.min(axis=0)).max())
    origin = xy.min(axis=0) + np.array([-0.08, -0.04]) * size  # left of the box
    ends = origin + 0.09 * size * np.array(v.rows)[:2].T  # column k: axis k's direction
    for k, name in enumerate("xyz"):
        ax.annotate("", xy=tuple(ends[k]), xytext=tuple(origin),
                    arrowprops={"arrowstyle": "->", "color": "0.3", "lw": 0.8})
        label = origin + 1.3 * (ends[k] - origin)
        ax.text(label[0], label[1], name, fontsize=9, color="0.2", ha="center",
                va="center")
    fit(ax, np.concatenate([xy, ends, origin[None] - 0.02 * size]), margin)


def fit(ax, xy, margin: float = 0.04) -> None:
    """Equal aspect, limits around the picture points ``xy`` (n, 2), axis off."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = margin * float((hi - lo).max())
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_axis_off()
