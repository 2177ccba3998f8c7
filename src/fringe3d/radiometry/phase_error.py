"""Phase-error look-up table indexed by the wrapped phase (Zhang & Yau 2007).

A nonlinear projector response makes the N-step phase (Eq. 2.4) deviate from the true phase by
an error that depends only on the phase itself (and on the response, not on the pixel's ambient
or albedo): ``phi_measured = phi + e(phi)``. The table stores ``e`` on a grid of *measured*
phase, so a capture already taken is corrected by ``phi - e(phi_measured)`` with one periodic
interpolation per pixel (:meth:`PhaseErrorLUT.correct`).

Two ways to build it:

* :func:`lut_from_response`: simulate the N-step algorithm on the measured response curve
  (Zhang & Yau's construction from the projector's gamma curve);
* :func:`lut_from_reference`: bin the difference between a measured phase and a known
  reference phase (a flat board, or a capture decoded with a linear projector), by measured phase.

References
----------
S. Zhang and S.-T. Yau, "Generic nonsinusoidal phase error correction for three-dimensional
shape measurement using a digital video projector", Appl. Opt. 46(1), 36-43 (2007).
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import numba
import numpy as np

from fringe3d.phase.psp import default_shifts, lsq_coefficients

from .response import ResponseLUT

TWO_PI = 2.0 * np.pi


def wrap(phi) -> np.ndarray:
    """Phase wrapped to [-pi, pi) (rad), float64."""
    return np.mod(np.asarray(phi, float) + np.pi, TWO_PI) - np.pi


class PhaseErrorLUT(NamedTuple):
    """Phase error ``e`` (rad) on ``bins`` equally spaced measured phases covering [-pi, pi).

    Attributes
    ----------
    phase : (M,) float64
        Bin centres, rad, ``-pi + 2 pi (j + 1/2) / M``.
    error : (M,) float64
        Mean ``phi_measured - phi_true`` in each bin, rad.
    """

    phase: np.ndarray
    error: np.ndarray

    def at(self, measured) -> np.ndarray:
        """``e(phi_measured)`` by periodic linear interpolation, same shape as ``measured``."""
        return np.interp(wrap(measured), self.phase, self.error, period=TWO_PI)

    def correct(self, measured) -> np.ndarray:
        """Corrected wrapped phase ``wrap(phi_measured - e(phi_measured))`` (rad, float32)."""
        m = np.asarray(measured, float)
        return wrap(m - self.at(m)).astype(np.float32)

    @property
    def amplitude(self) -> float:
        """Largest ``|e|`` in the table (rad)."""
        return float(np.max(np.abs(self.error)))


def bin_centres(bins: int) -> np.ndarray:
    """``-pi + 2 pi (j + 1/2) / bins``, (bins,) float64."""
    return -np.pi + TWO_PI * (np.arange(bins) + 0.5) / bins


def simulate_phase(response: ResponseLUT, phi, shifts) -> np.ndarray:
    """N-step least-squares phase (Eq. 2.4) of ``r(1/2 (1 + cos(phi + delta_k)))``; rad, like ``phi``."""
    d = np.asarray(shifts, float)
    return _lsq_phase(response, _patterns(np.asarray(phi, float), d), d)


def _patterns(phi: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(N, ...) projected pattern values ``1/2 (1 + cos(phi + delta_k))`` of :func:`simulate_phase`."""
    return 0.5 * (1.0 + np.cos(phi[None] + d.reshape((-1,) + (1,) * phi.ndim)))


