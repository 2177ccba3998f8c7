"""Camera sensor model: blur, shot and read noise, quantisation with saturation.

Intensities are in units of the camera's full scale (1.0 = saturation). Each frame draws its
noise from its own generator, ``default_rng([seed, frame_index])``, so a frame's noise does not
depend on how many frames were rendered before it.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .settings import RenderSettings


def frame_rng(seed: int, index: int) -> np.random.Generator:
    """The noise generator of frame ``index`` for ``seed`` (deterministic)."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, int(index)])


def blur_margin(settings: RenderSettings) -> int:
    """Pixels the renderer adds beyond each sensor border so that the camera blur sees what a real
    lens brings onto the border pixels: the blur kernel's radius, ``round(4 sigma)`` (scipy's
    ``truncate=4``), 0 without blur."""
    return int(4.0 * settings.camera_blur + 0.5) if settings.camera_blur > 0 else 0


def sense(image: np.ndarray, settings: RenderSettings, index: int, margin: int = 0) -> np.ndarray:
    """Turn a noiseless irradiance image (H, W) float into camera output.

    ``image`` may extend ``margin`` pixels beyond the sensor on every side ((H + 2 margin,
    W + 2 margin), :func:`blur_margin`): the blur then takes the scene beyond the border as the
    lens does, and the result is cropped to the sensor, exact for ``margin >= blur_margin``. A
    ``margin`` 0 image is padded with its edge values (``mode="nearest"``), which biases the
    outermost ~2 sigma of pixels wherever the image has a gradient there.

    Applies, in order: Gaussian camera blur (``camera_blur`` px), shot noise
    (:func:`shot_noise`, ``full_well`` electrons at full scale), Gaussian read noise (``read_noise`` full-scale
    sigma), then quantisation to ``bit_depth`` bits with clipping to [0, 2^b - 1]
    (uint8 for 8 bits, uint16 otherwise). ``bit_depth=None`` returns float32 (no clipping).
    """
    img = np.asarray(image, dtype=np.float64)
    if settings.camera_blur > 0:
        from scipy.ndimage import gaussian_filter  # heavy (0.25 s with scipy.special): a blurred camera only

        img = gaussian_filter(img, settings.camera_blur, mode="nearest")
    if margin:
        img = img[margin:img.shape[0] - margin, margin:img.shape[1] - margin]
    rng = frame_rng(settings.seed, index)
    if settings.noise_model == "emva":
        return sense_emva(img, settings, rng)
    if settings.shot_noise and settings.bit_depth is not None:
        return _shot_read_quantize(img, settings, rng)
    if settings.shot_noise:
        img = shot_noise(img, settings.full_well, rng)
    if settings.read_noise > 0:
        img = img + settings.read_noise * rng.standard_normal(img.shape, dtype=np.float32)
    return quantize(img, settings.bit_depth)


def sense_emva(img: np.ndarray, settings: RenderSettings, rng: np.random.Generator) -> np.ndarray:
    """The EMVA 1288 linear camera model on full-scale irradiances ``img`` (H, W).

    Mean electrons ``mu_e = I * full_well``; Poisson shot noise (:func:`shot_noise`); the well clips
    at ``full_well``; dark noise ``N(0, read_noise_e**2)`` electrons; digital value
    ``y = dark_offset_dn + K * e`` (``K`` = :attr:`RenderSettings.system_gain`), rounded and clipped
    to ``[0, 2**bit_depth - 1]``. Below both clips (EMVA 1288 Eq. 6 and 9):

    ``E[y] = dark_offset_dn + K * mu_e``,   ``Var[y] = K**2 * (read_noise_e**2 + mu_e) + 1/12``.
    """
    e = shot_noise(img, settings.full_well, rng) * settings.full_well
    e = np.minimum(e, settings.full_well)
    if settings.read_noise_e > 0:
        e = e + settings.read_noise_e * rng.standard_normal(e.shape, dtype=np.float32)
    y = settings.dark_offset_dn + settings.system_gain * e
    top = 2 ** int(settings.bit_depth or 16) - 1
    q = np.clip(np.rint(y), 0, top)
    return q.astype(np.uint8 if settings.bit_depth == 8 else np.uint16)


