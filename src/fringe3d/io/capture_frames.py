"""A capture folder's frames as an ``(F, H, W)`` array-like read on demand (:func:`capture_frames`).

A sequence reads a capture's frames from the first on, but only once its reconstructor and
store are set up (about 0.3 s for 1280 x 1024 on one core, ``benchmarks/bench_sequence.py``): a
capture opened for it (:meth:`CaptureFolder.open`) starts decoding its first frames at once
(``read_first``, :func:`frames_read_first`) on the read threads, beside that setup, and hands
them over when they are asked for (each once).
"""
from __future__ import annotations

import functools
import os
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from fringe3d.io.capture import list_frame_files, open_frames
from fringe3d.io.images import read_image


#: the first frames a capture opened for a sequence decodes at once, at most (about 0.3 s of one
#: core for 1280 x 1024 PNG frames) ...
READ_FIRST = 36
#: ... and at most this many bytes of them
READ_FIRST_BYTES = 64 << 20


def frames_read_first(frame_bytes: int) -> int:
    """Frames of ``frame_bytes`` bytes decoded ahead from the opening of a capture
    (:data:`READ_FIRST`, at most :data:`READ_FIRST_BYTES`)."""
    return max(0, min(READ_FIRST, READ_FIRST_BYTES // max(1, frame_bytes)))


def read_threads() -> int:
    """Threads decoding frame files in parallel (:class:`CaptureFrames`): the cores, at most 8."""
    return min(8, os.cpu_count() or 1)


@functools.lru_cache(maxsize=1)
def _read_pool() -> ThreadPoolExecutor:
    """The threads that decode a cycle's frame files in parallel, created on first use."""
    return ThreadPoolExecutor(max_workers=read_threads(), thread_name_prefix="fringe3d-read")


@dataclass(frozen=True)
class CaptureFolder:
    """A capture folder ``path`` and the number of its first frames to use (``limit``, None: all):
    what a process that reopens the capture elsewhere (a Dask worker) needs."""

    path: str
    limit: int | None = None

    def open(self):
        """The frames, read on demand (:func:`capture_frames`), for a sequence: frame files'
        first frames decoded at once (:func:`frames_read_first`; where the frames are then read
        elsewhere, e.g. by Dask workers, they are decoded for nothing and kept until the frames
        are dropped: at most :data:`READ_FIRST_BYTES`)."""
        return capture_frames(self.path, self.limit, read_first=True)


def capture_frames(folder, limit: int | None = None, read_first: bool = False):
    """The frames of the capture ``folder``, read on demand: its referenced camera file
    (:func:`fringe3d.io.capture.open_frames`), else its ``frames/`` files (:class:`CaptureFrames`;
    with ``read_first``, its first frames decoded at once, :func:`frames_read_first`).
    ``limit`` keeps only the first frames."""
    frames = open_frames(folder, limit=limit)
    if frames is not None:
        return frames
    return CaptureFrames(folder, limit=limit, read_first=-1 if read_first else 0)


class CaptureFrames:
    """The frames of a capture folder, read on demand: ``frames[idx]`` reads only those files.

    Stands in for the ``(F, H, W)`` array of :func:`fringe3d.reconstruct.sequence.reconstruct_sequence` so a capture of
    thousands of frames never has to fit in memory. ``limit`` keeps only the first frames;
    ``read_first`` of them (-1: :func:`frames_read_first`) are decoded at once on the read
    threads and handed over when asked for, each once (the ones not started are dropped when a
    read asks for frames far past them: a resumed sequence).
    """

    def __init__(self, folder, limit: int | None = None, read_first: int = 0):
        self._read = read_image
        self.files = list_frame_files(folder)[:limit]
        if not self.files:
            raise ValueError(f"capture folder {folder} holds no frames")
        first = read_image(self.files[0])
        self.shape = (len(self.files),) + first.shape
        self.dtype = first.dtype
        self.ndim = 3
        if read_first < 0:
            read_first = frames_read_first(first.nbytes)
        read_first = min(read_first, len(self.files))
        self._first: dict[int, Future] = {}
        if read_first:
            done: Future = Future()
            done.set_result(first)
            self._first = {0: done, **{k: _read_pool().submit(self._one, k) for k in range(1, read_first)}}
        self._first_end = read_first

    def __len__(self) -> int:
        return self.shape[0]

    def _one(self, k: int, out: np.ndarray | None = None) -> np.ndarray:
        """Frame ``k``, copied into ``out`` (a frame of the stack being read) when given."""
        img = self._read(self.files[k], out=out)
        if img.shape != self.shape[1:] or img.dtype != self.dtype:
            raise ValueError(f"{self.files[k]} is {img.dtype} {img.shape} but {self.files[0].name} is "
                             f"{self.dtype} {self.shape[1:]}; all frames of a capture must match")
        if out is not None and img is not out:
            out[...] = img
        return img

    def _taken_first(self, k: int, out: np.ndarray | None = None) -> np.ndarray:
        """Frame ``k``: the one decoded at the opening (taken: handed over once) if there is one
        (copied into ``out`` when given), else decoded now."""
        ahead = self._first.pop(k, None)
        try:
            img = ahead.result() if ahead is not None else None
        except CancelledError:  # dropped (_drop_first) after it was taken
            img = None
        if img is None:
            return self._one(k, out)
        if out is None:
            return img
        out[...] = img
        return out

    def _drop_first(self, ks: list[int]) -> None:
        """Cancel the opening's reads not started when ``ks`` lies a whole read-first span past them."""
        if self._first and min(ks) >= 2 * self._first_end:
            for fut in list(self._first.values()):
                fut.cancel()
            self._first.clear()

    def __getitem__(self, idx):
        if np.ndim(idx) == 0:
            k = int(idx)
            self._drop_first([k])
            return self._taken_first(k)
        ks = [int(k) for k in np.asarray(idx).ravel()]
        stack = np.empty((len(ks),) + self.shape[1:], self.dtype)
        if ks:
            self._drop_first(ks)
        if len(ks) < 2:
            for k, out in zip(ks, stack):
                self._taken_first(k, out)
        else:  # PNG/TIFF decoders release the GIL: a cycle's frames decode in parallel, each into its place
            for _ in _read_pool().map(self._taken_first, ks, stack):
                pass
        return stack
