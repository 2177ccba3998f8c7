"""Self-calibrating harmonic model: the projector's nonlinearity estimated from the capture itself.

With ``N`` equally shifted frames (``delta_k = 2 pi k / N``) the DFT of each pixel's samples has
bins ``m = 0 .. N-1``. A response ``r`` turns the pattern ``1/2 (1 + cos t)`` into a Fourier
series ``sum_m c_m cos(m t)``; harmonic ``m`` lands in bin ``m mod N``. Harmonics ``N - 1`` and
``N + 1`` fold onto bin 1 and cause the familiar ripple ``e(phi) ~ eps sin(N phi)`` of the
phase (Pan et al. 2009); they cannot be told apart from a warping of the phase, so no per-pixel
fit recovers them. The harmonics ``2 .. N - 2`` (present when ``N >= 4``) land in bins of their
own: the residual of the first-harmonic fit. Their ratio to the first harmonic is the same at
every pixel of a matte surface, so the whole capture measures it precisely.

The model closes the gap: a power-law response ``r = x ** gamma`` fixes every ``c_m / c_1``, so
the measured ``c_2 / c_1`` gives ``gamma`` (Hoang et al. 2010), and the phase-error table of that
response (:func:`fringe3d.radiometry.phase_error.lut_from_response`, Zhang & Yau 2007) corrects
the ripple. With N = 3 no bin is free and :func:`estimate_gamma` raises.

References
----------
B. Pan, Q. Kemao, L. Huang and A. Asundi, "Phase error analysis and compensation for
nonsinusoidal waveforms in phase-shifting digital fringe projection profilometry",
Opt. Lett. 34(4), 416-418 (2009).
T. Hoang, B. Pan, D. Nguyen and Z. Wang, "Generic gamma correction for accuracy enhancement in
fringe-projection profilometry", Opt. Lett. 35(12), 1992-1994 (2010).
S. Zhang and S.-T. Yau, Appl. Opt. 46(1), 36-43 (2007).
"""
from __future__ import annotations

import functools
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ._harmonic_kernel import harmonic_ratio_pass
from .phase_error import PhaseErrorLUT, lut_from_response
from .response import power_law

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

GAMMA_RANGE = (0.2, 8.0)


class HarmonicEstimate(NamedTuple):
    """What the residual bins of an N-step capture say about the projector.

    Attributes
    ----------
    steps : int
        N.
    ratio : float
        Second-to-first harmonic ratio ``c_2 / c_1`` (0 for a linear projector).
    ratio_sigma : float
        Its standard error from the spread over pixels.
    gamma : float
        The power-law gamma with that ratio.
    pixels : int
        Pixels used.
    """

    steps: int
    ratio: float
    ratio_sigma: float
    gamma: float
    pixels: int


def harmonic_ratio(gamma: float, order: int = 2, samples: int = 4096) -> float:
    """``c_order / c_1`` of ``(1/2 (1 + cos t)) ** gamma`` (numerical Fourier series)."""
    t = 2.0 * np.pi * np.arange(samples) / samples
    spec = np.fft.rfft((0.5 * (1.0 + np.cos(t))) ** gamma)
    return float(spec[order].real / spec[1].real)


def observed_ratio(gamma: float, steps: int, samples: int = 512) -> float:
    """The ratio :func:`estimate_gamma` measures on an ideal N-step capture of ``x ** gamma``.

    Equals :func:`harmonic_ratio` up to the higher harmonics folding onto bin 2 and the ripple
    of the phase used to rotate it; matching this instead removes both biases.
    """
    return float(_observed_ratios(np.array([gamma], float), steps, samples)[0])


def gamma_from_ratio(ratio: float, steps: int) -> float:
    """The gamma whose observed ratio (:func:`observed_ratio`) is ``ratio``, clipped to ``GAMMA_RANGE``.

    A cubic spline of ``log gamma`` against the observed ratio on ``TABLE_SIZE`` gammas (built
    once per ``steps``, :func:`_ratio_table`; the ratio rises with gamma) gives a first guess,
    and one secant step on two exact evaluations (:func:`_observed_ratios`, vectorised)
    polishes it: within ``1e-8`` of the root for N = 4 .. 12, well below the ``1e-6`` tolerance
    a root search would be run to.
    """
    if not np.isfinite(ratio):
        raise ValueError(f"the harmonic ratio must be a finite number, got {ratio}")
    gammas, ratios, spline = _ratio_table(int(steps))
    if ratio <= ratios[0]:
        return float(gammas[0])
    if ratio >= ratios[-1]:
        return float(gammas[-1])
    u = float(spline(ratio))                                   # log gamma, first guess
    pair = np.array([u, u + 1e-4])
    r0, r1 = _observed_ratios(np.exp(pair), int(steps))
    if r1 != r0:
        u += (ratio - r0) * 1e-4 / (r1 - r0)
    return float(min(max(np.exp(u), gammas[0]), gammas[-1]))


#: Gammas in the table :func:`gamma_from_ratio` starts from (geometric over ``GAMMA_RANGE``).
TABLE_SIZE = 64


