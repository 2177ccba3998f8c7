"""Fourier transform profilometry (FTP): wrapped phase from one fringe image.

Eq. (4.1)-(4.4): ``I = A + B cos(phi)`` = ``A + (B/2)(e^{i phi} + e^{-i phi})``; a band-pass
window keeps the carrier lobe ``(B/2) e^{i phi}`` of the 2D spectrum, the inverse FFT gives
``I_f``, and ``phi = atan2(Im I_f, Re I_f)``, ``B = 2 |I_f|``. Modified FTP (Eq. 4.5-4.7,
6.1-6.6) first subtracts the pi-shifted pair, ``(I1 - I2)/2 = B cos(phi)``, removing the DC
lobe so a wider window fits.

The carrier is found automatically as the spectral peak away from DC, for any fringe angle;
of the two conjugate lobes the one whose phase increases along ``w = v cos(a) + u sin(a)``
(manifest convention, 0 <= a < pi) is kept, so the phase has the sign of the phase-shifting
result.

Border accuracy (noise-free, tests/test_phase_ftp.py, 128 x 160 images, T = 16-25 px, any
angle): with a carrier of a whole number of periods across the image the error is < 1e-4 rad
everywhere (border 0), both windows. With a non-integer number of periods the image edges
leak into the carrier lobe: beyond :data:`BORDER_PX` = 32 px from every edge the error is
< 3e-3 rad with the Hanning window and < 0.15 rad with the smoothed circular window
(:data:`NONINTEGER_BORDER_ERROR`), larger nearer the edges. The edge error decays roughly as
1/d^2: with the Hanning window it is < 1e-4 rad beyond :data:`BORDER_1E4_PX` = 160 px
(about 6-10 periods; measured on 512 x 640 images); the smoothed circular window stays
above 1e-3 rad even 200 px from the edges. The circular window's flat top
in turn keeps object phase detail better (a 0.5 rad Gaussian bump of sigma 20 px: 3e-3 rad
error vs 4e-2 rad with Hanning). FTP never reaches phase-shifting accuracy near edges.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fringe3d.patterns.conventions import fringe_coordinate

#: Border (px) beyond which :data:`NONINTEGER_BORDER_ERROR` holds (see module docstring).
BORDER_PX = 32
#: Border (px) beyond which the noise-free Hanning-window error is < 1e-4 rad for any carrier
#: with T <= 25 px (non-integer number of periods; module docstring).
BORDER_1E4_PX = 160
#: Max noise-free phase error (rad) beyond BORDER_PX for a non-integer number of periods.
NONINTEGER_BORDER_ERROR = {"hanning": 3e-3, "circular": 0.15}
WINDOWS = ("hanning", "circular")


class FTPResult(NamedTuple):
    """FTP outputs, each (H, W) float64: wrapped phase (rad), modulation B, average A; and the
    carrier ``(f_v, f_u)`` in cycles per pixel."""

    phase: np.ndarray
    modulation: np.ndarray
    average: np.ndarray
    carrier: tuple[float, float]


def _fft():
    """``scipy.fft``, imported on first use (with ``scipy.special``, 0.4 s that a decoder without an
    FTP plan does not pay)."""
    from scipy import fft

    return fft


def _freqs(shape):
    fv = _fft().fftfreq(shape[0])[:, None]
    fu = _fft().fftfreq(shape[1])[None, :]
    return fv, fu


def detect_carrier(image: np.ndarray, angle: float | None = None, dc_radius: float | None = None,
                   spectrum: np.ndarray | None = None) -> tuple[float, float]:
    """Carrier frequency ``(f_v, f_u)`` (cycles/pixel) of a fringe image: the strongest
    spectral peak outside a disc of ``dc_radius`` (default 3 bins of the shorter side) around
    DC, with sub-bin parabolic refinement.

    Of the two conjugate peaks the one with ``f_v cos(angle) + f_u sin(angle) > 0`` is
    returned (default: ``f_u > 0``, or ``f_v > 0`` for ``f_u = 0``, i.e. the manifest's angle
    range 0 <= angle < pi). Raises ``ValueError`` on a featureless image.

    Parameters
    ----------
    image : (H, W) array_like
        One fringe image.
    angle : float, optional
        Fringe angle (rad) choosing which conjugate peak is returned.
    dc_radius : float, optional
        Radius (cycles/pixel) of the disc around DC that is ignored; default ``3 / min(H, W)``.
    spectrum : (H, W) ndarray, optional
        A precomputed 2-D FFT of the image (its magnitude is searched) instead of the FFT of
        the mean-subtracted image.

    Returns
    -------
    tuple of float
        The carrier ``(f_v, f_u)`` in cycles per pixel.

    Examples
    --------
    >>> import numpy as np
    >>> v, u = np.mgrid[0:64, 0:64]
    >>> detect_carrier(100 + 50 * np.cos(2 * np.pi * u / 16))  # (f_v, f_u): period 16 px along u
    (0.0, 0.0625)
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 2:
        raise ValueError(f"FTP needs one (H, W) image, got shape {img.shape}")
    spec = np.abs(_fft().fft2(img - img.mean())) if spectrum is None else np.abs(spectrum)
    fv, fu = _freqs(img.shape)
    r = 3.0 / min(img.shape) if dc_radius is None else dc_radius
    if angle is None:
        half = (fu > 1e-12) | ((np.abs(fu) <= 1e-12) & (fv > 0))
    else:
        half = fringe_coordinate(fu, fv, angle) > 0
    score = np.where(half & (np.hypot(fv, fu) > r), spec, -1.0)
    iv, iu = np.unravel_index(np.argmax(score), score.shape)
    if score[iv, iu] <= 1e-9 * max(1.0, float(spec.max())):
        raise ValueError("no fringe carrier found in the image (flat spectrum away from DC); expected a fringe pattern")

    def refine(a, b, c):
        den = a - 2 * b + c
        return 0.0 if den == 0 else 0.5 * (a - c) / den

    h, w = img.shape
    dv = refine(spec[(iv - 1) % h, iu], spec[iv, iu], spec[(iv + 1) % h, iu])
    du = refine(spec[iv, (iu - 1) % w], spec[iv, iu], spec[iv, (iu + 1) % w])
    return float(fv[iv, 0] + dv / h), float(fu[0, iu] + du / w)


