"""Camera files as frame sources, read lazily: Photron MRAW, Phantom CINE, multi-page TIFF, zarr stores.

A capture folder may reference a camera file instead of holding ``frames/``: its
``capture.json`` then has a ``source`` object (see :func:`parse_source` and the user guide)::

    {"kind": "mraw", "path": "../run1.cihx", "first_frame": 12, "frame_count": 3000}

Every reader is a :class:`FrameSource`: it knows the file's frame count, frame size, dtype,
bit depth and frame rate from the header alone, and ``read(start, stop)`` returns only the
frames ``[start, stop)`` — memory is bounded by the requested range (MRAW 8/16-bit and zarr
by a memory map / chunk reads, 12-bit packed MRAW by unpacking only those bytes, TIFF page by
page, CINE image by image). :class:`FrameRange` cuts the frames a capture uses out of a source
and indexes like an ``(F, H, W)`` array (``frames[idx]`` reads only the frames asked for).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
import tifffile

#: Source kinds that ``capture.json``'s ``source.kind`` may name.
SOURCE_KINDS = ("mraw", "cine", "tiff", "zarr")
#: Array name of a zarr frame store.
ZARR_ARRAY = "frames"


@runtime_checkable
class FrameSource(Protocol):
    """What a capture reads frames from.

    Attributes
    ----------
    path : Path
        The file (for MRAW: the ``.cih`` / ``.cihx`` header).
    shape : tuple (F, H, W)
        Frames in the file, rows, columns (pixels).
    dtype : numpy dtype
    bit_depth : int
        Significant bits per pixel (e.g. 12 in 16-bit words).
    frame_rate : float or None
        Recording rate in Hz, when the header has one.
    """

    path: Path
    shape: tuple[int, int, int]
    dtype: np.dtype
    bit_depth: int
    frame_rate: float | None

    def __len__(self) -> int: ...

    def read(self, start: int, stop: int) -> np.ndarray:
        """Frames ``[start, stop)`` as an ``(stop - start, H, W)`` array."""
        ...


def _read_each(src, start: int, stop: int, frame) -> np.ndarray:
    """Frames ``[start, stop)`` of ``src`` (a source read image by image), ``frame(k)`` each,
    into one ``(stop - start, H, W)`` array."""
    _check_range(src, start, stop)
    out = np.empty((stop - start,) + tuple(src.shape[1:]), src.dtype)
    for k in range(start, stop):
        out[k - start] = frame(k)
    return out


def _check_range(src: FrameSource, start: int, stop: int) -> None:
    if not 0 <= start <= stop <= len(src):
        raise ValueError(f"{src.path}: frames [{start}, {stop}) are outside the file's {len(src)} frames")


def _native_bits(dtype: np.dtype) -> int:
    return 8 * np.dtype(dtype).itemsize


# ----------------------------------------------------------------------------- MRAW
def mraw_header(path: Path) -> Path:
    """The ``.cih`` / ``.cihx`` header of an MRAW recording given either file."""
    if path.suffix.lower() in (".cih", ".cihx"):
        return path
    for ext in (".cihx", ".cih"):
        if path.with_suffix(ext).is_file():
            return path.with_suffix(ext)
    raise FileNotFoundError(f"{path}: no .cih or .cihx header next to the MRAW file "
                            f"(expected {path.with_suffix('.cih')})")


class MrawSource:
    """A Photron MRAW recording (header read by ``pyMRAW.get_cih``).

    8- and 16-bit files are memory-mapped (as ``pyMRAW.load_video`` does); 12-bit packed files
    are unpacked range by range (pyMRAW would unpack the whole file). Values stored in the
    high bits (``EffectiveBit Side: Higher``) are shifted down to the effective bit depth.
    """

    kind = "mraw"

    def __init__(self, path: str | os.PathLike):
        import pyMRAW  # optional dependency (extra "camfiles"); imports numba kernels

        self.path = mraw_header(Path(path))
        if not self.path.is_file():
            raise FileNotFoundError(f"MRAW header {self.path} does not exist")
        try:
            cih = pyMRAW.get_cih(str(self.path))
        except Exception as e:  # pyMRAW raises bare Exceptions / KeyErrors for broken headers
            raise ValueError(f"{self.path} is not a readable Photron header ({type(e).__name__}: {e})") from None
        self.cih = cih
        self.raw = self.path.with_suffix(".mraw")
        fmt = str(cih.get("File Format", "")).lower()
        if fmt != "mraw":
            raise ValueError(f"{self.path}: File Format is {cih.get('File Format')!r}; expected MRaw")
        self.stored_bits = int(self._field("Color Bit"))
        if self.stored_bits not in (8, 12, 16):
            raise ValueError(f"{self.path}: Color Bit is {self.stored_bits}; expected 8, 12 or 16")
        F, H, W = (int(self._field(k)) for k in ("Total Frame", "Image Height", "Image Width"))
        self.shape = (F, H, W)
        self.dtype = np.dtype(np.uint8 if self.stored_bits == 8 else np.uint16)
        self.bit_depth = int(cih.get("EffectiveBit Depth", self.stored_bits))
        self.high_side = str(cih.get("EffectiveBit Side", "Lower")).lower() == "higher"
        rate = cih.get("Record Rate(fps)")
        self.frame_rate = float(rate) if isinstance(rate, (int, float)) and rate > 0 else None
        self._check_file_size()

    def _field(self, key: str):
        if key not in self.cih:
            raise ValueError(f"{self.path}: the header has no {key!r} field")
        return self.cih[key]

    @property
    def frame_bytes(self) -> int:
        """Bytes per frame in the ``.mraw`` file."""
        return self.shape[1] * self.shape[2] * self.stored_bits // 8

    def _check_file_size(self) -> None:
        if not self.raw.is_file():
            raise FileNotFoundError(f"{self.raw} (the frames of {self.path.name}) does not exist")
        need = self.shape[0] * self.frame_bytes
        have = self.raw.stat().st_size
        if have < need:
            raise ValueError(f"{self.raw} holds {have} bytes but the header {self.path.name} says Total Frame "
                             f"{self.shape[0]} of {self.shape[2]}x{self.shape[1]} at {self.stored_bits} bits "
                             f"({need} bytes expected)")

    def __len__(self) -> int:
        return self.shape[0]

    def read(self, start: int, stop: int) -> np.ndarray:
        _check_range(self, start, stop)
        n, (_, H, W) = stop - start, self.shape
        raw = np.memmap(self.raw, dtype=np.uint8, mode="r", offset=start * self.frame_bytes,
                        shape=(n * self.frame_bytes,)) if n else np.empty(0, np.uint8)
        if self.stored_bits == 12:
            out = _unpack12(np.asarray(raw)).reshape(n, H, W)
        else:
            out = np.array(raw.view(self.dtype).reshape(n, H, W))
        if self.high_side and self.bit_depth < _native_bits(self.dtype) and self.stored_bits != 12:
            out >>= _native_bits(self.dtype) - self.bit_depth
        return out


def _unpack12(raw: np.ndarray) -> np.ndarray:
    """Photron 12-bit packing (two pixels in three bytes, big-endian nibbles) -> uint16."""
    b = raw.reshape(-1, 3).astype(np.uint16)
    out = np.empty(2 * len(b), np.uint16)
    out[0::2] = (b[:, 0] << 4) | (b[:, 1] >> 4)
    out[1::2] = ((b[:, 1] & 0x0F) << 8) | b[:, 2]
    return out


# ----------------------------------------------------------------------------- CINE
class CineSource:
    """A Phantom CINE recording (Vision Research), read image by image through ``pims.Cine``.

    Only uncompressed monochrome files (``Compression`` 0, ``CFA`` 0, 8- or 16-bit pixels) are
    read; a colour or compressed file is refused. ``shape`` is ``(ImageCount, biHeight,
    biWidth)`` (BITMAPINFOHEADER), ``bit_depth`` the SETUP's ``RealBPP`` for 16-bit pixels (else
    8), ``frame_rate`` its ``FrameRate`` (Hz, None when 0) and ``first_image_no`` the header's
    ``FirstImageNo``: the camera's number of file frame 0, counted from the trigger (negative
    before it). ``read(start, stop)`` reads those images only (``pims.Cine.get_frame``).
    """

    kind = "cine"

    def __init__(self, path: str | os.PathLike):
        from pims.cine import Cine  # optional dependency (extra "camfiles")

        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"CINE file {self.path} does not exist")
        with open(self.path, "rb") as f:
            magic = f.read(2)
        if magic != b"CI":
            raise ValueError(f"{self.path} is not a Phantom CINE file (it starts with {magic!r}, not b'CI')")
        try:
            self._cine = Cine(str(self.path))
        except Exception as e:  # pims raises struct.error, TypeError, KeyError ... for broken files
            raise ValueError(f"{self.path} is not a readable Phantom CINE file ({type(e).__name__}: {e})") from None
        c = self._cine
        if c.compression != 0 or c.cfa != 0:
            raise ValueError(f"{self.path}: Compression {c.compression}, CFA {c.cfa}; fringe3d reads uncompressed "
                             "monochrome CINE files only (Compression 0, CFA 0)")
        bits = int(c.bitmapinfo_dict["bi_bit_count"])
        if bits not in (8, 16):
            raise ValueError(f"{self.path}: biBitCount is {bits}; expected 8 or 16 (monochrome)")
        W, H = (int(x) for x in c.frame_shape)
        if W <= 0 or H <= 0:
            raise ValueError(f"{self.path}: biWidth x biHeight is {W}x{H}; expected positive sizes")
        self.shape = (int(len(c)), H, W)
        self.dtype = np.dtype(np.uint8 if bits == 8 else np.uint16)
        real = int(c.setup_fields_dict.get("real_bpp", 0) or 0)
        self.bit_depth = real if bits == 16 and 8 < real <= 16 else bits
        rate = float(c.frame_rate)
        self.frame_rate = rate if rate > 0 else None
        self.first_image_no = int(c.header_dict["first_image_no"])
        self._check_file_size()

    def _check_file_size(self) -> None:
        """The last image (annotation header + pixels) must lie inside the file."""
        if not self.shape[0]:
            raise ValueError(f"{self.path}: the header's ImageCount is 0; expected a recording with frames")
        locations = getattr(self._cine, "image_locations", None)  # pims skips a table at the end of the file
        if not locations:
            raise ValueError(f"{self.path}: the file ends at the image offsets table (offset "
                             f"{self._cine.off_image_offsets}); expected {self.shape[0]} image offsets there")
        need = max(locations) + 8 + self.shape[1] * self.shape[2] * self.dtype.itemsize
        have = self.path.stat().st_size
        if have < need:
            raise ValueError(f"{self.path} holds {have} bytes but its header says ImageCount {self.shape[0]} of "
                             f"{self.shape[2]}x{self.shape[1]} at {8 * self.dtype.itemsize} bits (at least {need} "
                             "bytes expected)")

    def __len__(self) -> int:
        return self.shape[0]

    def read(self, start: int, stop: int) -> np.ndarray:
        return _read_each(self, start, stop, self._cine.get_frame)

    def close(self) -> None:
        self._cine.close()


# ----------------------------------------------------------------------------- TIFF
class TiffSource:
    """A multi-page (or BigTIFF) stack of grey pages, one frame a page, read page by page.

    The file stays open (until ``close()``, the end of a ``with`` block or the reader's deletion)
    so the page offsets are indexed once (8 bytes a page; pages themselves are not cached). Bit depth:
    ``capture.json`` may say 10/12/14 for 16-bit pages; the file's is its sample size.
    """

    kind = "tiff"

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"TIFF stack {self.path} does not exist")
        try:
            self._tif = tifffile.TiffFile(self.path)
            pages = self._tif.pages
            first = pages.first
            n = len(pages)
        except Exception as e:  # tifffile raises many types for corrupt files
            raise ValueError(f"{self.path} is not a readable TIFF ({type(e).__name__}: {e})") from None
        if len(first.shape) != 2:
            raise ValueError(f"{self.path}: pages are {first.shape}, not grey (H, W) images; import with "
                             "`copy_frames=True` to convert colour pages")
        self.dtype = np.dtype(first.dtype)
        if self.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"{self.path}: pages are {self.dtype}; expected 8- or 16-bit integer images")
        self.shape = (n, int(first.shape[0]), int(first.shape[1]))
        self.bit_depth = _native_bits(self.dtype)
        self.frame_rate: float | None = None

    def __len__(self) -> int:
        return self.shape[0]

    def read(self, start: int, stop: int) -> np.ndarray:
        return _read_each(self, start, stop, self._page)

    def _page(self, k: int) -> np.ndarray:
        img = self._tif.pages[k].asarray()
        if img.shape != self.shape[1:] or img.dtype != self.dtype:
            raise ValueError(f"{self.path}: page {k} is {img.dtype} {img.shape} but page 0 is "
                             f"{self.dtype} {self.shape[1:]}; all pages must match")
        return img

    def close(self) -> None:
        self._tif.close()

    def __del__(self) -> None:  # the reader is dropped with its capture: close the file then
        tif = getattr(self, "_tif", None)
        if tif is not None:
            tif.close()

    def __enter__(self) -> TiffSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# ----------------------------------------------------------------------------- zarr
class ZarrSource:
    """A chunked zarr store holding an ``(F, H, W)`` integer array named ``frames``.

    ``bit_depth`` and ``frame_rate`` come from the array's (or the group's) attributes when
    present, else the dtype's 8 / 16 bits and None.
    """

    kind = "zarr"

    def __init__(self, path: str | os.PathLike):
        import zarr  # heavy import, only for zarr sources

        self.path = Path(path)
        if not self.path.exists():
            raise FileNotFoundError(f"zarr store {self.path} does not exist")
        try:
            group = zarr.open_group(str(self.path), mode="r")
            arr = group[ZARR_ARRAY]
        except Exception as e:  # missing array, not a group, unreadable metadata
            raise ValueError(f"{self.path} is not a zarr store with an array named {ZARR_ARRAY!r} "
                             f"({type(e).__name__}: {e})") from None
        if not isinstance(arr, zarr.Array) or len(arr.shape) != 3:
            raise ValueError(f"{self.path}/{ZARR_ARRAY} must be an (F, H, W) array, got shape "
                             f"{getattr(arr, 'shape', None)}")
        self._arr = arr
        F, H, W = (int(s) for s in arr.shape)
        self.shape = (F, H, W)
        self.dtype = np.dtype(arr.dtype)
        if self.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"{self.path}/{ZARR_ARRAY} is {self.dtype}; expected uint8 or uint16 frames")
        attrs: dict = {**dict(group.attrs), **dict(arr.attrs)}
        self.bit_depth = int(attrs.get("bit_depth", _native_bits(self.dtype)))
        rate = attrs.get("frame_rate")
        self.frame_rate = float(rate) if isinstance(rate, (int, float)) and rate > 0 else None

    def __len__(self) -> int:
        return self.shape[0]

    def read(self, start: int, stop: int) -> np.ndarray:
        _check_range(self, start, stop)
        return np.asarray(self._arr[start:stop])


# ----------------------------------------------------------------------------- opening
_READERS: dict[str, type[MrawSource] | type[CineSource] | type[TiffSource] | type[ZarrSource]] = {
    "mraw": MrawSource, "cine": CineSource, "tiff": TiffSource, "zarr": ZarrSource}


def guess_kind(path: str | os.PathLike) -> str | None:
    """Source kind of a camera file by its name, or None: ``.mraw``/``.cih``/``.cihx`` -> mraw,
    ``.cine`` -> cine, ``.tif``/``.tiff`` -> tiff, a folder ending ``.zarr`` or holding zarr
    metadata -> zarr."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".mraw", ".cih", ".cihx"):
        return "mraw"
    if suffix == ".cine":
        return "cine"
    if suffix in (".tif", ".tiff") and p.is_file():
        return "tiff"
    if p.is_dir() and (suffix == ".zarr" or any((p / m).exists() for m in ("zarr.json", ".zgroup", ".zarray"))):
        return "zarr"
    return None


