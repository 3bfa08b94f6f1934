"""Registration of a simulation mesh against a cutting mesh (section 1 of the paper),
built on the algorithms of sections 4–5 (:mod:`predicates.d2`, :mod:`predicates.d3`).

Subpackages, in the order a run uses them (imports point from later to earlier;
docs/design.md has one line per module):

* :mod:`~predicates.registration.spatial` — blocks, exact boxes, grids, the broad phase;
* :mod:`~predicates.registration.plan` — inputs and validation, exact scaling, refinement
  of coarse cutting meshes, L and the resolution report;
* :mod:`~predicates.registration.levels` — complexes, face pairs, the level loop;
* :mod:`~predicates.registration.result` — :class:`IntersectionResult`, exports, consistency;
* :mod:`~predicates.registration.partition` — the same run in partitions on Dask;
* :mod:`~predicates.registration.pipeline` — :func:`intersect`, :func:`intersect_files`;
* :mod:`~predicates.registration.io` — mesh objects and files in and out;
* :mod:`~predicates.registration.split` — the virtual-node split along the cut;
* :mod:`~predicates.registration.pictures` — pictures and ``fperr demo``;
* :mod:`~predicates.registration.examples` (with :mod:`predicates.portable`) —
  generated example meshes and the machine-independent arithmetic they use.
"""
from predicates.registration.io.read import MeshFileError
from predicates.registration.pipeline import intersect, intersect_files
from predicates.registration.result.intersection import (
    KIND_CODES, IntersectionResult, KindPairs)

__all__ = ["KIND_CODES", "IntersectionResult", "KindPairs", "MeshFileError", "intersect",
           "intersect_files"]
