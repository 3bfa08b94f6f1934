"""Registration of a simulation mesh against a cutting mesh (section 1 of the paper),
built on the algorithms of sections 4–5 (:mod:`predicates.d2`, :mod:`predicates.d3`).

One module per step (see :mod:`predicates.registration.pipeline` for how they fit):

* :mod:`~predicates.registration.inputs` — the call's forms, validation, exact scaling;
* :mod:`~predicates.registration.examples` — generated example meshes;
* :mod:`~predicates.registration.broadphase` — boxes within a distance, on a grid;
* :mod:`~predicates.registration.complex` — rank space and simplicial complexes;
* :mod:`~predicates.registration.levels` — candidates, suppression, the level loop;
* :mod:`~predicates.registration.refine` — refinement of coarse cutting meshes;
* :mod:`~predicates.registration.resolution` — L from the cells that can meet, report;
* :mod:`~predicates.registration.pipeline` — :func:`intersect`, :func:`intersect_files`;
* :mod:`~predicates.registration.partition`, :mod:`~predicates.registration.partition_run`
  — the same run in spatial partitions on Dask (``intersect(..., partitions=k)``);
* :mod:`~predicates.registration.result` — :class:`IntersectionResult`, :class:`KindPairs`;
* :mod:`~predicates.registration.files` — mesh files in and out;
* :mod:`~predicates.registration.io_read` — guarded reading of mesh files;
* :mod:`~predicates.registration.io_write` — checked outputs, atomic writes;
* :mod:`~predicates.registration.io_convert` — mesh objects (meshio, pyvista, trimesh);
* :mod:`~predicates.registration.consistency` — inconsistency counters;
* :mod:`~predicates.registration.plot` — pictures (matplotlib);
* :mod:`~predicates.registration.demo` — the built-in examples of ``fperr demo``.
"""
from .io_read import MeshFileError
from .pipeline import intersect, intersect_files
from .result import KIND_CODES, IntersectionResult, KindPairs

__all__ = ["KIND_CODES", "IntersectionResult", "KindPairs", "MeshFileError", "intersect",
           "intersect_files"]