def bandpass_window(shape, carrier, window: str = "hanning", radius: float | None = None) -> np.ndarray:
    """(H, W) float64 band-pass window in FFT layout centred on ``carrier`` (cycles/pixel).

    ``"hanning"``: ``0.5 (1 + cos(pi d / R))`` for ``d < R``, default ``R = |carrier|`` (zero at
    DC). ``"circular"``: a smoothed circular window, 1 inside ``0.7 R`` and a raised-cosine
    edge to 0 at ``R``, default ``R = 0.5 |carrier|``. ``d`` is the distance to the carrier.

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)`` of the image.
    carrier : tuple of float
        Carrier ``(f_v, f_u)`` (cycles/pixel).
    window : {"hanning", "circular"}
        Window shape.
    radius : float, optional
        Window radius ``R`` (cycles/pixel); defaults above.

    Returns
    -------
    ndarray
        ``(H, W)`` float64 window in FFT layout, values in [0, 1].
    """
    if window not in WINDOWS:
        raise ValueError(f"unknown FTP window {window!r}; expected one of {WINDOWS}")
    fv, fu = _freqs(shape)
    f0 = math.hypot(*carrier)
    d = np.hypot(fv - carrier[0], fu - carrier[1])
    if window == "hanning":
        rr = f0 if radius is None else radius
        return np.where(d < rr, 0.5 * (1 + np.cos(np.pi * np.minimum(d, rr) / rr)), 0.0)
    rr = 0.5 * f0 if radius is None else radius
    inner = 0.7 * rr
    edge = np.clip((d - inner) / (rr - inner), 0.0, 1.0)
    return 0.5 * (1 + np.cos(np.pi * edge))


