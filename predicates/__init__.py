"""predicates: the paper's twelve algorithms, written once, run in every number system.

``predicates.d2`` (Algorithms 2–5), ``predicates.d3`` (Algorithms 7–12) and
``predicates.tolerances`` (Algorithms 1 and 6). Built on :mod:`fperr`.
"""
from . import d2, d3
from .core import Instrumented, Predicate
from .tolerances import Tolerances, tolerances, tracked_tolerances
from .registration import intersect  # noqa: E402  (registration of two meshes)

#: Every predicate, by dimension, in the paper's order.
ALL = {2: (d2.vertex_vertex, d2.edge_vertex, d2.edge_edge, d2.triangle_vertex),
       3: (d3.vertex_vertex, d3.edge_vertex, d3.edge_edge, d3.triangle_vertex,
           d3.triangle_edge, d3.tetrahedron_vertex)}

__all__ = ["ALL", "Instrumented", "Predicate", "Tolerances", "d2", "d3", "tolerances",
           "tracked_tolerances"]
