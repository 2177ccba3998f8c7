"""A capture folder's frames as an ``(F, H, W)`` array-like read on demand (:func:`capture_frames`)."""
from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from fringe3d.io.capture import list_frame_files, open_frames
from fringe3d.io.images import read_image


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
        """The frames, read on demand (:func:`capture_frames`)."""
        return capture_frames(self.path, self.limit)


def capture_frames(folder, limit: int | None = None):
    """The frames of the capture ``folder``, read on demand: its referenced camera file
    (:func:`fringe3d.io.capture.open_frames`), else its ``frames/`` files (:class:`CaptureFrames`).
    ``limit`` keeps only the first frames."""
    frames = open_frames(folder, limit=limit)
    return frames if frames is not None else CaptureFrames(folder, limit=limit)


class CaptureFrames:
    """The frames of a capture folder, read on demand: ``frames[idx]`` reads only those files.

    Stands in for the ``(F, H, W)`` array of :func:`fringe3d.reconstruct.sequence.reconstruct_sequence` so a capture of
    thousands of frames never has to fit in memory. ``limit`` keeps only the first frames.
    """

    def __init__(self, folder, limit: int | None = None):
        self._read = read_image
        self.files = list_frame_files(folder)[:limit]
        if not self.files:
            raise ValueError(f"capture folder {folder} holds no frames")
        first = read_image(self.files[0])
        self.shape = (len(self.files),) + first.shape
        self.dtype = first.dtype
        self.ndim = 3

    def __len__(self) -> int:
        return self.shape[0]

    def _one(self, k: int, out: np.ndarray | None = None) -> np.ndarray:
        """Frame ``k``, decoded into ``out`` (a frame of the stack being read) when given."""
        img = self._read(self.files[k], out=out)
        if img.shape != self.shape[1:] or img.dtype != self.dtype:
            raise ValueError(f"{self.files[k]} is {img.dtype} {img.shape} but {self.files[0].name} is "
                             f"{self.dtype} {self.shape[1:]}; all frames of a capture must match")
        if out is not None and img is not out:
            out[...] = img
        return img

    def __getitem__(self, idx):
        if np.ndim(idx) == 0:
            return self._one(int(idx))
        ks = [int(k) for k in np.asarray(idx).ravel()]
        stack = np.empty((len(ks),) + self.shape[1:], self.dtype)
        if len(ks) < 2:
            for k, out in zip(ks, stack):
                self._one(k, out)
        else:  # PNG/TIFF decoders release the GIL: a cycle's frames decode in parallel, each into its place
            for _ in _read_pool().map(self._one, ks, stack):
                pass
        return stack