def ftp_analysis(image: np.ndarray, window: str = "hanning", carrier=None, angle: float | None = None,
                 radius: float | None = None) -> FTPResult:
    """FTP of one (H, W) fringe image (Eq. 4.1-4.4): phase, modulation, average and carrier.

    ``carrier`` (f_v, f_u) cycles/pixel, default :func:`detect_carrier`; ``angle`` (rad)
    picks the lobe sign; ``radius`` the window size (cycles/pixel). The average is
    ``I - 2 Re(I_f)`` (the image without its carrier lobes).

    Parameters
    ----------
    image : (H, W) array_like
        One fringe image.
    window : {"hanning", "circular"}
        Band-pass window, see :func:`bandpass_window`.
    carrier : tuple of float, optional
        Carrier ``(f_v, f_u)`` (cycles/pixel); default :func:`detect_carrier`.
    angle : float, optional
        Fringe angle (rad) choosing the lobe sign when the carrier is detected.
    radius : float, optional
        Window radius (cycles/pixel); default that of :func:`bandpass_window`.

    Returns
    -------
    FTPResult
        Wrapped phase (rad, (-pi, pi]), modulation B and average A, each (H, W) float64, and
        the carrier ``(f_v, f_u)``.
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 2:
        raise ValueError(f"FTP needs one (H, W) image, got shape {img.shape}")
    spec = _fft().fft2(img, workers=-1)
    if carrier is None:
        carrier = detect_carrier(img, angle=angle, spectrum=spec)  # DC is outside dc_radius
    win = bandpass_window(img.shape, carrier, window, radius)
    analytic = _fft().ifft2(spec * win, workers=-1)
    return FTPResult(np.angle(analytic), 2.0 * np.abs(analytic), img - 2.0 * analytic.real,
                     (float(carrier[0]), float(carrier[1])))


def ftp_phase(image: np.ndarray, window: str = "hanning", carrier=None, angle: float | None = None,
              radius: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Single-shot FTP wrapped phase and modulation, each (H, W) float64 (Eq. 4.1-4.4).

    ``window``: ``"hanning"`` or ``"circular"`` (smoothed circular), see
    :func:`bandpass_window`. Accurate to < 1e-4 rad (noise-free) beyond :data:`BORDER_PX`
    from the edges, everywhere for an integer number of periods across the image.

    Parameters
    ----------
    image : (H, W) array_like
        One fringe image.
    window : {"hanning", "circular"}
        Band-pass window.
    carrier : tuple of float, optional
        Carrier ``(f_v, f_u)`` (cycles/pixel); default :func:`detect_carrier`.
    angle : float, optional
        Fringe angle (rad) choosing the lobe sign when the carrier is detected.
    radius : float, optional
        Window radius (cycles/pixel).

    Returns
    -------
    phase : ndarray
        ``(H, W)`` float64 wrapped phase (rad, (-pi, pi]).
    modulation : ndarray
        ``(H, W)`` float64 modulation B (the image's units).

    Examples
    --------
    >>> import numpy as np
    >>> v, u = np.mgrid[0:64, 0:64]
    >>> phase, modulation = ftp_phase(100 + 50 * np.cos(2 * np.pi * u / 16))
    >>> bool(np.allclose(np.exp(1j * phase), np.exp(2j * np.pi * u / 16))), round(float(modulation[32, 32]), 6)
    (True, 50.0)
    """
    r = ftp_analysis(image, window=window, carrier=carrier, angle=angle, radius=radius)
    return r.phase, r.modulation


def modified_ftp_phase(i1: np.ndarray, i2: np.ndarray, window: str = "circular", carrier=None,
                       angle: float | None = None, radius: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Modified FTP with a pi-shifted pair (Eq. 4.5-4.7, 6.1-6.6): FTP of ``(I1 - I2)/2``.

    i1, i2 (H, W) with ``I1 = A + B cos(phi)``, ``I2 = A - B cos(phi)``. The DC lobe is gone,
    so the default window is the wider smoothed circle of radius 0.9 |carrier|. Returns the
    phase of I1 and the modulation B, (H, W) float64.

    Parameters
    ----------
    i1, i2 : (H, W) array_like
        The pi-shifted pair of fringe images.
    window : {"circular", "hanning"}
        Band-pass window (default ``"circular"``).
    carrier : tuple of float, optional
        Carrier ``(f_v, f_u)`` (cycles/pixel); default :func:`detect_carrier` on ``(I1 - I2)/2``.
    angle : float, optional
        Fringe angle (rad) choosing the lobe sign when the carrier is detected.
    radius : float, optional
        Window radius (cycles/pixel); default ``0.9 |carrier|`` (circular) or ``|carrier|``.

    Returns
    -------
    phase : ndarray
        ``(H, W)`` float64 wrapped phase of I1 (rad, (-pi, pi]).
    modulation : ndarray
        ``(H, W)`` float64 modulation B.

    Examples
    --------
    >>> import numpy as np
    >>> v, u = np.mgrid[0:64, 0:64]
    >>> i1 = 100 + 50 * np.cos(2 * np.pi * u / 16)
    >>> phase, modulation = modified_ftp_phase(i1, 200 - i1)
    >>> bool(np.allclose(np.exp(1j * phase), np.exp(2j * np.pi * u / 16))), round(float(modulation[32, 32]), 6)
    (True, 50.0)
    """
    a = np.asarray(i1, dtype=np.float64)
    b = np.asarray(i2, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"modified FTP needs two images of one shape, got {a.shape} and {b.shape}")
    diff = 0.5 * (a - b)
    if carrier is None:
        carrier = detect_carrier(diff, angle=angle)
    if radius is None:
        radius = 0.9 * math.hypot(*carrier) if window == "circular" else math.hypot(*carrier)
    r = ftp_analysis(diff, window=window, carrier=carrier, angle=angle, radius=radius)
    return r.phase, r.modulation
