"""Greyscale PNG files (8 or 16 bits, not interlaced) decoded straight into an array.

A capture's PNG frames are such files, and decoding them is most of what reading a capture costs:
OpenCV (libpng) takes about 13 ms of CPU for a 1280 x 1024 8-bit frame. This path takes about
7 (8.5 in a capture's reader, whose stacks are new memory): CPython's ``zlib`` inflates the
image data (about 6 ms; the GIL released, into a buffer of the exact size) and a numba kernel
(``nogil``, about 1.3 ms) undoes the PNG row filters straight into the caller's array (a
capture's frame stack: no intermediate image, no copy). Its result equals OpenCV's
``IMREAD_UNCHANGED`` (uint8, or native-endian uint16), which stays the reader of every other
file: :func:`decode_grey_png` returns None for anything else (colour, palette, interlace, fewer
than 8 bits, transparency or any chunk not in :data:`PLAIN_CHUNKS`, a CRC that does not match,
image data of the wrong length, an unknown filter), and the caller decodes it with OpenCV as
before, so that file's result or error is OpenCV's.
"""
from __future__ import annotations

import struct
import sys
import zlib

import numba
import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: ancillary chunks that do not change OpenCV's IMREAD_UNCHANGED pixels (text, time, pixel size)
PLAIN_CHUNKS = frozenset({b"tEXt", b"zTXt", b"iTXt", b"tIME", b"pHYs"})
_CHUNK = struct.Struct(">I4s")
_IHDR = struct.Struct(">IIBBBBB")


def grey_png_header(data) -> tuple[int, int, np.dtype] | None:
    """``(height, width, dtype)`` of an 8- or 16-bit greyscale, non-interlaced PNG held in
    ``data`` (bytes-like), read from its IHDR chunk alone; None for any other file."""
    if len(data) < 33 or bytes(data[:8]) != SIGNATURE:
        return None
    length, kind = _CHUNK.unpack_from(data, 8)
    if length != 13 or kind != b"IHDR":
        return None
    width, height, depth, colour, compression, filtering, interlace = _IHDR.unpack_from(data, 16)
    if colour != 0 or depth not in (8, 16) or compression or filtering or interlace or not width or not height:
        return None
    return height, width, np.dtype(np.uint8 if depth == 8 else np.uint16)


def _image_data(data) -> bytes | None:
    """The concatenated IDAT payload of a PNG whose chunks are all IHDR, IDAT (consecutive),
    IEND and :data:`PLAIN_CHUNKS`, each with a matching CRC; None otherwise."""
    view = memoryview(data)
    pos, parts, ended, after_idat = 8, [], False, False
    while pos + 12 <= len(view):
        length, kind = _CHUNK.unpack_from(view, pos)
        end = pos + 12 + length
        if end > len(view):
            return None
        (crc,) = struct.unpack_from(">I", view, end - 4)
        if zlib.crc32(view[pos + 4:end - 4]) != crc:
            return None
        if kind == b"IDAT":
            if after_idat:
                return None
            parts.append(view[pos + 8:end - 4])
        elif parts:
            after_idat = True
        if kind == b"IEND":
            ended = True
            break
        if kind != b"IDAT" and kind != b"IHDR" and kind not in PLAIN_CHUNKS:
            return None
        pos = end
    return b"".join(parts) if ended and parts else None


