"""Long sequences on Dask: pattern cycles (or windows) as tasks on a local or remote cluster.

:func:`~fringe3d.cluster.engine.reconstruct_on_dask` runs the same per-window reconstruction as
:func:`fringe3d.reconstruct.sequence.reconstruct_sequence` on ``dask.distributed`` workers,
writing into the same resumable zarr point store; see ``docs/long-sequences.md``.
"""
