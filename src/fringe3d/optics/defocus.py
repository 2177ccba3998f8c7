"""Projector defocus: point-spread and optical transfer functions, Eq. (2.22)-(2.26).

A defocused projector convolves the DMD image with a point-spread function (PSF),
``image = object * PSF`` (Eq. 2.22); in the frequency domain the spectrum is multiplied by
the optical transfer function (OTF). Two models:

* **Gaussian** PSF of standard deviation ``sigma`` (projector pixels), the usual model for
  binary defocusing: ``OTF(f) = exp(-2 pi^2 sigma^2 f^2)`` with ``f`` in cycles/pixel.
* **Hopkins** geometric-optics defocus OTF (Eq. 2.26): ``OTF(s) = 2 J1(a) / a`` with
  ``a = 4 pi omega s / lambda``; ``omega`` is the maximal wavefront error (defocus), ``s`` the
  spatial frequency. Here ``s`` is in cycles per projector pixel, so ``omega / lambda`` is a
  length in pixels; the matching PSF is a uniform disc of radius ``2 omega / lambda`` pixels
  (the Fourier transform of a disc of radius R is ``2 J1(2 pi R f) / (2 pi R f)``).

Both OTFs are real and circularly symmetric, so defocus lowers fringe contrast (and the
harmonics of a squared binary pattern) but never moves the phase (Eq. 2.27-2.29).
"""
from __future__ import annotations

import numpy as np

MODELS = ("none", "gaussian", "hopkins")


def gaussian_otf(f, sigma: float) -> np.ndarray:
    """Gaussian OTF ``exp(-2 pi^2 sigma^2 f^2)``.

    Parameters
    ----------
    f : array_like
        Spatial frequency magnitude, cycles per pixel.
    sigma : float
        PSF standard deviation, pixels (>= 0).

    Returns
    -------
    ndarray (float)
        OTF values, shape of ``f``; 1 at ``f = 0``.
    """
    if sigma < 0:
        raise ValueError(f"Gaussian defocus sigma must be >= 0 pixels, got {sigma}")
    f = np.asarray(f, dtype=float)
    return np.exp(-2.0 * np.pi**2 * sigma**2 * f**2)


def hopkins_otf(s, omega: float, wavelength: float = 1.0) -> np.ndarray:
    """Hopkins' geometric-optics defocus OTF ``2 J1(a)/a``, ``a = 4 pi omega s / lambda`` (Eq. 2.26).

    Parameters
    ----------
    s : array_like
        Spatial frequency magnitude (cycles per pixel when used on images).
    omega : float
        Defocus (maximal wavefront error), same length unit as ``wavelength`` (>= 0).
    wavelength : float
        Wavelength; only the ratio ``omega / wavelength`` matters (pixels when ``s`` is in
        cycles/pixel).

    Returns
    -------
    ndarray (float)
        OTF values; 1 at ``a = 0``. The OTF is real and may go negative (contrast reversal)
        beyond its first zero at ``a = 3.8317``.
    """
    if omega < 0 or wavelength <= 0:
        raise ValueError(f"Hopkins defocus needs omega >= 0 and wavelength > 0, got {omega}, {wavelength}")
    a = 4.0 * np.pi * omega * np.asarray(s, dtype=float) / wavelength
    out = np.ones_like(a)
    nz = np.abs(a) > 1e-12
    from scipy.special import j1  # heavy: loaded with the first Hopkins OTF

    out[nz] = 2.0 * j1(a[nz]) / a[nz]
    return out


def otf(f, model: str, size: float) -> np.ndarray:
    """OTF of ``model`` (``"none"``, ``"gaussian"`` with sigma = ``size``, ``"hopkins"`` with
    omega/lambda = ``size`` pixels) at frequency magnitudes ``f`` (cycles/pixel).

    Parameters
    ----------
    f : array_like
        Spatial frequency magnitude, cycles per pixel.
    model : ``"none"`` | ``"gaussian"`` | ``"hopkins"``
        Defocus model (:data:`MODELS`); anything else raises ``ValueError``.
    size : float
        Gaussian sigma (pixels) or Hopkins omega/lambda (pixels); 0 means no blur.

    Returns
    -------
    ndarray (float)
        OTF values, shape of ``f`` (:func:`gaussian_otf`, :func:`hopkins_otf`, or ones).
    """
    check_model(model)
    if model == "none" or size == 0:
        return np.ones_like(np.asarray(f, dtype=float))
    if model == "gaussian":
        return gaussian_otf(f, size)
    return hopkins_otf(f, size, 1.0)


def check_model(model: str) -> None:
    if model not in MODELS:
        raise ValueError(f"unknown defocus model {model!r}; expected one of {MODELS}")


