"""High-speed sequences: many captured frames -> one 3D frame per pattern cycle or sliding window.

A capture of ``F`` frames repeats the manifest's cycle of ``n`` patterns. Two ways to cut it:

* ``mode="cycle"``: frames ``[c*n, (c+1)*n)`` -> 3D frame ``c`` (F/n 3D frames);
* ``mode="window"``: every ``step`` frames a window of ``n`` consecutive frames (any phase of
  the cycle) -> one 3D frame, ``(F - n)//step + 1`` 3D frames; the window's frames are
  reordered into manifest order, which is what superfast systems do to reach one 3D frame per
  captured frame.

Each 3D frame is one cycle for the engine, :class:`fringe3d.reconstruct.frame.FrameReconstructor`
(decode + triangulate, or the fused 3-step kernel); this module only sequences them.
Outputs: a resumable zarr store (:class:`fringe3d.io.store.PointMapStore`) and/or one PLY per
3D frame; an interrupted run picks up where it stopped.
"""
from __future__ import annotations

import contextlib
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterator

import numba
import numpy as np

from fringe3d.io.capture_frames import CaptureFolder, CaptureFrames
from fringe3d.io.ply_standard import write_measurement_ply
from fringe3d.io.store import PointMapStore, StoreSettings
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.manifest import PatternSet
from fringe3d.reconstruct.executors import FINISH_ON_WRITERS_FROM, Executor, WindowJob, serial
from fringe3d.reconstruct.frame import Cycle, FrameReconstructor, store_layout, reconstruction_plans, with_sigma
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.windows import window_index, window_starts
from fringe3d.utils.camera_size import check_camera_size
from fringe3d.utils.console import progress_bar

__all__ = ["CaptureFrames", "DecodeSettings", "FrameReconstructor", "OutputSettings", "RunSettings",
           "prepare_sequence", "reconstruct_sequence", "window_index", "window_starts", "reconstruction_plans"]

STORE_NAME = "points.zarr"
PLY_DIR = "ply"


def write_ply_frame(ply_dir: Path, k: int, cycle: Cycle) -> None:
    """3D frame ``k``'s points and texture as ``ply_dir/frame_NNNNN.ply`` (the measurement PLY,
    :func:`fringe3d.io.ply_standard.write_measurement_ply`, with ``scalar_sigma_z_mm`` when the
    cycle has it); nothing for a frame with no point."""
    if cycle.points is not None and np.isfinite(cycle.points[..., 0]).any():
        write_measurement_ply(Path(ply_dir) / ply_name(k), cycle.points, cycle.texture, sigma_z=cycle.sigma_z)


def store_arrays(cycle: Cycle, st: PointMapStore) -> dict:
    """The keyword arguments of :meth:`PointMapStore.write_frame` for ``cycle`` in ``st``."""
    out: dict = {"points": cycle.points} if st.layout == "xyz" else {"depth": cycle.depth}
    if st.has_quality:
        out["quality"] = cycle.quality
    if st.has_sigma:
        H, W = st.shape
        out["sigma_z"] = (cycle.sigma_z if cycle.sigma_z is not None
                          else np.full((H, W), np.nan, np.float32))
    return out


# ----------------------------------------------------------------------------- sequences
def ply_name(k: int) -> str:
    return f"frame_{k:05d}.ply"


def prepare_sequence(shape: tuple[int, ...], patterns: PatternSet, rig: Rig, out: Path, rec: FrameReconstructor,
                     decode: DecodeSettings, outputs: OutputSettings) -> tuple[list[int], PointMapStore | None]:
    """Check a sequence of frames of ``shape`` (F, H, W) against the rig, create (or resume) the
    point store and the PLY folder in ``out``; returns the windows' first frames and the store.

    ``rec`` (the sequence's reconstructor) chooses the store layout (:func:`store_layout`);
    ``decode`` gives the windows (``mode``, ``step``), ``outputs`` what to write."""
    if not (outputs.ply or outputs.store):
        raise ValueError("nothing to write: ask for the point store and/or PLY files")
    if len(shape) != 3:
        raise ValueError(f"frames must be an (F, H, W) stack, got shape {tuple(shape)}")
    H, W = shape[1:]
    check_camera_size((H, W), (rig.camera.height, rig.camera.width))
    starts = window_starts(shape[0], len(patterns), decode.mode, decode.step)
    st = None
    lay = store_layout(rec, outputs.layout) if outputs.store else None  # one it cannot fill: before writing
    out.mkdir(parents=True, exist_ok=True)
    meta = {"patterns": patterns.name, "mode": decode.mode, "step": decode.step, "z_min": decode.options.z_min,
            "rig": rig.to_dict(), "window_starts": [starts[0], starts[-1], len(starts)]}
    if lay is not None:
        kept = StoreSettings(lay, quality=outputs.store_quality, sigma=outputs.store_quality, codec=outputs.codec)
        st = PointMapStore.open(out / STORE_NAME, len(starts), H, W, meta=meta, settings=kept,
                                rays=rec.rays if lay == "ray_depth" else None,
                                times=None if outputs.frame_rate is None
                                else np.asarray(starts, np.float64) / outputs.frame_rate)
    if outputs.ply:
        (out / PLY_DIR).mkdir(exist_ok=True)
    return starts, st


