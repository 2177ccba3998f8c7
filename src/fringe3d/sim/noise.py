"""Camera sensor model: blur, shot and read noise, quantisation with saturation.

Intensities are in units of the camera's full scale (1.0 = saturation). Each frame draws its
noise from its own generator, ``default_rng([seed, frame_index])``, so a frame's noise does not
depend on how many frames were rendered before it.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from .settings import RenderSettings


def frame_rng(seed: int, index: int) -> np.random.Generator:
    """The noise generator of frame ``index`` for ``seed`` (deterministic)."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, int(index)])


def sense(image: np.ndarray, settings: RenderSettings, index: int) -> np.ndarray:
    """Turn a noiseless irradiance image (H, W) float into camera output.

    Applies, in order: Gaussian camera blur (``camera_blur`` px), Poisson shot noise
    (``full_well`` electrons at full scale), Gaussian read noise (``read_noise`` full-scale
    sigma), then quantisation to ``bit_depth`` bits with clipping to [0, 2^b - 1]
    (uint8 for 8 bits, uint16 otherwise). ``bit_depth=None`` returns float32 (no clipping).
    """
    img = np.asarray(image, dtype=np.float64)
    if settings.camera_blur > 0:
        img = gaussian_filter(img, settings.camera_blur, mode="nearest")
    rng = frame_rng(settings.seed, index)
    if settings.shot_noise:
        img = rng.poisson(np.clip(img, 0, None) * settings.full_well) / settings.full_well
    if settings.read_noise > 0:
        img = img + rng.normal(0.0, settings.read_noise, img.shape)
    return quantize(img, settings.bit_depth)


def quantize(img: np.ndarray, bit_depth: int | None) -> np.ndarray:
    """Full-scale intensities to ``bit_depth``-bit integers with saturation (or float32)."""
    if bit_depth is None:
        return img.astype(np.float32)
    top = 2**bit_depth - 1
    q = np.clip(np.rint(img * top), 0, top)
    return q.astype(np.uint8 if bit_depth == 8 else np.uint16)


def full_scale(bit_depth: int | None) -> float:
    """Digital value of full scale (1.0 for float output)."""
    return 1.0 if bit_depth is None else float(2**bit_depth - 1)
