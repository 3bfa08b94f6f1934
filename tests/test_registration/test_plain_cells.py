"""The vectorised boundaries of the plain cut cells (3D and 2D) (predicates.registration.split.
plain_cells, docs/split.md "Volumes and moments") against the per-cell rules
(split/regions.py, ``per_cell=True``) on several cuts: the same boundary triangles,
compared as multisets of integer rows (exactly), the same reported cells, and the same
volumes and moments up to the order of summation — np.bincount adds the triangles of a
fragment in the order of the rows, grouped by kind (face segments, chords, polygon
fans) in the vectorised path and by cell in the per-cell one, so the sums may differ
in their last bits (≤ 1e-15 · the cell's volume, resp. · volume × coordinate scale).
The per-cell rules themselves are checked against exact arithmetic in
test_fragment_volumes.py."""
from __future__ import annotations

import numpy as np
import pytest

import predicates
from cut_cases import box_surface, gmsh_box, square_loop, torus
from predicates.portable import rotate, rotation
from predicates.registration.examples import (circle_polygon, cube_grid, grid_plane,
                                              icosphere, square_grid)
from predicates.registration.split.surface import cut_surface
from predicates.registration.split.volume import fragment_boundaries, fragment_volumes


def _rotated_sphere(level, a, b):
    P, T = icosphere(level)
    return rotate(P - 0.5, rotation(a, b)) + 0.5, T


#: name: (simulation mesh, cutting mesh, least fraction of the cut cells that are plain)
CASES = {
    "kuhn10_sphere": (lambda: cube_grid(10), lambda: icosphere(3), 0.9),
    # a coarse sphere bulges through many edges (crossed twice: per cell, 156 of 534)
    "kuhn7_rotated_sphere": (lambda: cube_grid(7), lambda: _rotated_sphere(2, 3, 3), 0.6),
    "kuhn12_torus": (lambda: cube_grid(12), torus, 0.9),
    "gmsh_sphere": (lambda: gmsh_box(0.12), lambda: icosphere(3), 0.9),
    "kuhn8_box_on_faces": (lambda: cube_grid(8), lambda: box_surface(8, 2, 6), 0.0),
    "kuhn4_plane_on_vertices": (lambda: cube_grid(4), lambda: grid_plane(4), 0.0),
    "kuhn4_plane_offset": (lambda: cube_grid(4), lambda: grid_plane(4, offset=True), 0.0),
    # 2D: a coarse circle (one segment per cell) and a fine one (paths through points
    # inside the triangles), a square along grid edges (corners on the cut)
    "2d_circle": (lambda: square_grid(10), lambda: circle_polygon(37, radius=0.33), 0.9),
    "2d_fine_circle": (lambda: square_grid(16), lambda: circle_polygon(256, radius=0.3), 0.9),
    "2d_square_on_edges": (lambda: square_grid(8), lambda: square_loop(8, 2, 6), 0.0),
}


def _sorted_rows(rows):
    return rows[np.lexsort(rows.T[::-1])]


@pytest.mark.parametrize("name", sorted(CASES))
def test_vectorised_boundaries_equal_the_per_cell_rules(name):
    if name.startswith("gmsh"):
        pytest.importorskip("gmsh")
    sim, cut, least = CASES[name]
    res = predicates.intersect(*sim(), *cut())
    sm = res.split()
    cs = cut_surface(res)
    rows, todo, bad, plain = fragment_boundaries(res, sm, cs)
    ref_rows, ref_todo, ref_bad, ref_plain = fragment_boundaries(res, sm, cs, per_cell=True)
    assert not ref_plain.any() and np.array_equal(todo, ref_todo)
    assert plain.sum() >= least * todo.sum() and plain.sum() <= todo.sum()
    # the plain cells' triangles are the per-cell rules' triangles, exactly
    assert bad == ref_bad
    assert np.array_equal(_sorted_rows(rows), _sorted_rows(ref_rows))
    fv = fragment_volumes(res, sm, cs)
    ref = fragment_volumes(res, sm, cs, per_cell=True)
    assert np.array_equal(fv.unresolved, ref.unresolved)
    cv = fv.cell_volume[sm.cell_origin]
    ok = ~np.isnan(ref.volume)
    assert np.array_equal(ok, ~np.isnan(fv.volume))
    assert np.all(np.abs(fv.volume - ref.volume)[ok] <= 1e-15 * cv[ok])
    scale = np.abs(res.sim_points).max()
    assert np.all(np.abs(fv.moment - ref.moment)[ok] <= 1e-15 * scale * cv[ok, None])
    assert np.array_equal(np.isnan(fv.unclaimed), np.isnan(ref.unclaimed))
