"""Run a sequence reconstruction on ``dask.distributed``: a local cluster sized to the machine, or
an existing scheduler (``tcp://HOST:8786``) whose workers read the capture from a shared path.

Tasks are chunks of consecutive 3D frames; finished chunks are marked done in the point store by
the client as they complete (so a resumed run skips them), a task whose worker dies is re-run on
another worker (``retries``), and progress comes from the completed futures.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from fringe3d.cluster.chunk_task import SequenceJob, run_chunk
from fringe3d.decode.options import DecodeOptions
from fringe3d.io.capture import open_frames
from fringe3d.io.store import PointMapStore
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.reconstruct.sequence import (
    PLY_DIR,
    STORE_NAME,
    CaptureFrames,
    FrameReconstructor,
    ply_name,
    prepare_sequence,
)
from fringe3d.utils.console import progress_bar
from fringe3d.utils.output_folder import fingerprint
from fringe3d.utils.provenance import command_line

#: 3D frames per task: large enough to amortise scheduling (~1 ms a task), small enough to balance.
DEFAULT_CHUNK = 8


#: The Dask worker resource a ``backend="cuda"`` task asks for (start GPU workers with
#: ``dask worker tcp://HOST:8786 --resources GPU=1``).
GPU_RESOURCE = {"GPU": 1}


def connect(scheduler: str | None = None, workers: int | None = None, timeout: float = 10.0, gpu: bool = False):
    """A ``distributed.Client``: to ``scheduler`` if given, else to a new ``LocalCluster`` of
    ``workers`` single-threaded worker processes (default: one per core; with ``gpu`` one worker
    by default, each declaring :data:`GPU_RESOURCE`).

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
                                       silence_logs=40, resources=dict(GPU_RESOURCE) if gpu else None)
    return distributed.Client(cluster)


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


def reconstruct_on_dask(job: SequenceJob, client, chunk: int = DEFAULT_CHUNK, progress: bool = True,
                        retries: int = 3) -> dict:
    """Reconstruct every pending 3D frame of ``job`` on ``client``'s workers.

    A ``job.backend == "cuda"`` job's tasks ask for :data:`GPU_RESOURCE`, so they run only on
    workers that declare it, one task per GPU at a time; ``ValueError`` when no worker does.

    Returns ``{"done_now", "done_before", "empty_frames", "seconds", "frames_3d_per_s", "tasks"}``.
    """
    resources = None
    if job.backend == "cuda":
        if not gpu_workers(client):
            raise ValueError("the CUDA backend on Dask needs workers that declare a GPU: none of the cluster's "
                             "workers has the resource GPU; start them with `dask worker SCHEDULER --resources "
                             "GPU=1` on the GPU machines")
        resources = dict(GPU_RESOURCE)
    store = PointMapStore.open_existing(job.store) if job.store else None
    if store is not None:
        pending = store.pending()
    else:  # PLY only: a frame is done when its file exists
        pending = [k for k in range(len(job.starts)) if not (Path(str(job.ply_dir)) / ply_name(k)).exists()]
    before = len(job.starts) - len(pending)
    parts = chunks_of(pending, max(1, chunk))
    t0 = time.perf_counter()
    empty = 0
    import distributed  # optional extra, see connect()

    futures = [client.submit(run_chunk, job, ks, retries=retries, pure=False, resources=resources) for ks in parts]
    with progress_bar("reconstructing 3D frames", len(pending), enabled=progress and len(pending) > 1) as advance:
        for fut in distributed.as_completed(futures):
            res = fut.result()
            if store is not None:
                store.mark_done(res["done"])
            empty += res["empty"]
            advance(len(res["done"]))
    dt = time.perf_counter() - t0
    return {"done_now": len(pending), "done_before": before, "empty_frames": empty, "seconds": round(dt, 3),
            "frames_3d_per_s": (len(pending) / dt) if pending and dt > 0 else None, "tasks": len(parts)}


def reconstruct_capture_on_dask(capture: str | os.PathLike, patterns: PatternSet, rig: Rig, out: Path,
                                options: DecodeOptions | None = None, *, limit: int | None = None,
                                mode: str = "cycle", step: int | None = None, ply: bool = False, store: bool = True,
                                triangulation: str = "auto", client=None, chunk: int = DEFAULT_CHUNK,
                                progress: bool = True, layout: str = "auto", store_quality: bool = True,
                                backend: str = "cpu", codec: str | None = None,
                                allow_relative: bool = False) -> dict:
    """:func:`fringe3d.reconstruct.sequence.reconstruct_sequence` of a capture folder, on Dask.

    Same store, same point maps (bit-identical: the same per-window code runs on the workers),
    same summary, plus ``workers`` and ``tasks``. ``client`` from :func:`connect`; ``layout``
    ``store_quality``, ``codec`` and ``allow_relative`` as there; ``backend`` as
    :class:`~fringe3d.cluster.chunk_task.SequenceJob`.
    """
    frames = open_frames(capture, limit=limit)
    frames = frames if frames is not None else CaptureFrames(capture, limit=limit)
    out = Path(out)
    options = options or DecodeOptions()
    rec = FrameReconstructor(patterns, rig, options, triangulation=triangulation, allow_relative=allow_relative)
    starts, st = prepare_sequence(frames.shape, patterns, rig, out, options, mode, step, ply, store, rec=rec,
                                  layout=layout, store_quality=store_quality, codec=codec)
    key = fingerprint([capture], {"patterns": patterns.to_dict(), "rig": rig.to_dict(), "options": repr(options),
                                  "mode": mode, "step": step, "limit": limit, "triangulation": triangulation,
                                  "layout": layout, "store_quality": store_quality, "backend": backend})
    job = SequenceJob(key=key, capture=str(Path(capture).resolve()), limit=len(frames), patterns=patterns, rig=rig,
                      options=options, starts=tuple(starts), triangulation=triangulation,
                      store=str((out / STORE_NAME).resolve()) if st is not None else None,
                      ply_dir=str((out / PLY_DIR).resolve()) if ply else None, backend=backend,
                      command=command_line(), allow_relative=allow_relative)
    res = reconstruct_on_dask(job, client, chunk=chunk, progress=progress)
    return {"out": str(out), "frames_3d": len(starts), **res, "path": rec.path, "mode": mode, "backend": backend,
            "store": str(out / STORE_NAME) if store else None, "ply_dir": str(out / PLY_DIR) if ply else None,
            "store_layout": st.layout if st is not None else None,
            "workers": len(client.scheduler_info().get("workers", {}))}
