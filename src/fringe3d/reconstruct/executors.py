"""Executors: who computes a sequence's 3D frames (the loop that writes them is one,
:func:`fringe3d.reconstruct.sequence.reconstruct_sequence`).

An executor is a callable ``executor(job, todo)`` yielding ``(k, cycle, empty)`` for every 3D
frame ``k`` of ``todo`` (any order) where ``job`` is a :class:`WindowJob`; it computes, the caller
writes and keeps the books (store, PLY files, ``done`` marks, summary). :func:`serial` runs here (reading ahead),
:func:`threads` on a thread pool, and ``fringe3d.cluster.engine.dask_executor`` on Dask workers.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numba

from fringe3d.io.capture_frames import CaptureFolder, CaptureFrames, read_threads
from fringe3d.io.read_ahead import DEPTH, ReadAhead
from fringe3d.reconstruct.frame import (Cycle, FrameReconstructor, LaterCycle, reconstructed_cycles,
                                      reconstructed_windows, window_frames)

#: Cycles per batched launch on the CUDA backend (one cycle at a time on the CPU).
CUDA_BATCH = 32

Done = tuple[int, Cycle | LaterCycle, bool]
Executor = Callable[["WindowJob", list[int]], Iterator[Done]]


@dataclass(frozen=True)
class WindowJob:
    """The 3D frames to compute: the engine ``rec``, the capture's ``frames`` (F, H, W) array-like
    (and, for executors that reopen it elsewhere, its ``capture`` folder), each
    3D frame's first frame ``starts``, and what the outputs need: ``ply`` (points and texture),
    ``layout`` (the store's, or None) and ``quality`` (quality map and sigma_z)."""

    rec: FrameReconstructor
    frames: Any
    starts: tuple[int, ...]
    ply: bool
    layout: str | None
    quality: bool
    capture: CaptureFolder | None = None

    def run(self, ks: list[int]) -> list[Done]:
        """``(k, cycle, empty)`` of the 3D frames ``ks`` (:func:`reconstructed_windows`)."""
        return list(reconstructed_windows(self.rec, self.frames, list(self.starts), list(ks), self.ply,
                                          self.layout, self.quality))


def batch_size(job: WindowJob) -> int:
    """3D frames computed together: :data:`CUDA_BATCH` on the CUDA backend (one launch), else 1."""
    return CUDA_BATCH if job.rec.backend == "cuda" else 1


def serial(job: WindowJob, todo: list[int]) -> Iterator[Done]:
    """Every 3D frame of ``todo`` in this thread, in order, the next batches' frames read ahead on a
    reader thread (:class:`~fringe3d.io.read_ahead.ReadAhead`: PNG or TIFF decoding is off the
    compute's path; a few cycles in memory at most). The fused path's sigma_z is left for later
    (``Cycle.sigma_later``) and, on the CPU without points and with enough cores
    (:func:`finish_on_writers`), all but the kernel's pass (a
    :class:`~fringe3d.reconstruct.frame.LaterCycle`), which the store writers' threads finish
    (:func:`~fringe3d.reconstruct.frame.with_sigma`): the quality map, the noise estimate and
    the sigma_z pass leave the compute's path. Which of the two is decided here, on the caller's
    numba threads, before the loop that writes the frames gives the kernels fewer of them beside
    its writers (decided lazily there, on those fewer threads, it came out the other way on 2 and
    3 threads, and on 4 to 6 under the former threshold of 4)."""
    later = "all" if finish_on_writers() else True
    return _serial(job, todo, later)


def _serial(job: WindowJob, todo: list[int], later: bool | str) -> Iterator[Done]:
    """:func:`serial`'s loop, ``later`` decided."""
    size = batch_size(job)
    parts = [todo[b0:b0 + size] for b0 in range(0, len(todo), size)]
    n = len(job.rec.patterns)
    workers = read_workers(job.frames, n)
    with ReadAhead(lambda ks: window_frames(job.frames, job.starts, ks, n), parts, depth=DEPTH + workers - 1,
                   workers=workers) as read:
        for ks, cycles in zip(parts, read):
            yield from reconstructed_cycles(job.rec, ks, cycles, job.ply, job.layout, job.quality, later=later)


#: numba threads from which :func:`serial` leaves all but the fused kernel's pass to the store
#: writers (:func:`finish_on_writers`)
FINISH_ON_WRITERS_FROM = 2


def finish_on_writers() -> bool:
    """Whether :func:`serial` leaves the quality map, the masking and sigma_z to the store
    writers (:meth:`~fringe3d.reconstruct.frame.FrameReconstructor.fused_later`): from
    :data:`FINISH_ON_WRITERS_FROM` numba threads. The main thread then runs the fused kernel
    alone (5.6 instead of 15.8 ms of CPU a 1280 x 1024 frame), which bounds the rate no longer,
    and at least two writers (:func:`~fringe3d.reconstruct.sequence.writer_threads`) finish the
    frames beside it: on 2 cores three busy threads, so neither core idles while one stage waits
    for the other (with one writer finishing only sigma_z, the main thread and the writer each
    spent about 14 ms a frame and took turns waiting). On a 2-core machine shared with other
    work, 60 cycles from the MRAW file (the two settings alternated in one process, 5-12 rounds,
    four sessions; ``docs/long-sequences.md``) ran 4-13 % faster in the median for the same
    process CPU (about 36 ms a frame either way).
    """
    return numba.get_num_threads() >= FINISH_ON_WRITERS_FROM


def read_workers(frames, n: int) -> int:
    """Windows read at once by :func:`serial`: for frames decoded from files
    (:class:`~fringe3d.io.capture_frames.CaptureFrames`), as many as fill the file-decoding
    threads with ``n``-frame windows (at least 2: a 3-frame window on two decoding threads leaves
    one idle for its last file), else 1 (a camera file or an array: reading is a copy)."""
    if not isinstance(frames, CaptureFrames):
        return 1
    return max(2, -(-read_threads() // max(1, n)))


def threads(workers: int = 2, in_flight: int | None = None) -> Executor:
    """An executor computing ``workers`` batches at once on a thread pool (the numba kernels
    release the GIL), yielding in order; at most ``in_flight`` batches (default ``2 * workers``)
    are computed ahead of the one being written (bounded memory). Each worker's kernels run on
    ``max(1, n // workers)`` numba threads, ``n`` the caller's (:func:`numba.get_num_threads`):
    the workers share the cores instead of each spreading over all of them."""

    def run(job: WindowJob, todo: list[int]) -> Iterator[Done]:
        size = batch_size(job)
        parts = [todo[i:i + size] for i in range(0, len(todo), size)]
        most = in_flight or 2 * workers
        per_worker = max(1, numba.get_num_threads() // workers)

        def compute(ks: list[int]) -> list[Done]:
            numba.set_num_threads(per_worker)  # this worker thread's own setting
            return job.run(ks)

        with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="fringe3d-frames") as pool:
            pending: deque = deque()
            try:
                for ks in parts:
                    pending.append(pool.submit(compute, ks))
                    while len(pending) >= most:
                        yield from pending.popleft().result()
                while pending:
                    yield from pending.popleft().result()
            finally:
                for fut in pending:
                    fut.cancel()

    return run
