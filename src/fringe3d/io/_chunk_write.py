"""Whole-chunk writes of a local zarr v3 array without zarr's per-call machinery (private; see
:class:`fringe3d.io.store.PointMapStore`).

``array[k] = frame`` on a zarr 3 array goes through its asyncio event loop thread, the batched
codec pipeline and a thread hop per codec; for one 1280 x 1024 frame that cost 8 ms on a
uint8 quality map whose compression takes 0.2 ms (``benchmarks/bench_sequence.py``'s machine).
A point store writes whole chunks of one frame, so the chunk bytes can be made and written
directly: the array's own codecs applied in order (``bytes`` little-endian, then its Blosc
codec with the same parameters through numcodecs, as zarr's ``BloscCodec`` does) and the file
put at the array's chunk key with an atomic rename, as zarr's ``LocalStore`` does. The bytes
on disk are zarr's own (``tests/test_store_chunk_write.py`` compares them), so every zarr reader
(``xarray.open_zarr`` included) sees the same store.

:func:`chunk_writer` returns None for any array it cannot write this way (another store, codec,
chunking or byte order); the caller then uses ``array[k] = frame``.
"""
from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import Callable

import numpy as np

#: ``writer(k, frame)``: encode the (tail) frame ``k`` and write it as its chunk
ChunkWriter = Callable[[int, np.ndarray], None]


def chunk_writer(array) -> ChunkWriter | None:
    """A function writing frame ``k`` (the array's shape without its first axis) as chunk ``k``
    of the zarr v3 ``array`` (chunks ``(1,) + shape[1:]``, on a local store, codecs ``bytes``
    [+ ``blosc``]); None when the array is not of that kind."""
    try:
        from zarr.codecs import BloscCodec, BytesCodec
        from zarr.storage import LocalStore
    except ImportError:  # zarr 2: no v3 codecs
        return None
    md = getattr(array, "metadata", None)
    store = getattr(getattr(array, "store_path", None), "store", None)
    if md is None or getattr(md, "zarr_format", None) != 3 or not isinstance(store, LocalStore):
        return None
    shape = tuple(array.shape)
    if tuple(md.chunk_grid.chunk_shape) != (1,) + shape[1:]:
        return None
    codecs = tuple(md.codecs)
    if not codecs or not isinstance(codecs[0], BytesCodec) or len(codecs) > 2:
        return None
    dtype = np.dtype(array.dtype)
    if dtype.itemsize > 1 and (codecs[0].endian is None or codecs[0].endian.value != "little"):
        return None
    encode: Callable[[np.ndarray], bytes | memoryview]
    if len(codecs) == 2:
        if not isinstance(codecs[1], BloscCodec):
            return None
        from numcodecs import Blosc
        b = codecs[1]
        shuffle = {"noshuffle": Blosc.NOSHUFFLE, "shuffle": Blosc.SHUFFLE, "bitshuffle": Blosc.BITSHUFFLE}
        blosc = Blosc(cname=b.cname.value, clevel=b.clevel, shuffle=shuffle[b.shuffle.value], blocksize=b.blocksize,
                      typesize=b.typesize)

        def encode(raw: np.ndarray) -> bytes | memoryview:
            return blosc.encode(raw)
    else:
        def encode(raw: np.ndarray) -> bytes | memoryview:
            return raw.data  # the raw bytes, no copy
    root = Path(store.root) / array.store_path.path
    le = dtype.newbyteorder("<")
    tail = shape[1:]
    made: set[Path] = set()

    def write(k: int, frame: np.ndarray) -> None:
        v = np.ascontiguousarray(frame, le)
        if v.shape != tail:
            raise ValueError(f"chunk {k} of shape {v.shape}, expected {tail}")
        path = root / md.chunk_key_encoding.encode_chunk_key((int(k),) + (0,) * len(tail))
        data = encode(v.reshape(-1).view(np.uint8))
        if path.parent not in made:  # one mkdir per folder, not per chunk
            path.parent.mkdir(parents=True, exist_ok=True)
            made.add(path.parent)
        tmp = path.with_suffix(f".{uuid.uuid4().hex}.partial")
        try:
            with open(tmp, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise

    return write
