"""Run a sequence reconstruction on ``dask.distributed``: a local cluster sized to the machine, or
an existing scheduler (``tcp://HOST:8786``) whose workers read the capture from a shared path.

:func:`dask_executor` is an executor for :func:`fringe3d.reconstruct.sequence.reconstruct_sequence`
(as :func:`fringe3d.cluster.strain_frames.frames_on_dask` is a frame scheduler for strain): tasks
are chunks of consecutive 3D frames computed on the workers and sent back; the client writes
them and marks them done in the same loop as the serial path (so a resumed run skips them). A
task whose worker dies is re-run on another worker (``retries``).
"""
from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

from fringe3d.cluster.chunk_task import SequenceJob, run_chunk
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.reconstruct.executors import Done, WindowJob
from fringe3d.reconstruct.sequence import reconstruct_sequence
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.utils.output_folder import fingerprint

#: 3D frames per task: large enough to amortise scheduling (~1 ms a task), small enough to balance.
DEFAULT_CHUNK = 8


#: The Dask worker resource a ``backend="cuda"`` task asks for (start GPU workers with
#: ``dask worker tcp://HOST:8786 --resources GPU=1``).
GPU_RESOURCE = {"GPU": 1}


def connect(scheduler: str | None = None, workers: int | None = None, timeout: float = 10.0, gpu: bool = False):
    """A ``distributed.Client``: to ``scheduler`` if given, else to a new ``LocalCluster`` of
    ``workers`` single-threaded worker processes (default: one per core; with ``gpu`` one worker
    by default, each declaring :data:`GPU_RESOURCE`), each worker's numba kernels on its share
    of the cores (:func:`kernel_threads`).

    Raises ``ValueError`` naming the address when the scheduler cannot be reached.
    """
    import distributed  # optional extra fringe3d[dask]: loaded only when a cluster is asked for

    if scheduler is not None:
        try:
            return distributed.Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as e:
            raise ValueError(f"cannot reach the Dask scheduler at {scheduler} ({type(e).__name__}: {e}); start "
                             "one with `dask scheduler` or check the address (tcp://HOST:8786)") from None
    n = workers or (1 if gpu else os.cpu_count() or 1)
    cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                       silence_logs=40, resources=dict(GPU_RESOURCE) if gpu else None,
                                       env={"NUMBA_NUM_THREADS": str(kernel_threads(n))})
    return distributed.Client(cluster)


def kernel_threads(workers: int) -> int:
    """Numba threads of each of ``workers`` local worker processes: the cores shared among them
    (at least one). Each worker left at numba's default, all cores, put ``workers`` threads on
    every core, and a parallel kernel waits for its slowest thread."""
    return max(1, (os.cpu_count() or 1) // max(1, int(workers)))


def close(client, own_cluster: bool) -> None:
    """Close ``client`` (and the LocalCluster :func:`connect` started for it)."""
    cluster = client.cluster if own_cluster else None
    client.close()
    if cluster is not None:
        cluster.close()


def chunks_of(pending: list[int], size: int) -> list[list[int]]:
    """``pending`` 3D frame indices cut into runs of at most ``size``."""
    return [pending[i:i + size] for i in range(0, len(pending), size)]


def gpu_workers(client) -> list[str]:
    """Addresses of ``client``'s workers that declare the ``GPU`` resource."""
    workers = client.scheduler_info().get("workers", {})
    return [a for a, w in workers.items() if (w.get("resources") or {}).get("GPU", 0) >= 1]


class dask_executor:  # noqa: N801 - used as a function, as the executors of fringe3d.reconstruct.executors
    """An executor (:mod:`fringe3d.reconstruct.executors`) computing chunks of ``chunk`` 3D frames
    on ``client``'s workers; the job must come from a capture folder the workers can read.

    A ``"cuda"`` job's tasks ask for :data:`GPU_RESOURCE`, so they run only on workers that
    declare it; ``ValueError`` when no worker does. Chunks are yielded as they complete; at most
    ``in_flight`` (default: two per worker thread, at least 2) are submitted and not yet written.
    ``mark_every``: the writing loop marks frames done once per chunk (a killed run loses at most
    the chunks in flight).
    """

    def __init__(self, client, chunk: int = DEFAULT_CHUNK, retries: int = 3, in_flight: int | None = None):
        self.client, self.chunk, self.retries, self.in_flight = client, max(1, int(chunk)), retries, in_flight
        self.mark_every = self.chunk

    def __call__(self, job: WindowJob, todo: list[int]) -> Iterator[Done]:
        import distributed  # optional extra, see connect()

        client = self.client
        remote = sequence_job(job, client)
        resources = dict(GPU_RESOURCE) if remote.backend == "cuda" else None
        parts = chunks_of(todo, self.chunk)
        most = self.in_flight or max(2, 2 * sum(client.nthreads().values()))
        queue = distributed.as_completed()
        submitted = 0
        try:
            while submitted < len(parts) or not queue.is_empty():
                while submitted < len(parts) and queue.count() < most:
                    queue.add(client.submit(run_chunk, remote, parts[submitted], retries=self.retries, pure=False,
                                            resources=resources))
                    submitted += 1
                fut = next(queue)
                done = fut.result()
                fut.release()
                yield from done
        finally:
            client.cancel(list(queue.futures))


def sequence_job(job: WindowJob, client) -> SequenceJob:
    """The picklable description of ``job`` that a worker rebuilds (:func:`run_chunk`); checks
    that the frames come from a capture folder and, for the CUDA backend, that a worker has a GPU."""
    if job.capture is None:
        raise ValueError("the Dask executor reads the capture on the workers: pass the capture folder "
                         "(not an array of frames) to reconstruct_sequence")
    rec = job.rec
    if rec.backend == "cuda" and not gpu_workers(client):
        raise ValueError("the CUDA backend on Dask needs workers that declare a GPU: none of the cluster's "
                         "workers has the resource GPU; start them with `dask worker SCHEDULER --resources "
                         "GPU=1` on the GPU machines")
    key = fingerprint([job.capture.path], {"patterns": rec.patterns.to_dict(), "rig": rec.rig.to_dict(),
                                           "options": repr(rec.options), "starts": list(job.starts),
                                           "limit": job.capture.limit, "triangulation": rec.triangulation,
                                           "backend": rec.backend, "fast": rec.allow_fused})
    return SequenceJob(key=key, capture=job.capture.path, limit=job.capture.limit, patterns=rec.patterns, rig=rec.rig,
                       options=rec.options, starts=job.starts, triangulation=rec.triangulation, backend=rec.backend,
                       allow_relative=rec.allow_relative, fast=rec.allow_fused, ply=job.ply, layout=job.layout,
                       quality=job.quality)


def reconstruct_capture_on_dask(capture: CaptureFolder, patterns: PatternSet, rig: Rig, out: Path,
                                executor: dask_executor, decode: DecodeSettings | None = None,
                                outputs: OutputSettings | None = None, run: RunSettings | None = None) -> dict:
    """:func:`fringe3d.reconstruct.sequence.reconstruct_sequence` of a capture folder with the
    :func:`dask_executor` ``executor`` (its client from :func:`connect`): same store, same point maps
    (bit-identical: the same per-window code runs on the workers, the same loop writes), same
    summary plus ``workers`` and ``tasks``. ``capture``: the folder and frame limit the workers read."""
    res = reconstruct_sequence(capture, patterns, rig, out, decode, outputs, run, executor=executor)
    return {**res, "workers": len(executor.client.scheduler_info().get("workers", {})),
            "tasks": -(-res["done_now"] // executor.chunk)}