def decode_grey_png(data, out: np.ndarray | None = None) -> np.ndarray | None:
    """The image of an 8- or 16-bit greyscale, non-interlaced PNG held in ``data`` (bytes-like):
    an ``(H, W)`` uint8 or native-endian uint16 array equal to OpenCV's ``IMREAD_UNCHANGED``.

    Parameters
    ----------
    data : bytes-like
        The whole file.
    out : ndarray, optional
        A C-contiguous array of the image's shape and dtype to decode into (else a new one).

    Returns
    -------
    ndarray or None
        ``out`` (or the new array); None for a file this path does not decode (see the module),
        or when ``out`` does not fit it: decode it with OpenCV (``out`` may then hold part of
        the image).
    """
    head = grey_png_header(data)
    if head is None:
        return None
    height, width, dtype = head
    if out is None:
        out = np.empty((height, width), dtype)
    elif out.shape != (height, width) or out.dtype != dtype or not out.flags.c_contiguous:
        return None
    compressed = _image_data(data)
    if compressed is None:
        return None
    row = width * dtype.itemsize
    size = height * (row + 1)
    try:
        raw = zlib.decompress(compressed, zlib.MAX_WBITS, size)
    except zlib.error:
        return None
    if len(raw) != size:
        return None
    rows = out.view(np.uint8).reshape(height, row)
    if _unfilter(np.frombuffer(raw, np.uint8), rows, dtype.itemsize) >= 0:
        return None
    if dtype.itemsize == 2 and sys.byteorder == "little":
        _swap_pairs(rows)
    return out


@numba.njit(cache=True, nogil=True)
def _unfilter(raw, rows, bpp):  # pragma: no cover - compiled
    """Undo the PNG filters of ``raw`` (each row: its filter byte, then its bytes) into ``rows``
    (H, row bytes); ``bpp`` bytes per pixel. Returns -1, or the first row with an unknown filter.
    At one byte a pixel, the left neighbour of Sub, Average and Paeth rides in a register (the
    byte-by-byte chain of those filters is the loop's latency: half the time of reading it back)."""
    height, width = rows.shape
    stride = width + 1
    zero = np.zeros(width, np.uint8)
    for y in range(height):
        f = raw[y * stride]
        line = raw[y * stride + 1:(y + 1) * stride]
        out = rows[y]
        up = rows[y - 1] if y > 0 else zero
        lead = min(bpp, width)
        if f == 0:
            out[:] = line
        elif f == 2:
            for x in range(width):
                out[x] = line[x] + up[x]
        elif bpp == 1 and f == 1:
            left = np.uint8(0)
            for x in range(width):
                left = np.uint8(line[x] + left)
                out[x] = left
        elif bpp == 1 and f == 3:
            left = np.uint32(0)
            for x in range(width):
                left = np.uint32(np.uint8(np.uint32(line[x]) + ((left + np.uint32(up[x])) >> 1)))
                out[x] = np.uint8(left)
        elif bpp == 1 and f == 4:
            left = np.int32(0)
            upleft = np.int32(0)
            for x in range(width):
                b = np.int32(up[x])
                pa, pb, pc = abs(b - upleft), abs(left - upleft), abs(left + b - 2 * upleft)
                pred = left if pa <= pb and pa <= pc else (b if pb <= pc else upleft)
                left = np.int32(np.uint8(np.int32(line[x]) + pred))
                out[x] = np.uint8(left)
                upleft = b
        elif f == 1:
            out[:lead] = line[:lead]
            for x in range(bpp, width):
                out[x] = line[x] + out[x - bpp]
        elif f == 3:
            for x in range(lead):
                out[x] = line[x] + (up[x] >> 1)
            for x in range(bpp, width):
                out[x] = line[x] + np.uint8((np.uint32(out[x - bpp]) + np.uint32(up[x])) >> 1)
        elif f == 4:
            for x in range(lead):
                out[x] = line[x] + up[x]
            for x in range(bpp, width):
                a, b, c = np.int32(out[x - bpp]), np.int32(up[x]), np.int32(up[x - bpp])
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                out[x] = line[x] + np.uint8(pred)
        else:
            return y
    return -1


@numba.njit(cache=True, nogil=True)
def _swap_pairs(rows):  # pragma: no cover - compiled
    """Swap the two bytes of every 16-bit sample of ``rows`` (H, 2 W) in place (PNG stores
    them big-endian)."""
    height, width = rows.shape
    for y in range(height):
        for x in range(0, width, 2):
            t = rows[y, x]
            rows[y, x] = rows[y, x + 1]
            rows[y, x + 1] = t
