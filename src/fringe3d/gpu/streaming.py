"""Batched launches over many pattern cycles, with the upload overlapping the compute.

Host frames ``(C, F, P)`` are cut into chunks of cycles. Each chunk is copied into one of two
pinned (page-locked) host buffers, uploaded asynchronously on its own stream, processed there
and (unless the results stay on the device) downloaded into a pinned buffer on the same stream.
While stream 0 computes chunk ``i``, the host fills the other pinned buffer with chunk ``i + 1``
and stream 1 uploads it: the copies hide behind the kernels (double buffering). Frames already
on the device are processed in one launch.

The pinned and device buffers of the chunks are kept per thread and reused by the next call of
the same shapes (:class:`BufferPool`): a sequence sends a batch of cycles per call, and
page-locking host memory costs far more than copying into it.
"""
from __future__ import annotations

import threading
from typing import Callable, Sequence

import numpy as np

from fringe3d.gpu.runtime import is_device_array

#: Threads per block along the pixels (the grid's y axis runs over the cycles of a chunk).
THREADS = 256
#: Cycles per chunk of a host-to-device stream: 8 cycles of 15 frames at 1280x1024 uint8 are 157 MB.
DEFAULT_CHUNK = 8


def launch_grid(n_pixels: int, n_cycles: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """(blocks, threads) of a 2D launch: x over ``n_pixels`` in blocks of :data:`THREADS`, y over cycles
    (at most 65,535, CUDA's limit of the grid's y dimension)."""
    if n_cycles > 65535:
        raise ValueError(f"{n_cycles} cycles in one launch; at most 65535 (pass host frames, which go up in "
                         "chunks, or split the device stack)")
    return ((n_pixels + THREADS - 1) // THREADS, max(1, n_cycles)), (THREADS, 1)


OutSpec = tuple[tuple[int, ...], type]  # per-cycle shape and dtype of one output


class BufferPool(threading.local):
    """Chunk buffers kept between calls, one pool per thread (two threads never share one):
    :meth:`get` returns the buffer of that role, shape and dtype made last time, or makes it.
    Only the most recent shapes are kept (:attr:`KEEP` buffers), so memory stays bounded."""

    KEEP = 64

    def __init__(self) -> None:
        self.buffers: dict[tuple, object] = {}

    def get(self, cuda, role: str, slot: int, shape: tuple[int, ...], dtype) -> object:
        """The ``(pinned | device)`` buffer ``slot`` of ``role`` for ``shape`` and ``dtype``."""
        key = (role, slot, tuple(shape), np.dtype(dtype).str)
        buf = self.buffers.pop(key, None)
        if buf is None:
            make = cuda.pinned_array if role.startswith("pinned") else cuda.device_array
            buf = make(tuple(shape), dtype)
        self.buffers[key] = buf  # most recently used last
        while len(self.buffers) > self.KEEP:
            self.buffers.pop(next(iter(self.buffers)))
        return buf


_POOL = BufferPool()


def run_batched(cuda, frames, launch: Callable, outputs: Sequence[OutSpec], chunk: int = DEFAULT_CHUNK,
                device_output: bool = False, scratch: Sequence[OutSpec] = ()) -> list:
    """Run ``launch(d_frames, d_outputs, stream)`` over every cycle of ``frames``.

    Parameters
    ----------
    cuda : the ``numba.cuda`` module (from :func:`fringe3d.gpu.runtime.cuda_module`)
    frames : (C, F, P) host array, or a device array (processed in one launch)
    launch : callable
        Launches the kernel(s) for a ``(n, F, P)`` device chunk, writing the ``(n, ...)`` device
        outputs (followed by the ``(n, ...)`` scratch arrays, when any), on ``stream``.
    outputs : per-cycle ``(shape, dtype)`` of each output
    chunk : cycles per upload (host frames)
    device_output : keep the ``(C, ...)`` outputs on the device instead of copying them back
    scratch : per-cycle ``(shape, dtype)`` of device arrays the launch works in (never copied;
        one set per buffer, kept between calls like the chunk buffers)

    Returns
    -------
    list of (C, ...) arrays, host (numpy) or device ones.
    """
    n_cyc = frames.shape[0]
    if is_device_array(frames):
        d_res = [cuda.device_array((n_cyc,) + tuple(s), dt) for s, dt in outputs]
        tmp = [cuda.device_array((n_cyc,) + tuple(s), dt) for s, dt in scratch]
        stream = cuda.stream()
        launch(frames, d_res + tmp, stream)
        stream.synchronize()
        return d_res if device_output else [d.copy_to_host() for d in d_res]
    chunk = max(1, min(int(chunk), n_cyc))
    per = tuple(frames.shape[1:])
    streams = [cuda.stream(), cuda.stream()]
    pin_in: list = [_POOL.get(cuda, "pinned in", b, (chunk,) + per, frames.dtype) for b in range(2)]
    d_in: list = [_POOL.get(cuda, "device in", b, (chunk,) + per, frames.dtype) for b in range(2)]
    if device_output:  # the caller keeps these: never pooled
        full = [cuda.device_array((n_cyc,) + tuple(s), dt) for s, dt in outputs]
    else:
        host = [np.empty((n_cyc,) + tuple(s), dt) for s, dt in outputs]
        d_out: list = [[_POOL.get(cuda, f"device out {o}", b, (chunk,) + tuple(s), dt)
                        for o, (s, dt) in enumerate(outputs)] for b in range(2)]
        pin_out: list = [[_POOL.get(cuda, f"pinned out {o}", b, (chunk,) + tuple(s), dt)
                          for o, (s, dt) in enumerate(outputs)] for b in range(2)]
    d_tmp: list = [[_POOL.get(cuda, f"device scratch {o}", b, (chunk,) + tuple(s), dt)
                    for o, (s, dt) in enumerate(scratch)] for b in range(2)]
    pending: list = [None, None]  # (c0, n) of the chunk whose results wait in pin_out[b]

    def flush(b: int) -> None:
        if pending[b] is not None:
            c0, n = pending[b]
            for h, po in zip(host, pin_out[b]):
                h[c0:c0 + n] = po[:n]
            pending[b] = None

    for i, c0 in enumerate(range(0, n_cyc, chunk)):
        b = i % 2
        n = min(chunk, n_cyc - c0)
        streams[b].synchronize()  # this buffer's previous chunk is uploaded, computed and downloaded
        if not device_output:
            flush(b)
        pin_in[b][:n] = frames[c0:c0 + n]  # overlaps the other stream's upload and kernel
        src = d_in[b][:n]
        src.copy_to_device(pin_in[b][:n], stream=streams[b])
        outs = [d[c0:c0 + n] for d in full] if device_output else [d[:n] for d in d_out[b]]
        launch(src, outs + [d[:n] for d in d_tmp[b]], streams[b])
        if not device_output:
            for d, po in zip(outs, pin_out[b]):
                d.copy_to_host(po[:n], stream=streams[b])
            pending[b] = (c0, n)
    for b in range(2):
        streams[b].synchronize()
        if not device_output:
            flush(b)
    return full if device_output else host
