"""predicates: the paper's twelve algorithms, written once, run in every number system.

``predicates.d2`` (Algorithms 2–5), ``predicates.d3`` (Algorithms 7–12) and
``predicates.tolerances`` (Algorithms 1 and 6); ``predicates.registration`` registers
two meshes with them (section 1). Built on :mod:`fperr`.
"""
from . import catalogue, d2, d3
from .core import Instrumented, Predicate
from .tolerances import Tolerances, tolerances, tracked_tolerances
from .registration import intersect

#: Every predicate, by dimension, in the paper's order (from :mod:`predicates.catalogue`).
ALL = {dim: catalogue.predicates(dim) for dim in (2, 3)}

__all__ = ["ALL", "Instrumented", "Predicate", "Tolerances", "catalogue", "d2", "d3", "intersect",
           "tolerances", "tracked_tolerances"]
