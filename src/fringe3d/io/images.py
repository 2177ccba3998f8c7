"""Single-image read/write: PNG (uint8/uint16, via OpenCV) and TIFF (any dtype, via tifffile).

Every write is atomic (:mod:`fringe3d.utils.atomic`); every read error names the file.
"""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import tifffile

from fringe3d.utils.atomic import atomic_path, atomic_write_bytes
from fringe3d.utils.provenance import tiff_description

PNG_SUFFIXES = (".png",)
TIFF_SUFFIXES = (".tif", ".tiff")
IMAGE_SUFFIXES = PNG_SUFFIXES + TIFF_SUFFIXES + (".bmp", ".jpg", ".jpeg", ".pgm")


def read_image(path: str | os.PathLike, grey: bool = True, out: np.ndarray | None = None) -> np.ndarray:
    """Read one image as stored (uint8, uint16, or TIFF float) -> (H, W) array.

    Colour images are converted to grey (OpenCV's BT.601 weights) when ``grey``. An image of
    ``out``'s shape and dtype is copied into ``out`` (a frame of a stack being read), which is
    returned; any other image is returned as read, ``out`` unchanged (the caller checks what
    came back).

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ValueError
        The file is not a readable image (the message names it).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"image file {path} does not exist")
    suffix = path.suffix.lower()
    img: np.ndarray | None
    try:
        if suffix in TIFF_SUFFIXES:
            img = tifffile.imread(path)
        else:
            data = np.fromfile(path, dtype=np.uint8)
            img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
    except Exception as e:  # tifffile raises many types for corrupt files
        raise ValueError(f"{path} is not a readable image ({type(e).__name__}: {e})") from None
    if img is None or not isinstance(img, np.ndarray) or img.ndim not in (2, 3) or img.size == 0:
        raise ValueError(f"{path} is not a readable image (expected PNG or TIFF, "
                         f"{'empty file' if path.stat().st_size == 0 else 'could not decode'})")
    if img.ndim == 3:
        if not grey:
            return img
        if img.shape[2] == 4:
            img = img[..., :3]
        if img.shape[2] == 3:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if suffix not in TIFF_SUFFIXES else \
                cv2.cvtColor(np.ascontiguousarray(img), cv2.COLOR_RGB2GRAY)
        elif img.shape[2] == 1:
            img = img[..., 0]
        else:
            raise ValueError(f"{path}: cannot read an image with {img.shape[2]} channels as grey")
    if out is not None and img.shape == out.shape and img.dtype == out.dtype:
        out[...] = img
        return out
    return img


def write_image(path: str | os.PathLike, img: np.ndarray, quantity: str = "", unit: str = "") -> Path:
    """Write ``img`` (H, W) or (H, W, 3) atomically. PNG needs uint8/uint16; TIFF takes any dtype.

    A TIFF carries the JSON description :func:`fringe3d.utils.provenance.tiff_description`
    (``quantity``, ``unit``, fringe3d version, command line); a measurement map must name both.
    Raises ``ValueError`` for a dtype the format cannot hold or an unknown suffix.
    """
    path = Path(path)
    img = np.asarray(img)
    suffix = path.suffix.lower()
    if suffix in TIFF_SUFFIXES:
        write_tiff(path, img, quantity, unit)
        return path
    if suffix in PNG_SUFFIXES:
        if img.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"PNG holds uint8 or uint16 images, got {img.dtype} for {path}; "
                             f"write a .tif for floating-point data")
        ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 1])
        if not ok:
            raise ValueError(f"OpenCV could not encode {path} (shape {img.shape}, dtype {img.dtype})")
        atomic_write_bytes(path, buf.tobytes())
        return path
    raise ValueError(f"unsupported image suffix {path.suffix!r} for {path}; use .png or .tif")


def write_tiff(path: str | os.PathLike, img: np.ndarray, quantity: str, unit: str) -> Path:
    """Write ``img`` as a TIFF atomically with the description naming ``quantity`` and ``unit``
    (:func:`fringe3d.utils.provenance.tiff_description`); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, np.asarray(img), description=tiff_description(quantity, unit), metadata=None)
    return path
