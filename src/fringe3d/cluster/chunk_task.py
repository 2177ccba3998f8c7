"""The task a Dask worker runs: reconstruct a chunk of 3D frames and write them into the store.

Workers read the capture themselves (from a path they share with the client) and write each
point map into its own zarr chunk (one chunk per 3D frame, so writers never share a chunk); the
client alone marks frames done, once their task has returned. A worker that dies mid-chunk
leaves frames that are written but not marked: they are simply computed again.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fringe3d.decode.options import DecodeOptions
from fringe3d.io.capture import open_frames
from fringe3d.io.store import PointMapStore
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.utils.provenance import use_command_line
from fringe3d.reconstruct.sequence import (
    CaptureFrames,
    FrameReconstructor,
    reconstructed_windows,
    store_arrays,
    write_ply_frame,
)


@dataclass(frozen=True)
class SequenceJob:
    """Everything a worker needs to reconstruct any 3D frame of a sequence (picklable).

    ``capture`` is a capture folder the worker can read; ``limit`` the number of frames used;
    ``starts`` the first frame of each 3D frame's window; ``store`` the zarr point store (or None)
    and ``ply_dir`` the PLY folder (or None). ``key`` identifies the job (its fingerprint) so a
    worker builds the reconstructor (minimum phase, ray coefficients) once per job. ``backend``
    ``"cuda"`` runs the per-pixel kernels on the worker's GPU (its tasks ask for the worker
    resource ``{"GPU": 1}``, see :mod:`fringe3d.cluster.engine`), a chunk's cycles in one launch.
    ``command`` is the client's command line, recorded in the files the worker writes (PLY
    provenance comments) as the serial path records it. ``allow_relative``: the client accepted a
    wrapped or relative phase (:class:`~fringe3d.reconstruct.sequence.FrameReconstructor`).
    """

    key: str
    capture: str
    limit: int
    patterns: PatternSet
    rig: Rig
    options: DecodeOptions
    starts: tuple[int, ...]
    triangulation: str = "auto"
    store: str | None = None
    ply_dir: str | None = None
    backend: str = "cpu"
    command: str = ""
    allow_relative: bool = False


_WORKER_CACHE: dict[str, tuple] = {}  # job key -> (reconstructor, frames, store)


def _worker_state(job: SequenceJob):
    """The job's reconstructor, frame reader and store, built once per worker process."""
    if job.key not in _WORKER_CACHE:
        _WORKER_CACHE.clear()  # one job at a time per worker: drop the previous job's tables
        rec = FrameReconstructor(job.patterns, job.rig, job.options, triangulation=job.triangulation,
                                 backend=job.backend, allow_relative=job.allow_relative)
        frames = open_frames(job.capture, limit=job.limit)  # a referenced camera file, else frames/ files
        frames = frames if frames is not None else CaptureFrames(job.capture, limit=job.limit)
        store = PointMapStore.open_existing(job.store) if job.store else None
        _WORKER_CACHE[job.key] = (rec, frames, store)
    return _WORKER_CACHE[job.key]


def run_chunk(job: SequenceJob, ks: list[int]) -> dict:
    """Reconstruct the 3D frames ``ks`` of ``job`` and write them; returns ``{"done": ks, "empty": n}``.

    Each frame is the same :func:`~fringe3d.reconstruct.sequence.reconstruct_window` the serial
    path runs, written with the same arrays. Frames whose phase mask is empty are written as
    all-NaN point maps and counted.
    """
    rec, frames, store = _worker_state(job)
    use_command_line(job.command)
    empty = 0
    ply = job.ply_dir is not None
    layout = store.layout if store is not None else None
    quality = store is not None and store.has_quality
    for k, cyc, was_empty in reconstructed_windows(rec, frames, job.starts, list(ks), ply, layout, quality):
        empty += was_empty
        if job.ply_dir is not None:
            write_ply_frame(Path(job.ply_dir), k, cyc)
        if store is not None:
            store.write_frame(k, **store_arrays(cyc, store))
    return {"done": list(ks), "empty": empty}
