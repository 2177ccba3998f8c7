"""The strain run's per-frame work (tracking + Kirchhoff–Love strain, Eq. 6.9–6.21) on ``dask.distributed``.

:func:`frames_on_dask` is a frame scheduler for :func:`fringe3d.analyze.wing_strain.run_strain`:
the :class:`~fringe3d.analyze.frame_task.StrainFrameTask` (the sequence's path, the wings'
references, every frame's anchors) is scattered to every worker once; each 3D frame is then one
task that the worker runs on its copy, reading that frame from the shared path itself. Only the
frame index goes out and one frame's per-point results (a few arrays of N points per wing) come
back; the client writes every file, in frame order, as the threaded path does. A task whose
worker dies is re-run by Dask on another worker (the task is held by every worker, so no data is
lost with one); at most ``in_flight`` frames are submitted and not yet consumed (bounded memory).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Iterator

from fringe3d.analyze.frame_task import StrainFrameTask
from fringe3d.analyze.strain import WingFrame

#: Frames submitted per worker thread ahead of the one being written.
FRAMES_PER_THREAD = 2


def run_frame(task: StrainFrameTask, f: int) -> list[WingFrame]:
    """What a worker runs: ``task(f)`` on the worker's (scattered) copy of the task."""
    return task(f)


def frames_on_dask(client, in_flight: int | None = None, retries: int = 3):
    """A frame scheduler ``frames(task, n)`` running ``task(f)`` on ``client``'s workers.

    Yields ``(f, task(f))`` for f = 0 … n − 1 in order. ``in_flight``: frames submitted at once
    (default :data:`FRAMES_PER_THREAD` × the cluster's worker threads, at least 2). ``retries``:
    re-runs of a task that raised (a worker's death is handled by Dask itself). An error in a
    frame is raised at its turn; the frames not yet done are cancelled.
    """

    def frames(task: StrainFrameTask, n: int) -> Iterator[tuple[int, list[WingFrame]]]:
        most = in_flight or max(2, FRAMES_PER_THREAD * sum(client.nthreads().values()))
        remote = client.scatter(task, broadcast=True, hash=False)
        pending: deque = deque()
        try:
            nxt = 0
            while nxt < n or pending:
                while nxt < n and len(pending) < most:
                    pending.append((nxt, client.submit(run_frame, remote, nxt, pure=False, retries=retries)))
                    nxt += 1
                f, fut = pending.popleft()
                result = fut.result()
                fut.release()
                yield f, result
        finally:
            client.cancel([fut for _, fut in pending] + [remote])

    return frames
