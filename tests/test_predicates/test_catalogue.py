"""The predicate catalogue (predicates.catalogue): what is derived from ``@predicate``."""
import numpy as np
import pytest

import predicates
from predicates import catalogue


def test_kinds_in_registration_order():
    assert [(k.name, k.i, k.j) for k in catalogue.kinds(2)] == [
        ("vertex_vertex", 0, 0), ("vertex_edge", 0, 1), ("edge_vertex", 1, 0),
        ("edge_edge", 1, 1), ("triangle_vertex", 2, 0)]
    assert [(k.name, k.i, k.j) for k in catalogue.kinds(3)] == [
        ("vertex_vertex", 0, 0), ("vertex_edge", 0, 1), ("edge_vertex", 1, 0),
        ("edge_edge", 1, 1), ("vertex_triangle", 0, 2), ("triangle_vertex", 2, 0),
        ("edge_triangle", 1, 2), ("triangle_edge", 2, 1), ("tetrahedron_vertex", 3, 0)]


def test_every_predicate_declares_its_catalogue_entry():
    for dim in (2, 3):
        for p in catalogue.predicates(dim):
            assert p.section.startswith(f"{dim + 2}.")
            assert "".join(p.sim + p.cut) == "".join(p.points)
            name, factor = p.reach
            # every reach is at most sigma+ = 7/6.5 sigma (section 4.1), and covers T+
            assert name in ("sigma", "tau", "gamma", "delta") and 1 <= factor <= 2.75 / 2.25
    assert catalogue.find(3, "edge_edge").bracket == "gamma"
    assert catalogue.find(2, "edge_edge").bracket is None
    with pytest.raises(ValueError, match="no 2D predicate named 'triangle_edge'"):
        catalogue.find(2, "triangle_edge")


def test_sub_pairs_are_all_lower_face_pairs_across_primitives():
    tv = catalogue.find(3, "tetrahedron_vertex")
    subs = catalogue.sub_pairs(tv)
    # 4 vertices, 6 edges, 4 faces of the tetrahedron against the point P (index 4)
    assert sorted(len(idx) for _, idx in subs) == [2] * 4 + [3] * 6 + [4] * 4
    assert all(idx[-1] == 4 for _, idx in subs)
    ee = catalogue.find(2, "edge_edge")
    swapped = [idx for p, idx in catalogue.sub_pairs(ee) if p.name == "edge_vertex"
               and idx[0] >= 2]
    assert swapped == [(2, 3, 0), (2, 3, 1)]  # the cutting edge in the predicate's AB role


def test_swapped_kind_runs_the_predicate_with_the_roles_exchanged():
    tol = predicates.tolerances(3, 1.0, 1.0)
    k = {k.name: k for k in catalogue.kinds(3)}["vertex_triangle"]
    S = np.array([[[0.25, 0.25, 0.0]]])             # a simulation vertex
    C = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]])  # a cutting triangle through it
    hit, ws, wc = k.evaluate(S, C, tol)
    assert hit.tolist() == [True] and ws.tolist() == [[1.0]]
    np.testing.assert_allclose(wc, [[0.5, 0.25, 0.25]])
