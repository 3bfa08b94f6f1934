"""The same registration in spatial partitions on Dask, with the identical result
(docs/partitioned.md): assigning cells to partitions and merging, the halos' slices,
and the run on a client (workers, tasks, progress, failures, per-partition files)."""
