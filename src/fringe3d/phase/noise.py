"""Camera noise of one capture from its own frames, and the phase noise it gives.

The noise model is heteroscedastic, ``sigma^2(A) = c0 + c1 A`` (read noise plus shot noise,
frames' units, ``A`` the average intensity), fitted once per capture to per-pixel variance
estimates (:func:`fit_noise_model`). The per-pixel variance estimates come from:

* an ``N >= 4``-step group: the residual of the least-squares sinusoid fit (Eq. 2.4),
  ``s^2 = sum_k (I_k - a - b cos d_k - c sin d_k)^2 / (N - 3)`` (:func:`fit_residual_variance`);
* 3-step groups only (no residual degree of freedom): the spread of the averages of two
  groups, which see the same ``A``: ``s^2 = (A_1 - A_2)^2 / (1/N_1 + 1/N_2)``
  (:func:`average_difference_variance`);
* a single 3-step group: the Laplacian high-pass of its average image (Immerkaer 1996,
  :func:`laplacian_noise`), which over-estimates on textured scenes.

The phase noise of an ``N``-step least-squares phase is ``sigma_phi = sqrt(2/N) sigma / B``
(:func:`phase_sigma`).
"""
from __future__ import annotations

import math
from typing import Sequence

import numba
import numpy as np

from fringe3d.phase._noise_kernel import (interior_laplacian, line_moments, model_phase_sigma,  # noqa: F401 (API)
                                          model_phase_sigma_and_fraction, residual_sum_of_squares)

from fringe3d.phase.psp import lsq_coefficients


def fit_residual_variance(frames: np.ndarray, index: Sequence[int], shifts: Sequence[float]) -> np.ndarray:
    """(H, W) float32 per-pixel noise variance (frames' units squared) from an ``N >= 4``-step group.

    ``s^2 = |I - D P I|^2 / (N - 3)`` with ``D`` (N, 3) the design ``[1, cos d_k, sin d_k]`` and
    ``P`` its pseudo-inverse (:func:`fringe3d.phase.psp.lsq_coefficients`); unbiased for white noise.
    One numba pass in float64 over the frames (no (N, H, W) temporary).
    """
    idx = list(index)
    if len(idx) < 4:
        raise ValueError(f"a fit residual needs at least 4 phase steps, got {len(idx)}")
    d = np.asarray(shifts, np.float64)
    design = np.stack([np.ones_like(d), np.cos(d), np.sin(d)], axis=1)
    return residual_sum_of_squares(np.asarray(frames), np.asarray(idx, np.int64), design, lsq_coefficients(d),
                                   1.0 / (d.size - 3))


def average_difference_variance(avg1: np.ndarray, n1: int, avg2: np.ndarray, n2: int) -> np.ndarray:
    """(H, W) float32 per-pixel variance from two groups' averages ``A_1``, ``A_2`` of ``n1``, ``n2``
    equally spaced steps: ``(A_1 - A_2)^2 / (1/n1 + 1/n2)`` (each average carries ``sigma^2 / n``)."""
    diff = np.asarray(avg1, np.float32) - np.asarray(avg2, np.float32)
    return diff * diff / np.float32(1.0 / n1 + 1.0 / n2)