def psf_kernel(model: str, size: float, radius: int | None = None, oversample: int = 8) -> np.ndarray:
    """Normalised 2D PSF kernel (sums to 1), shape ``(2r+1, 2r+1)``.

    ``"gaussian"``: ``exp(-(x^2+y^2)/(2 sigma^2))`` with sigma = ``size`` pixels.
    ``"hopkins"``: uniform disc of radius ``2*size`` pixels (``size`` = omega/lambda), the
    geometric-optics PSF whose transform is Eq. (2.26); pixel coverage is anti-aliased by
    ``oversample`` x ``oversample`` sub-samples. ``"none"``: the 1x1 identity kernel.

    Parameters
    ----------
    model : ``"none"`` | ``"gaussian"`` | ``"hopkins"``
        Defocus model (:data:`MODELS`).
    size : float
        Gaussian sigma or Hopkins omega/lambda, pixels (>= 0); 0 gives the 1x1 kernel.
    radius : int, optional
        Kernel half-width ``r``, pixels; default ``ceil(4*size)`` (Gaussian) or
        ``ceil(2*size) + 1`` (Hopkins).
    oversample : int
        Sub-samples per pixel along each axis used to integrate the PSF over a pixel.

    Returns
    -------
    (2r+1, 2r+1) ndarray (float)
        The kernel, normalised to sum 1.
    """
    check_model(model)
    if size < 0:
        raise ValueError(f"defocus size must be >= 0, got {size}")
    if model == "none" or size == 0:
        return np.ones((1, 1))
    if radius is None:
        radius = int(np.ceil(4 * size)) if model == "gaussian" else int(np.ceil(2 * size)) + 1
    sub = (np.arange(oversample) + 0.5) / oversample - 0.5
    c = np.arange(-radius, radius + 1, dtype=float)
    xs = (c[:, None] + sub[None, :]).ravel()
    X, Y = np.meshgrid(xs, xs)
    if model == "gaussian":
        k = np.exp(-(X**2 + Y**2) / (2 * size**2))
    else:
        k = ((X**2 + Y**2) <= (2 * size) ** 2).astype(float)
    n = 2 * radius + 1
    k = k.reshape(n, oversample, n, oversample).sum(axis=(1, 3))
    return k / k.sum()


def blur_pattern(image: np.ndarray, model: str = "gaussian", size: float = 0.0,
                 pad: int | None = None) -> np.ndarray:
    """Blur a projector image by a defocus OTF in the frequency domain (Eq. 2.22).

    Parameters
    ----------
    image : (H, W) array
        Projector image (any float scale).
    model : ``"none"`` | ``"gaussian"`` | ``"hopkins"``
    size : float
        Gaussian sigma (pixels) or Hopkins omega/lambda (pixels).
    pad : int, optional
        Symmetric padding (reflect) added on each side before the FFT so the borders do not
        wrap around; default ``ceil(6*size)``. ``pad=0`` treats the image as periodic (exact
        for patterns whose period divides the image size).

    Returns
    -------
    (H, W) float64
        The blurred image; its mean is preserved (OTF(0) = 1).
    """
    check_model(model)
    img = np.asarray(image, dtype=float)
    if img.ndim != 2:
        raise ValueError(f"blur_pattern expects a 2D image, got shape {img.shape}")
    if model == "none" or size == 0:
        return img.copy()
    if pad is None:
        pad = int(np.ceil(6 * size)) + 2
    work = np.pad(img, pad, mode="symmetric") if pad > 0 else img
    H, W = work.shape
    from scipy import fft as sfft  # heavy (0.3 s with scipy.special): loaded with the first blur

    fy = sfft.fftfreq(H)[:, None]
    fx = sfft.rfftfreq(W)[None, :]
    transfer = otf(np.sqrt(fx**2 + fy**2), model, size)
    out = sfft.irfft2(sfft.rfft2(work) * transfer, s=(H, W), workers=1)
    return out[pad:pad + img.shape[0], pad:pad + img.shape[1]] if pad > 0 else out


def defocus_size_at(distance, size: float, focus_distance: float | None, growth: float) -> np.ndarray:
    """Defocus size growing linearly with distance from the projector's focal plane.

    ``size(d) = size + growth * |d - focus_distance|`` (pixels; ``growth`` in pixels per mm,
    ``distance`` in mm along the projector axis). With ``focus_distance=None`` the size is
    constant. A thin-lens blur circle grows linearly with defocus distance near focus.

    Parameters
    ----------
    distance : array_like
        Distance along the projector axis, mm.
    size : float
        Defocus size at the focal plane (Gaussian sigma or Hopkins omega/lambda), pixels.
    focus_distance : float or None
        Distance of the focal plane, mm; ``None`` keeps the size constant.
    growth : float
        Growth of the size per mm away from focus, pixels/mm; 0 keeps it constant.

    Returns
    -------
    ndarray (float)
        Defocus size in pixels, shape of ``distance``.
    """
    d = np.asarray(distance, dtype=float)
    if focus_distance is None or growth == 0:
        return np.full_like(d, size)
    return size + growth * np.abs(d - focus_distance)


def fundamental_contrast(sigma: float, period: float = 18.0) -> float:
    """Fraction of the fringe fundamental a Gaussian blur keeps: its OTF (:func:`gaussian_otf`)
    at ``f = 1 / T`` (Eq. 2.22-2.26), ``C = exp(-2 pi^2 sigma^2 / T^2)``.

    Phase noise - and, when sensor noise dominates, the
    measured sphere RMS - scales with ``1 / C``.

    Parameters
    ----------
    sigma : float
        Gaussian projector blur (projector px).
    period : float
        Fringe period ``T`` (projector px).

    Returns
    -------
    float
        Contrast in (0, 1].

    Examples
    --------
    >>> round(fundamental_contrast(3.0), 4)
    0.5779
    """
    return float(np.exp(-2 * np.pi ** 2 * sigma ** 2 / period ** 2))