def _observed_ratios(gammas: np.ndarray, steps: int, samples: int = 512) -> np.ndarray:
    """:func:`observed_ratio` of each of ``gammas`` (G,) in one vectorised evaluation, (G,) float64."""
    x, cos_ang, sin_ang = _ideal_capture(int(steps), int(samples))
    frames = x[None] ** np.asarray(gammas, float)[:, None, None]          # (G, N, S)
    s = (np.einsum("mk,gks->gms", cos_ang, frames)
         - 1j * np.einsum("mk,gks->gms", sin_ang, frames)) / steps       # (G, 2, S) bins 1 and 2
    s1 = s[:, 0]
    amp = np.abs(s1)
    rot = (np.conj(s1) / amp) ** 2
    if steps == 4:
        y = s[:, 1].real
        model = 2.0 * amp * np.real(1.0 / rot)
        return np.sum(model * y, axis=1) / np.sum(model ** 2, axis=1)
    return np.sum(amp * np.real(s[:, 1] * rot), axis=1) / np.sum(amp ** 2, axis=1)


@functools.lru_cache(maxsize=16)
def _ideal_capture(steps: int, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What :func:`_observed_ratios` evaluates for every gamma (cached per ``steps`` and
    ``samples``, read-only): the (N, S) linear pattern values ``1/2 (1 + cos(phi + 2 pi k / N))``
    on ``S`` phases and the (2, N) DFT weights ``cos``, ``sin`` of bins 1 and 2."""
    phi = 2.0 * np.pi * np.arange(samples) / samples
    d = 2.0 * np.pi * np.arange(steps) / steps
    x = 0.5 * (1.0 + np.cos(phi[None, :] + d[:, None]))                 # (N, S)
    ang = 2.0 * np.pi * np.outer([1, 2], np.arange(steps)) / steps
    out = (x, np.cos(ang), np.sin(ang))
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=8)
def _ratio_table(steps: int) -> tuple[np.ndarray, np.ndarray, CubicSpline]:
    """The gammas, their observed ratios (increasing) and the spline of ``log gamma`` against the
    ratio that :func:`gamma_from_ratio` reads, for an N-step set (N >= 3; cached). scipy's
    interpolation module is imported here, on first use, not with the package."""
    from scipy.interpolate import CubicSpline
    gammas = np.geomspace(*GAMMA_RANGE, TABLE_SIZE)
    ratios = _observed_ratios(gammas, steps)
    if not np.all(np.diff(ratios) > 0):  # pragma: no cover - a property of the model, checked by the tests
        raise ArithmeticError(f"the observed harmonic ratio of a {steps}-step set is not monotone in gamma")
    return gammas, ratios, CubicSpline(ratios, np.log(gammas))


def estimate_gamma(frames, mask=None, min_modulation: float = 0.0) -> HarmonicEstimate:
    """Estimate the projector's gamma from one equally shifted N-step set (N >= 4).

    Parameters
    ----------
    frames : (N, H, W)
        Frames ``I_k = a + b r(1/2 (1 + cos(phi + 2 pi k / N)))`` (Eq. 2.2-2.3 with a response).
    mask : (H, W) bool, optional
        Pixels to use (default all).
    min_modulation : float
        Pixels whose first-bin magnitude is below this (frame units) are left out.

    Returns
    -------
    HarmonicEstimate

    Raises
    ------
    ValueError
        N < 4 (the second harmonic folds onto the first), or no usable pixel.
    """
    f = np.asarray(frames)
    if f.ndim != 3:
        raise ValueError(f"frames must be an (N, H, W) stack, got shape {f.shape}")
    n = f.shape[0]
    if n < 4:
        raise ValueError(f"a {n}-step set holds no harmonic of its own (needs N >= 4 equal steps); "
                         "measure the response with a grey ramp instead")
    ratio, sigma, pixels = harmonic_ratio_pass(f, np.ones(f.shape[1:], bool) if mask is None else mask,
                                               max(min_modulation, 1e-12))
    if pixels == 0:
        raise ValueError("no pixel with fringe modulation to estimate the harmonics from")
    return HarmonicEstimate(n, ratio, sigma, gamma_from_ratio(ratio, n), pixels)


def harmonic_lut(frames, mask=None, bins: int = 256) -> tuple[PhaseErrorLUT, HarmonicEstimate]:
    """The phase-error table of the gamma estimated from the capture itself (N >= 4).

    Parameters
    ----------
    frames : (N, H, W)
        One equally shifted N-step set, N >= 4 (:func:`estimate_gamma`).
    mask : (H, W) bool, optional
        Pixels to use (default all).
    bins : int
        Table size (phases per period).

    Returns
    -------
    lut : PhaseErrorLUT
        The phase error of ``r = x ** gamma`` for this set (:func:`lut_from_response`).
    estimate : HarmonicEstimate
        The gamma estimate it was built from.
    """
    est = estimate_gamma(frames, mask)
    return lut_from_response(power_law(est.gamma), steps=est.steps, bins=bins), est