def laplacian_noise(image: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Noise sigma (image units) of one image by Immerkaer's Laplacian-difference estimate.

    ``sigma = sqrt(pi/2) mean|I * L| / 6`` with ``L = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]``,
    over the pixels of ``mask`` (default all) away from the border.
    """
    if mask is not None:  # the mask eroded once: one numba pass
        return laplacian_sigma(*interior_laplacian(np.asarray(image), np.asarray(mask, bool)))
    from scipy import ndimage  # heavy (0.25 s with scipy.special): loaded for an unmasked image only

    kern = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    resp = np.abs(ndimage.convolve(np.asarray(image, np.float64), kern, mode="nearest"))
    return float(math.sqrt(math.pi / 2.0) * resp.mean() / 6.0)


def laplacian_sigma(total: float, count: int) -> float:
    """Immerkaer's ``sigma = sqrt(pi/2) total / count / 6`` from the sums ``(total, count)`` of
    :func:`interior_laplacian` (NaN for no pixel): :func:`laplacian_noise` over a mask, from sums
    another pass made (:func:`fringe3d.phase.psp.wrapped_phase_and_mask`)."""
    return float(math.sqrt(math.pi / 2.0) * total / count / 6.0) if count else float("nan")


def fit_noise_model(variance: np.ndarray, average: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """``(c0, c1)`` of ``sigma^2 = c0 + c1 A`` fitted to per-pixel variances over ``mask``.

    A robust two-step fit: ordinary least squares, then again on the pixels whose variance is
    within 5 times the first model (drops mixed and moving pixels). ``c1`` is clipped at 0
    (then ``c0`` is the mean variance); ``(nan, nan)`` when fewer than 10 pixels are valid.
    Each step is one numba pass of float64 sums (:func:`line_moments`), no per-pixel temporary.
    """
    a, v, m = np.asarray(average), np.asarray(variance), np.asarray(mask, bool)
    ref = _reference_point(a, v, m)  # sums about a point near the means: no cancellation in sum dx^2
    moments = line_moments(a, v, m, None, 0.0, ref)
    if moments[0] < 10:
        return float("nan"), float("nan")
    c0, c1 = _line_from_moments(moments, ref)
    return _line_from_moments(line_moments(a, v, m, (c0, c1), 5.0, ref), ref)


def _reference_point(x: np.ndarray, y: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """Means of ``x`` and ``y`` over the finite masked pixels of every 8th row and column, a
    centre for :func:`line_moments` (``(0, 0)`` where that sample is empty)."""
    if _compiled_pair(x, y, mask):  # the two compacted samples in one compiled pass, numpy's means of them
        xs, ys = _finite_sample(x, y, mask, 8)
    else:
        xs, ys, ms = x[::8, ::8], y[::8, ::8], mask[::8, ::8]
        sel = ms & np.isfinite(xs) & np.isfinite(ys)
        xs, ys = xs[sel], ys[sel]
    if not xs.size:
        return 0.0, 0.0
    return float(np.mean(xs, dtype=np.float64)), float(np.mean(ys, dtype=np.float64))


def _compiled_pair(x: np.ndarray, y: np.ndarray, mask: np.ndarray) -> bool:
    """``x``, ``y`` (H, W) float32 or float64 and ``mask`` (H, W) bool: what :func:`_finite_sample` reads."""
    return (x.ndim == 2 and x.shape == y.shape == mask.shape and mask.dtype == np.bool_
            and x.dtype in (np.float32, np.float64) and y.dtype in (np.float32, np.float64))


@numba.njit(cache=True, nogil=True)
def _finite_sample(x, y, mask, step):  # pragma: no cover - compiled
    """``(x[::step, ::step][sel], y[::step, ::step][sel])`` with ``sel`` the masked pixels of
    that sample where both are finite, in row-major order and the arrays' own dtypes."""
    h, w = x.shape
    size = ((h + step - 1) // step) * ((w + step - 1) // step)
    xs = np.empty(size, x.dtype)
    ys = np.empty(size, y.dtype)
    n = 0
    for i in range(0, h, step):
        for j in range(0, w, step):
            a = x[i, j]
            b = y[i, j]
            if mask[i, j] and np.isfinite(a) and np.isfinite(b):
                xs[n] = a
                ys[n] = b
                n += 1
    return xs[:n], ys[:n]


def _line_from_moments(moments: np.ndarray, ref: tuple[float, float]) -> tuple[float, float]:
    """Least-squares line ``y = c0 + c1 x`` from :func:`line_moments` (sums of ``x - ref[0]``,
    ``y - ref[1]``): ``c1 = S_xy / S_xx`` of the centred sums, ``c0 = my - c1 mx``; ``c1 = 0``
    where x is constant; ``(mean y, 0)`` where the slope is negative."""
    n, sx, sy, sxx, sxy = (float(t) for t in moments)
    if n <= 0:
        return float("nan"), float("nan")
    mx, my = ref[0] + sx / n, ref[1] + sy / n
    cxx = sxx - sx * sx / n
    c1 = (sxy - sx * sy / n) / cxx if cxx > 1e-12 * n * max(1.0, mx * mx) * 1e-12 else 0.0
    if c1 < 0:
        return my, 0.0
    return my - c1 * mx, c1


def noise_sigma(model: tuple[float, float], average: np.ndarray) -> np.ndarray:
    """(H, W) float32 noise sigma ``sqrt(max(c0 + c1 A, 0))`` (frames' units) of the model."""
    c0, c1 = model
    return np.sqrt(np.maximum(c0 + c1 * np.asarray(average, np.float32), 0.0)).astype(np.float32)


def phase_sigma(sigma: np.ndarray | float, modulation: np.ndarray, steps: int) -> np.ndarray:
    """(H, W) float32 standard deviation (rad) of an ``N``-step least-squares phase,
    ``sigma_phi = sqrt(2/N) sigma / B`` (``B`` the modulation, same units as ``sigma``); inf where B <= 0."""
    b = np.asarray(modulation, np.float32)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.float32(math.sqrt(2.0 / steps)) * np.asarray(sigma, np.float32) / b
    return np.where(b > 0, out, np.inf).astype(np.float32)