#: Written frames marked done at once (one write of the store's ``done`` array and attributes; an
#: interrupted run recomputes at most this many frames whose chunks were already written).
MARK_EVERY = 16


def reconstruct_sequence(frames, patterns: PatternSet, rig: Rig | RigGeometry, out,
                         decode: DecodeSettings | None = None, outputs: OutputSettings | None = None,
                         run: RunSettings | None = None,
                         executor: Executor = serial) -> dict:
    """Reconstruct every 3D frame of a sequence into ``out`` (resumable).

    Parameters
    ----------
    frames : (F, H, W) array (or a memory map, a :class:`CaptureFrames`, or a
        :class:`~fringe3d.io.capture_frames.CaptureFolder`, which executors running elsewhere
        need), in projection order
    patterns : the manifest (its plans choose the unwrapping; see :func:`reconstruction_plans`)
    rig : the calibrated rig, or its :class:`~fringe3d.optics.rig_geometry.RigGeometry` (the maps
        a caller's checks already computed, e.g. :func:`fringe3d.decode.plan_checks.check_plans`'
        minimum phase map, are then reused, not computed again)
    out : output folder: ``points.zarr`` and/or ``ply/frame_00000.ply`` ...
    decode, outputs, run : :class:`~fringe3d.reconstruct.settings.DecodeSettings` (options,
        triangulation, windows), :class:`~fringe3d.reconstruct.settings.OutputSettings` (PLY,
        store, layout, quality, codec), :class:`~fringe3d.reconstruct.settings.RunSettings`
        (backend, progress); defaults when None
    executor : who computes the 3D frames (:mod:`fringe3d.reconstruct.executors`: :func:`serial`,
        ``threads(n)``, ``fringe3d.cluster.engine.dask_executor(client)``); this loop writes
        them, marks them done (every ``executor.mark_every`` frames, default :data:`MARK_EVERY`)
        and counts them whichever computes

    Returns a summary dict (3D frames, done now / before, empty frames, seconds, 3D frames per
    second, path, mode, backend, store, PLY folder, store layout).
    """
    decode, outputs, run = decode or DecodeSettings(), outputs or OutputSettings(), run or RunSettings()
    capture = None
    if isinstance(frames, CaptureFolder):
        capture, frames = CaptureFolder(str(Path(frames.path).resolve()), frames.limit), frames.open()
    frames = frames if hasattr(frames, "shape") else np.asarray(frames)
    out = Path(out)
    geometry = rig if isinstance(rig, RigGeometry) else None
    rig = rig.rig if isinstance(rig, RigGeometry) else rig
    rec = FrameReconstructor(patterns, rig, decode.options, triangulation=decode.triangulation, fast=decode.fast,
                             backend=run.backend, allow_relative=decode.allow_relative, geometry=geometry)
    starts, st = prepare_sequence(frames.shape, patterns, rig, out, rec, decode, outputs)

    def done(k):
        return (st is None or st.is_done(k)) and (not outputs.ply or (out / PLY_DIR / ply_name(k)).exists())

    todo = [k for k in range(len(starts)) if not done(k)]
    job = WindowJob(rec, frames, tuple(starts), outputs.ply, st.layout if st is not None else None,
                    st is not None and st.has_quality, capture=capture)
    t0 = time.perf_counter()
    mark_every = int(getattr(executor, "mark_every", MARK_EVERY))
    empty = _write_all(executor(job, todo), out, (st, mark_every), outputs.ply, run.progress and len(todo) > 1,
                       len(todo))
    dt = time.perf_counter() - t0
    return {"out": str(out), "frames_3d": len(starts), "done_now": len(todo), "done_before": len(starts) - len(todo),
            "empty_frames": empty, "seconds": round(dt, 3),
            "frames_3d_per_s": (len(todo) / dt) if todo and dt > 0 else None, "path": rec.path, "mode": decode.mode,
            "backend": run.backend, "store": str(out / STORE_NAME) if outputs.store else None,
            "ply_dir": str(out / PLY_DIR) if outputs.ply else None,
            "store_layout": st.layout if st is not None else None}