def _lsq_phase(response: ResponseLUT, patterns: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The N-step phase of :func:`simulate_phase` from its pattern values (:func:`_patterns`)."""
    _, b, c = np.tensordot(lsq_coefficients(d), response.apply(patterns), axes=1)
    return np.arctan2(-c, b)


@functools.lru_cache(maxsize=16)
def _simulated_patterns(shifts: tuple[float, ...], samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The true phases :func:`bin_centres` of ``samples`` and their pattern values (:func:`_patterns`)
    for ``shifts``, which :func:`lut_from_response` simulates for every response (cached per
    shifts and samples, read-only: the decoder's diagnostic asks per direction and cycle)."""
    true = bin_centres(samples)
    patterns = _patterns(true, np.array(shifts, float))
    true.flags.writeable = False
    patterns.flags.writeable = False
    return true, patterns


def lut_from_response(response: ResponseLUT, shifts=None, steps: int | None = None, bins: int = 256,
                      samples: int = 8192) -> PhaseErrorLUT:
    """Phase-error table of a projector response for one phase-shift set (Zhang & Yau 2007).

    Parameters
    ----------
    response : ResponseLUT
    shifts : (N,) float, optional
        Phase shifts (rad); default ``2 pi k / steps``.
    steps : int, optional
        N when ``shifts`` is not given.
    bins : int
        Table size (phases per period).
    samples : int
        True phases simulated per period.

    Returns
    -------
    PhaseErrorLUT
        The N-step phase's error as a function of the measured phase.
    """
    if shifts is None:
        if steps is None:
            raise ValueError("give the phase shifts or the number of steps")
        shifts = default_shifts(steps)
    d = np.asarray(shifts, float)
    true, patterns = _simulated_patterns(tuple(d.ravel().tolist()), int(samples))
    return lut_from_reference(_lsq_phase(response, patterns, d), true, bins=bins)


def lut_from_reference(measured, reference, mask=None, bins: int = 256) -> PhaseErrorLUT:
    """Phase-error table from a measured phase and a known reference phase of the same pixels.

    Parameters
    ----------
    measured : (...) float
        Measured wrapped (or absolute) phase, rad.
    reference : (...) float
        The true phase of the same pixels (a plane fitted to a flat board's absolute phase, or the
        phase from a linear projector), rad; only its value modulo 2 pi matters.
    mask : (...) bool, optional
        Pixels to use (default: all finite).
    bins : int
        Table size.

    Returns
    -------
    PhaseErrorLUT
        Mean of ``wrap(measured - reference)`` per bin of ``wrap(measured)``; empty bins are
        filled by periodic interpolation.

    Raises
    ------
    ValueError
        Shapes differ, or fewer than half of the bins receive a pixel.
    """
    m = np.asarray(measured, float)
    r = np.asarray(reference, float)
    if m.shape != r.shape:
        raise ValueError(f"measured phase {m.shape} and reference phase {r.shape} must have the same shape")
    ok = np.isfinite(m) & np.isfinite(r)
    if mask is not None:
        ok &= np.asarray(mask, bool)
    # wrap(m), wrap(wrap(m) - r) and the bin of wrap(m) of the pixels of ok, in one compiled pass
    err, idx = _wrapped_errors(np.ascontiguousarray(m).reshape(-1), np.ascontiguousarray(r).reshape(-1),
                               np.ascontiguousarray(ok).reshape(-1), int(bins))
    count = np.bincount(idx, minlength=bins)
    if np.count_nonzero(count) < bins // 2:
        raise ValueError(f"the reference region covers only {np.count_nonzero(count)} of {bins} phase bins; "
                         "use a larger flat region (at least one full fringe period) or fewer bins")
    # average the error as a unit vector so bins straddling +-pi do not cancel
    s = np.bincount(idx, np.sin(err), bins)
    c = np.bincount(idx, np.cos(err), bins)
    centres = bin_centres(bins)
    full = count > 0
    if full.all():  # np.interp at its own sample points returns their values: the table itself
        return PhaseErrorLUT(centres, np.arctan2(s, c))
    e = np.arctan2(s[full], c[full])
    return PhaseErrorLUT(centres, np.interp(centres, centres[full], e, period=TWO_PI))


@numba.njit(cache=True, nogil=True)
def _wrapped_errors(m, r, ok, bins):  # pragma: no cover - compiled
    """``(err, idx)`` over the entries of ``ok`` in order: ``mw = wrap(m)``, ``err = wrap(mw - r)``
    and ``idx = min(int((mw + pi) / (2 pi) * bins), bins - 1)``, the float64 operations of
    :func:`wrap` (``np.mod``: C ``fmod``, then ``+ 2 pi`` for a negative remainder and +0.0 for
    a zero one) and of the numpy expressions, one by one."""
    n = 0
    for i in range(ok.size):
        n += ok[i]
    err = np.empty(n)
    idx = np.empty(n, np.int64)
    k = 0
    for i in range(ok.size):
        if ok[i]:
            mw = _wrap1(m[i])
            err[k] = _wrap1(mw - r[i])
            idx[k] = min(int((mw + np.pi) / TWO_PI * bins), bins - 1)
            k += 1
    return err, idx


@numba.njit(cache=True, nogil=True, inline="always")
def _wrap1(x):  # pragma: no cover - compiled
    """:func:`wrap` of one float64: ``np.mod(x + pi, 2 pi) - pi``."""
    y = x + np.pi
    mod = y if -TWO_PI < y < TWO_PI else np.fmod(y, TWO_PI)  # fmod is exact: y itself below the divisor
    if mod != 0.0:
        if mod < 0.0:
            mod += TWO_PI
    else:
        mod = 0.0
    return mod - np.pi
