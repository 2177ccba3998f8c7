"""NumPy ``.npy`` files written and read one frame at a time, so a long sequence never sits in memory.

:class:`NpyFrameWriter` writes the header of an ``(F, ...)`` array first (its shape is known up
front) and then appends frame ``0, 1, …, F - 1`` as raw bytes; the file is a plain ``.npy``
(``np.load(path, mmap_mode="r")`` opens it). It is written under a temporary name and renamed
into place only when all F frames are in (:func:`fringe3d.utils.atomic.atomic_path`).
:func:`read_npy_frame` reads one frame back by seeking, without mapping the file (mapped pages
would stay resident). :func:`pack_npz` copies finished ``.npy`` files into an ``.npz`` in bounded
chunks (the layout ``np.savez_compressed`` writes).
"""
from __future__ import annotations

import os
import shutil
import zipfile
from contextlib import ExitStack
from pathlib import Path
from typing import BinaryIO

import numpy as np

from fringe3d.utils.atomic import atomic_path

__all__ = ["NpyFrameWriter", "read_npy_frame", "iter_npy_frames", "pack_npz"]

#: Bytes copied per read when packing a ``.npy`` into a zip member.
COPY_CHUNK = 1 << 22


class NpyFrameWriter:
    """Write an ``(frames, *frame_shape)`` array of ``dtype`` to ``path``, frame by frame.

    Parameters
    ----------
    path : path-like
        The ``.npy`` file (written atomically: it appears only once :meth:`close` has seen every frame).
    frames : int
        Leading length F.
    frame_shape : tuple of int
        Shape of one frame.
    dtype : numpy dtype

    Use as a context manager; :meth:`append` one frame (anything that casts to ``frame_shape`` /
    ``dtype``) at a time. Leaving the block with fewer than F frames (an exception) removes the
    temporary file.
    """

    def __init__(self, path: str | os.PathLike, frames: int, frame_shape: tuple, dtype):
        self.path = Path(path)
        self.frames = int(frames)
        self.frame_shape = tuple(int(s) for s in frame_shape)
        self.dtype = np.dtype(dtype)
        self.count = 0
        self._stack = ExitStack()
        self._fh: BinaryIO | None = None

    def __enter__(self) -> "NpyFrameWriter":
        tmp = self._stack.enter_context(atomic_path(self.path))
        fh = self._fh = self._stack.enter_context(open(tmp, "wb"))
        header = {"descr": np.lib.format.dtype_to_descr(self.dtype), "fortran_order": False,
                  "shape": (self.frames,) + self.frame_shape}
        try:
            np.lib.format.write_array_header_1_0(fh, header)   # what np.save writes when it fits
        except ValueError:
            np.lib.format.write_array_header_2_0(fh, header)
        return self

    def append(self, frame) -> None:
        """Write the next frame (cast to ``dtype``; ValueError when its shape differs)."""
        a = np.ascontiguousarray(frame, dtype=self.dtype)
        if a.shape != self.frame_shape:
            raise ValueError(f"frame {self.count} for {self.path.name} has shape {a.shape}; "
                             f"expected {self.frame_shape}")
        if self.count >= self.frames:
            raise ValueError(f"{self.path.name} holds {self.frames} frames; got one more")
        assert self._fh is not None, "NpyFrameWriter used outside its with block"
        self._fh.write(a.tobytes())
        self.count += 1

    def __exit__(self, kind, value, tb) -> bool:
        if kind is None and self.count != self.frames:
            err = ValueError(f"{self.path.name}: {self.count} of {self.frames} frames written")
            self._stack.__exit__(ValueError, err, None)   # removes the temporary file
            raise err
        return bool(self._stack.__exit__(kind, value, tb))   # renames it into place on success


def _header(fh) -> tuple[tuple, np.dtype, int]:
    version = np.lib.format.read_magic(fh)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, fortran, dtype = read(fh)
    if fortran:
        raise ValueError(f"{fh.name}: Fortran-ordered arrays cannot be read frame by frame")
    return tuple(shape), np.dtype(dtype), fh.tell()


def read_npy_frame(path: str | os.PathLike, k: int) -> np.ndarray:
    """Frame ``k`` of the ``.npy`` at ``path`` (shape ``shape[1:]``), read by seeking."""
    with open(path, "rb") as fh:
        shape, dtype, offset = _header(fh)
        if not 0 <= k < shape[0]:
            raise IndexError(f"frame {k} outside {Path(path).name}'s 0..{shape[0] - 1}")
        n = int(np.prod(shape[1:], dtype=np.int64)) * dtype.itemsize
        fh.seek(offset + k * n)
        return np.frombuffer(fh.read(n), dtype=dtype).reshape(shape[1:]).copy()


def iter_npy_frames(path: str | os.PathLike):
    """Frames ``0, 1, …`` of the ``.npy`` at ``path``, read one at a time from an open file."""
    with open(path, "rb") as fh:
        shape, dtype, _ = _header(fh)
        n = int(np.prod(shape[1:], dtype=np.int64)) * dtype.itemsize
        for _k in range(shape[0]):
            yield np.frombuffer(fh.read(n), dtype=dtype).reshape(shape[1:])


def pack_npz(path: str | os.PathLike, members: dict[str, str | os.PathLike], level: int = 1) -> None:
    """Write ``path`` (``.npz``, deflate ``level``, atomically) whose member ``NAME.npy`` is a byte copy
    of the ``.npy`` file ``members[NAME]``; memory is bounded by :data:`COPY_CHUNK`."""
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED,
                                                   compresslevel=level) as zf:
        for name, src in members.items():
            with open(src, "rb") as fi, zf.open(f"{name}.npy", "w", force_zip64=True) as fo:
                shutil.copyfileobj(fi, fo, COPY_CHUNK)
