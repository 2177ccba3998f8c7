"""Saturation by what it breaks: the phase bias that clipped samples cause.

A sensor clips every sample at its saturation level ``L``: a clipped sample reads ``L`` where
the light gave ``I_k >= L``, so clipping only ever *lowers* a sample, by its deficit
``d_k = I_k - L >= 0``. In the least-squares fit of Eq. (2.4) the complex fringe amplitude
``z = b - i c = B exp(i phi)`` is linear in the samples, ``z = sum_k w_k I_k`` with
``w_k = P[1, k] - i P[2, k]`` (``P`` from :func:`fringe3d.phase.psp.lsq_coefficients`;
``w_k = (2/N) exp(-i delta_k)`` for equal shifts), so the clipped fit misses

``z_true = z_meas + sum_{k clipped} d_k w_k``            (bias ``= arg(z_true / z_meas)``)

and a pixel's phase is broken only where that bias exceeds the phase noise. Two cases:

* **estimated** (at least 3 unclipped samples whose shifts separate A, B and phi): the
  sinusoid fitted to the unclipped samples predicts each clipped sample, ``d_k = fit_k - L``
  (signed: a sample that reads ``L`` while the fit says it should be darker was raised, e.g.
  by a glint, and biases the phase just as well), and the bias is computed from it;
* **bounded** (fewer unclipped samples, e.g. a 3-step group with one clipped sample): the
  deficits are unknown but non-negative, so ``z_true`` lies in the cone spanned by ``z_meas``
  and the clipped samples' ``w_k``; the bias is at most ``max_k |arg(w_k / z_meas)|`` when that
  cone is narrower than pi (else pi). A sample clipped at the fringe crest (``arg w_k`` equal to
  the phase) then bounds the bias by how far the crest lies from it. With one clipped sample
  the bound is tightened by the light being non-negative (the true sinusoid's minimum
  ``A - B >= 0`` caps the deficit at the root of a quadratic, in closed form).

The per-pixel work is one numba pass over the clipped pixels
(:mod:`fringe3d.phase._clipping_kernel`; its plain-NumPy reference is
``tests/clipping_reference.py``). A pixel is masked where ``|bias| > tau``; ``tau`` is the
pixel's phase-noise sigma ``sqrt(2/N) sigma / B`` (:func:`fringe3d.phase.noise.phase_sigma`) for intensity noise
``sigma`` (frames' units), or a stated bound in radians.
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple, Sequence

import numpy as np

from fringe3d.phase import _clipping_kernel
from fringe3d.phase.psp import lsq_coefficients


#: Most phase steps :func:`clipping_bias` takes (a pixel's clipped samples are the bits of an int64).
MAX_STEPS = 63


class ClippingBias(NamedTuple):
    """Per clipped pixel (M,): ``bias`` (rad; the estimate, or the bound), ``estimated`` (bool:
    estimated from the unclipped samples, else a bound) and ``modulation`` (the fringe
    modulation B after restoring the estimated deficits; the clipped fit's B for a bound)."""

    bias: np.ndarray
    estimated: np.ndarray
    modulation: np.ndarray


class ClippingMask(NamedTuple):
    """(H, W) bool maps of one phase group: ``clipped`` (a sample at the saturation level) and
    ``broken`` (clipping biases the phase beyond the bound; the pixels to mask); ``estimated``
    counts the clipped pixels whose bias was estimated rather than bounded."""

    clipped: np.ndarray
    broken: np.ndarray
    estimated: int


def clipping_bias(samples: np.ndarray, shifts: Sequence[float], level: float) -> ClippingBias:
    """Phase bias (rad) that clipping at ``level`` causes in an N-step least-squares phase.

    Parameters
    ----------
    samples : (N, M) float
        The N phase-shifted samples of M pixels (frames' units), in the order of ``shifts``.
    shifts : (N,) float
        Phase shifts (rad).
    level : float
        Saturation level: a sample ``>= level`` is clipped.

    Returns
    -------
    :class:`ClippingBias` of the M pixels (0 bias for a pixel without a clipped sample). See the
    module docstring for the estimate and the bound.

    Examples
    --------
    >>> import numpy as np
    >>> d = 2 * np.pi * np.arange(8) / 8
    >>> true = 100 + 200 * np.cos(0.3 + d)                 # crest 300, clipped at 255
    >>> r = clipping_bias(np.minimum(true, 255)[:, None], d, 255)
    >>> bool(r.estimated[0]), round(float(r.modulation[0]), 6)   # restored: B = 200
    (True, 200.0)
    """
    s = np.ascontiguousarray(samples, np.float64)
    d = np.asarray(shifts, np.float64)
    if s.ndim != 2 or s.shape[0] != d.size:
        raise ValueError(f"samples {s.shape} must be (N, M) for the N = {d.size} shifts")
    if d.size > MAX_STEPS:
        raise ValueError(f"the clipping analysis takes at most {MAX_STEPS} phase steps, got {d.size}")
    m = s.shape[1]
    out = ClippingBias(np.zeros(m), np.zeros(m, bool), np.zeros(m))
    _clipping_kernel.clipping_bias_kernel(s, np.cos(d), np.sin(d), lsq_coefficients(d), float(level), *out)
    return out


def clipping_mask(frames: np.ndarray, index: Sequence[int], shifts: Sequence[float], level: float,
                  noise: float | Callable[[], float], max_bias: float | None = None,
                  clipped: np.ndarray | None = None) -> ClippingMask:
    """Which pixels of one N-step group clipping breaks (see the module docstring).

    Parameters
    ----------
    frames : (F, H, W) array
        Camera frames (any real dtype); only the group's ``index`` frames are read.
    index, shifts : (N,)
        The group's frame indices and phase shifts (rad), in step order.
    level : float
        Saturation level (frames' units); ``inf`` gives no clipped pixel.
    noise : float or callable
        Intensity noise sigma (frames' units) of one sample, or a function returning it (called
        only when a pixel is clipped and ``max_bias`` is None).
    max_bias : float, optional
        Largest accepted bias (rad); default the pixel's phase-noise sigma
        ``sqrt(2/N) noise / B`` (:func:`fringe3d.phase.noise.phase_sigma`).
    clipped : (H, W) bool, optional
        The group's clipping flags (a frame ``>= level``) when already known, e.g. from the
        decoder's fused pass; default: compared here, one pass per frame.

    Returns
    -------
    :class:`ClippingMask`.
    """
    idx = list(index)
    h, w = frames.shape[1:]
    if clipped is None:
        clipped = np.zeros((h, w), bool)
        if math.isfinite(level):
            for i in idx:
                clipped |= frames[i] >= level
    broken = np.zeros((h, w), bool)
    if not clipped.any():
        return ClippingMask(clipped, broken, 0)
    rows, cols = np.nonzero(clipped)
    samples = np.stack([np.asarray(frames[i][rows, cols], np.float64) for i in idx])
    r = clipping_bias(samples, shifts, level)
    if max_bias is None:
        with np.errstate(divide="ignore", invalid="ignore"):
            sigma = float(noise() if callable(noise) else noise)
            tau = math.sqrt(2.0 / len(idx)) * sigma / r.modulation
        tau = np.where(r.modulation > 0, tau, 0.0)
    else:
        tau = np.full(r.bias.shape, float(max_bias))
    broken[rows, cols] = ~(np.abs(r.bias) <= tau)
    return ClippingMask(clipped, broken, int(r.estimated.sum()))