#: Above this many electrons the Poisson draw is replaced by its normal limit N(lam, lam).
POISSON_NORMAL_LIMIT = 100.0


def shot_noise(img: np.ndarray, full_well: float, rng: np.random.Generator) -> np.ndarray:
    """Photon shot noise on full-scale intensities: ``Poisson(I * full_well) / full_well``.

    Pixels with ``lam = I * full_well >= 100`` electrons draw from the normal limit
    ``N(lam, lam)`` (same mean and variance; skewness 1/sqrt(lam) <= 10%), which is several
    times faster on megapixel frames; fewer electrons draw an exact Poisson count (none for
    ``lam = 0``).
    """
    lam = np.clip(img, 0, None) * full_well
    big = lam >= POISSON_NORMAL_LIMIT
    out = lam + np.sqrt(lam) * rng.standard_normal(lam.shape, dtype=np.float32) * big
    small = np.flatnonzero(~big & (lam > 0))
    if small.size:
        out.flat[small] = rng.poisson(lam.flat[small])
    return out / full_well


@numba.njit(cache=True, nogil=True)
def _electrons_kernel(img, full_well, normal, out):  # pragma: no cover - compiled
    """:func:`shot_noise`'s electrons in one pass, the same float operations in the same order:
    ``out = lam + sqrt(lam) * normal * big`` with ``lam = clip(img, 0) * full_well`` and
    ``big = lam >= POISSON_NORMAL_LIMIT``. Returns how many pixels are left for a Poisson draw
    (``0 < lam < POISSON_NORMAL_LIMIT``; branch-free, so the loop vectorises)."""
    n = 0
    for i in range(img.shape[0]):
        x = img[i]
        lam = (0.0 if x < 0.0 else x) * full_well
        big = lam >= POISSON_NORMAL_LIMIT
        out[i] = lam + math.sqrt(lam) * np.float64(normal[i]) * (1.0 if big else 0.0)
        n += (not big) & (lam > 0.0)
    return n


@numba.njit(cache=True, nogil=True)
def _read_quantize_kernel(electrons, full_well, read_noise, normal, top, out):  # pragma: no cover - compiled
    """``quantize(electrons / full_well + read_noise * normal)`` in one pass, the float operations
    of :func:`sense`'s NumPy steps: the read noise product in float32 (``read_noise`` and
    ``normal`` are float32), the sum in float64, then ``clip(rint(x * top), 0, top)``."""
    for i in range(electrons.shape[0]):
        x = electrons[i] / full_well
        if normal.shape[0]:
            x = x + np.float64(read_noise * normal[i])
        q = np.rint(x * top)
        out[i] = min(max(q, 0.0), top)


def _shot_read_quantize(img: np.ndarray, settings: RenderSettings, rng: np.random.Generator) -> np.ndarray:
    """:func:`shot_noise`, the read noise and :func:`quantize` of :func:`sense` (``bit_depth``
    set) in two compiled passes: the same draws from ``rng`` in the same order (shot noise
    normals, the Poisson counts, read noise normals), the same float operations, so the same
    frame as the NumPy steps, bit for bit."""
    flat = np.ascontiguousarray(img, np.float64).ravel()
    normal = rng.standard_normal(img.shape, dtype=np.float32).ravel()
    electrons = np.empty(flat.size)
    if _electrons_kernel(flat, float(settings.full_well), normal, electrons):
        lam = np.clip(flat, 0, None) * settings.full_well
        small = np.flatnonzero((lam < POISSON_NORMAL_LIMIT) & (lam > 0))
        electrons[small] = rng.poisson(lam[small])
    if settings.read_noise > 0:
        read = rng.standard_normal(img.shape, dtype=np.float32).ravel()
    else:
        read = np.empty(0, np.float32)
    top = 2 ** int(settings.bit_depth) - 1
    out = np.empty(flat.size, np.uint8 if settings.bit_depth == 8 else np.uint16)
    _read_quantize_kernel(electrons, float(settings.full_well), np.float32(settings.read_noise), read, float(top), out)
    return out.reshape(img.shape)


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
