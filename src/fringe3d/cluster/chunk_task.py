"""The task a Dask worker runs: compute a chunk of 3D frames and send them back to the client.

Workers read the capture themselves (from a path they share with the client) and build the
engine once per job; the client writes every frame and keeps the books, as for the serial and
threaded executors (:func:`fringe3d.reconstruct.sequence.reconstruct_sequence`). A worker that
dies mid-chunk loses nothing: Dask re-runs its task elsewhere.
"""
from __future__ import annotations

from dataclasses import dataclass

from fringe3d.decode.options import DecodeOptions
from fringe3d.io.capture_frames import capture_frames
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.reconstruct.executors import Done
from fringe3d.reconstruct.frame import FrameReconstructor, reconstructed_windows


@dataclass(frozen=True)
class SequenceJob:
    """Everything a worker needs to compute any 3D frame of a sequence (picklable).

    ``capture`` is a capture folder the worker can read; ``limit`` the number of frames used;
    ``starts`` the first frame of each 3D frame's window; ``ply``, ``layout`` (the store's, or
    None) and ``quality`` what the client's outputs need (:class:`~fringe3d.reconstruct.executors.
    WindowJob`). ``key`` identifies the job so a worker builds the engine (minimum phase, ray
    coefficients) once per job. ``backend`` ``"cuda"`` runs the per-pixel kernels on the worker's
    GPU (its tasks ask for the worker resource ``{"GPU": 1}``, see :mod:`fringe3d.cluster.engine`),
    a chunk's cycles in one launch. ``fast``, ``triangulation`` and ``allow_relative`` as the
    client's :class:`~fringe3d.reconstruct.frame.FrameReconstructor`.
    """

    key: str
    capture: str
    limit: int | None
    patterns: PatternSet
    rig: Rig
    options: DecodeOptions
    starts: tuple[int, ...]
    triangulation: str = "auto"
    backend: str = "cpu"
    allow_relative: bool = False
    fast: bool = True
    ply: bool = False
    layout: str | None = None
    quality: bool = False


_WORKER_CACHE: dict[str, tuple] = {}  # job key -> (reconstructor, frames)


def _worker_state(job: SequenceJob):
    """The job's reconstructor and frame reader, built once per worker process."""
    if job.key not in _WORKER_CACHE:
        _WORKER_CACHE.clear()  # one job at a time per worker: drop the previous job's tables
        rec = FrameReconstructor(job.patterns, job.rig, job.options, triangulation=job.triangulation,
                                 fast=job.fast, backend=job.backend, allow_relative=job.allow_relative)
        _WORKER_CACHE[job.key] = (rec, capture_frames(job.capture, limit=job.limit))
    return _WORKER_CACHE[job.key]


def run_chunk(job: SequenceJob, ks: list[int]) -> list[Done]:
    """``(k, cycle, empty)`` of the 3D frames ``ks`` of ``job`` (what the client writes)."""
    rec, frames = _worker_state(job)
    return list(reconstructed_windows(rec, frames, list(job.starts), list(ks), job.ply, job.layout, job.quality))
