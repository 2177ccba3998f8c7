"""Colour of a capture recorded by a colour camera, kept beside the grey texture.

Decoding works on grey frames (:func:`fringe3d.io.images.read_image`, BT.601 luma). When the
frame files are RGB, the colour is kept as a per-pixel **chroma**: the cycle's mean RGB divided
by its mean luma (``0.299 R + 0.587 G + 0.114 B``), so that

    texture_rgb = clip(texture * chroma, 0, 1)        (H, W, 3), fraction of full scale

has the grey texture (:mod:`fringe3d.decode.texture`) as its luma and the camera's colour; under
a white projector the ratio of the channels at a pixel is the same in every frame, so the mean
over the cycle gives it without noise from the fringes' dark phases.
"""
from __future__ import annotations

import os

import cv2
import numpy as np

from .capture import list_frame_files
from .images import TIFF_SUFFIXES, read_image

#: BT.601 luma weights (R, G, B): what colour frames are converted to grey with.
LUMA = np.array([0.299, 0.587, 0.114], np.float32)


def capture_chroma(folder: str | os.PathLike, n_frames: int) -> np.ndarray | None:
    """Chroma ``(H, W, 3)`` float32 of the first ``n_frames`` frame files of a capture folder, or
    None when they are grey (or the folder references a camera file instead of frames)."""
    try:
        files = list_frame_files(folder)[:n_frames]
    except FileNotFoundError:  # frames in a camera file: grey
        return None
    if not files:
        return None
    total: np.ndarray | None = None
    for path in files:
        img = read_image(path, grey=False)
        if img.ndim != 3 or img.shape[2] < 3:
            return None
        rgb = img[..., :3] if path.suffix.lower() in TIFF_SUFFIXES else cv2.cvtColor(img[..., :3], cv2.COLOR_BGR2RGB)
        total = rgb.astype(np.float64) if total is None else total + rgb
    assert total is not None
    luma = total @ LUMA.astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        chroma = np.where(luma[..., None] > 0, total / luma[..., None], 1.0)
    return chroma.astype(np.float32)


def rgb_texture(texture: np.ndarray, chroma: np.ndarray) -> np.ndarray:
    """``texture (H, W)`` (fraction of full scale) times ``chroma (H, W, 3)``, clipped to [0, 1]."""
    return np.clip(np.asarray(texture, np.float32)[..., None] * chroma, 0, 1).astype(np.float32)