def _write_all(results: Iterator, out: Path, store: tuple[PointMapStore | None, int], ply: bool, progress: bool,
               n: int) -> int:
    """Write every ``(k, cycle, empty)`` of ``results`` into ``store`` = (the store or None, frames
    marked done at once) and, with ``ply``, ``out/ply``: on :func:`writer_threads` writer threads
    (what the executor left for later: quality map, sigma_z; compression, file writes), several
    frames at once, behind the next frames' compute, at most :func:`in_flight` frames queued; a
    write's error is raised here. Returns the number of empty frames. Only written frames are
    marked done, in order, also when the run stops early (the writes in flight are waited for)."""
    st, mark_every = store
    empty = 0
    writes: deque = deque()
    written: list[int] = []
    n_writers = writer_threads()
    with progress_bar("reconstructing 3D frames", n, enabled=progress) as advance, \
            ThreadPoolExecutor(max_workers=n_writers, thread_name_prefix="fringe3d-store",
                               initializer=numba.set_num_threads, initargs=(1,)) as writer, \
            _kernel_threads_beside(n_writers):
        try:
            for k, cyc, was_empty in results:
                empty += was_empty
                writes.append((k, writer.submit(_write_frame, k, cyc, st, out / PLY_DIR if ply else None)))
                while len(writes) > in_flight(n_writers):  # bounded memory: the compute waits for the writers
                    written.append(_finish(writes.popleft()))
                if st is not None and len(written) >= mark_every:
                    st.mark_done(written)
                    written.clear()
                advance()
            while writes:
                written.append(_finish(writes.popleft()))
        finally:
            getattr(results, "close", lambda: None)()  # the executor's readers and workers stop now
            _drain(writes, written)
            if st is not None:
                st.mark_done(written)
    return empty


#: 3D frames computed and queued per writer thread at most (and one more)
IN_FLIGHT = 2


def writer_threads() -> int:
    """Store writer threads of a sequence: one below :data:`~fringe3d.reconstruct.executors.
    FINISH_ON_WRITERS_FROM` numba threads (the compute makes each frame but its sigma_z and
    compression), else half the numba threads and at least two: what is left to them after the
    fused kernel (quality map, sigma_z, compression, writes) costs about three times the kernel.
    Each writer runs its kernels on one numba thread, the compute keeps the rest, at least one
    (:func:`_kernel_threads_beside`)."""
    n = numba.get_num_threads()
    return 1 if n < FINISH_ON_WRITERS_FROM else max(2, n // 2)


def in_flight(writers: int) -> int:
    """3D frames computed and not yet written at most, with ``writers`` writer threads (bounded
    memory: about 21 MB a 1280 x 1024 frame of the fused path before its quality map)."""
    return IN_FLIGHT * writers


def _write_frame(k: int, cycle: Cycle, st: PointMapStore | None, ply_dir: Path | None) -> None:
    """3D frame ``k``'s store chunks (not marked done) and PLY file, where asked for (on the writer
    thread, whose kernels run on one numba thread); first its sigma_z where the executor left it
    for later (:func:`~fringe3d.reconstruct.frame.with_sigma`)."""
    cycle = with_sigma(cycle)
    if st is not None:
        st.write_frame(k, **store_arrays(cycle, st))
    if ply_dir is not None:
        write_ply_frame(ply_dir, k, cycle)


@contextlib.contextmanager
def _kernel_threads_beside(writers: int):
    """While ``writers`` writer threads run beside the kernels, the numba kernels of this thread
    use that many threads fewer (at least one): every parallel kernel waits for its slowest
    thread, and a thread sharing its core with the writer's compression made each kernel up to
    twice as slow (``benchmarks/bench_sequence.py`` on 2 cores)."""
    n = numba.get_num_threads()
    if writers and n > 1:
        numba.set_num_threads(max(1, n - writers))
    try:
        yield
    finally:
        numba.set_num_threads(n)


def _finish(pending: tuple) -> int:
    """The frame index of a ``(k, future)`` store write, once the write has finished (it raises if
    the write did)."""
    k, fut = pending
    fut.result()
    return k


def _drain(writes: deque, written: list[int]) -> None:
    """Wait for the store writes still in flight; append to ``written`` those that succeeded."""
    while writes:
        k, fut = writes.popleft()
        if fut.exception() is None:
            written.append(k)
