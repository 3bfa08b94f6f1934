"""Two mesh files registered in partitions with one output file per partition, each
written by its partition's task on the workers (docs/partitioned.md 6; the files'
rule and staging: :mod:`.outputs`) — the library side of ``fperr intersect ...
--workers N -o 'hits_{part}.vtu'``. Above the pipeline (it calls
:func:`predicates.registration.intersect`), which the partitioned run below it never
imports."""
from __future__ import annotations

import os

import numpy as np

from predicates.registration.partition.files import part_paths
from predicates.registration.partition.outputs import PartFiles

__all__ = ["intersect_files_parts"]


def intersect_files_parts(sim, cut, pattern: str | os.PathLike, *,
                          partitions: int | str = "auto", scheduler="threads",
                          plot=None, sim_output=None, dtype: str = "float64",
                          naive: bool = False, sim_region=None, cut_region=None,
                          **options):
    """:func:`predicates.registration.intersect_files` with one file per partition
    (``pattern``: ``"hits_{part}.vtu"``), each written by its partition's task
    (:class:`PartFiles`); ``plot`` and ``sim_output`` written by the client as there.
    Every path is checked before any work, and nothing is written when the run is
    refused or fails. Returns the result (its pairs merged as always)."""
    from predicates.registration.io.files import input_roles, load_pair, write_results
    from predicates.registration.io.write import check_outputs
    from predicates.registration.pipeline import CHUNK, intersect
    from predicates.registration.plan.inputs import validate_options

    # before any work, as intersect_files does
    validate_options(dtype, 0.0, options.get("progress", False), options.get("chunk", CHUNK))
    if not isinstance(naive, (bool, np.bool_)):
        raise TypeError(f"naive must be True or False, got {naive!r}")
    roles = input_roles(sim, cut)
    others = {("--plot", "plot"): plot, ("--sim-output", "mesh"): sim_output}
    check_outputs(roles, {("-o", "mesh"): part_paths(pattern, 1)[0], **others})
    arrays = load_pair(sim, cut, dtype=dtype, sim_region=sim_region,
                       cut_region=cut_region, scheduler=scheduler)
    if plot is not None and arrays[0].shape[1] != 2:
        raise ValueError("plots are drawn for 2D meshes only (this case is 3D; open the "
                         "output in ParaView instead)")
    files = PartFiles(os.fspath(pattern), partitions, roles, others, arrays.plane)
    res = intersect(*arrays, dtype=np.dtype(dtype), tolerance_scale=0.0 if naive else 1.0,
                    partitions=files, scheduler=scheduler, **options)
    res.notes[:0] = arrays.notes
    res.plane = arrays.plane
    write_results(res, plot=plot, sim_output=sim_output)
    return res