def open_source(kind: str, path: str | os.PathLike) -> FrameSource:
    """The reader of ``kind`` (one of :data:`SOURCE_KINDS`) for ``path``."""
    if kind not in _READERS:
        raise ValueError(f"unknown frame source kind {kind!r}; expected one of {', '.join(SOURCE_KINDS)}")
    return _READERS[kind](path)


class FrameRange:
    """Frames ``[first, first + count)`` of a source, indexed like an ``(F, H, W)`` array.

    ``frames[k]``, ``frames[a:b]`` and ``frames[index_array]`` read only the span they touch
    (one ``source.read`` call from the smallest to the largest index asked for).
    """

    ndim = 3

    def __init__(self, source: FrameSource, first: int = 0, count: int | None = None):
        self.source = source
        self.first = int(first)
        self.count = len(source) - self.first if count is None else int(count)
        if self.first < 0 or self.count < 0 or self.first + self.count > len(source):
            raise ValueError(f"{source.path}: frame range first_frame={self.first}, frame_count={self.count} "
                             f"(frames {self.first}..{self.first + self.count - 1}) is beyond the file's "
                             f"{len(source)} frames (0..{len(source) - 1})")
        self.shape = (self.count,) + tuple(source.shape[1:])
        self.dtype = source.dtype

    def __len__(self) -> int:
        return self.count

    def read(self, start: int, stop: int) -> np.ndarray:
        """Frames ``[start, stop)`` of the range, ``(stop - start, H, W)``."""
        if not 0 <= start <= stop <= self.count:
            raise IndexError(f"frames [{start}, {stop}) are outside the range's {self.count} frames")
        return self.source.read(self.first + start, self.first + stop)

    def __getitem__(self, idx) -> np.ndarray:
        if isinstance(idx, slice):
            start, stop, step = idx.indices(self.count)
            return self.read(start, max(start, stop))[::step] if step > 0 else np.asarray(
                self[np.arange(start, stop, step)])
        ks = np.asarray(idx)
        if ks.dtype.kind not in "iu":
            raise TypeError(f"frames are indexed by integers or slices, got {ks.dtype}")
        ks = np.where(ks < 0, ks + self.count, ks)
        if ks.size and (ks.min() < 0 or ks.max() >= self.count):
            raise IndexError(f"frame index out of range for {self.count} frames")
        if ks.size == 0:
            return np.empty((0,) + self.shape[1:], self.dtype)
        lo, hi = int(ks.min()), int(ks.max()) + 1
        return self.read(lo, hi)[ks - lo]

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self.read(0, self.count)
        return out if dtype is None else out.astype(dtype)

