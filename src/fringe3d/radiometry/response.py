"""Projector -> camera response as a monotone look-up table, its inverse, and linearised frames.

A camera looking at a matte surface lit by the projector sees ``I = a + b * r(x)`` at each pixel,
with ``x = L / 255`` the projector input, ``r`` the projector's response normalised so that
``r(0) = 0`` and ``r(1) = 1``, and ``a``, ``b`` the pixel's ambient and gain (albedo,
irradiance). ``r`` is the same at every pixel, so a grey ramp on a flat target measures it
(:func:`fit_response`, reusing :func:`fringe3d.patterns.gamma.normalised_response`). A power law
``r = x ** gamma`` (:mod:`fringe3d.patterns.gamma`) is one such curve; the table also describes
knees, toes and clipping that a single gamma cannot.

Captures already taken are corrected by :func:`linearise_frames`: per pixel, the affine
``a``, ``b`` are fitted from the current phase estimate, every frame is mapped through
``r^-1((I - a) / b)`` to the pattern value the projector was asked for, and the phase is
recomputed (a fixed-point iteration). This is the "inverse gamma applied to the captured
images" correction of the nonsinusoidal-fringe literature, generalised to a table.

References
----------
S. Zhang and S.-T. Yau, "Generic nonsinusoidal phase error correction for three-dimensional
shape measurement using a digital video projector", Appl. Opt. 46(1), 36-43 (2007).
"""
from __future__ import annotations

import functools
import os
from typing import NamedTuple

import numpy as np

from fringe3d.patterns.gamma import GAMMA_FORMAT, normalised_response
from fringe3d.phase.psp import default_shifts, wrapped_phase
from fringe3d.utils.jsonfile import read_json


class ResponseLUT(NamedTuple):
    """A monotone projector response on a grid of inputs.

    Attributes
    ----------
    inputs : (M,) float64
        Projector input ``x = L / 255`` in [0, 1], increasing, first 0 and last 1.
    response : (M,) float64
        Normalised camera response ``r(x)`` in [0, 1], non-decreasing, ``r(0) = 0``, ``r(1) = 1``.
    """

    inputs: np.ndarray
    response: np.ndarray

    def apply(self, x) -> np.ndarray:
        """``r(x)`` by linear interpolation; ``x`` any shape, clipped to [0, 1]."""
        return np.interp(np.clip(np.asarray(x, float), 0.0, 1.0), self.inputs, self.response)

    def invert(self, r) -> np.ndarray:
        """``x = r^-1(r)`` by linear interpolation of the table read backwards, clipped to [0, 1].

        Flat runs of the table (a clipped toe or shoulder) map to their first input.
        """
        y, keep = np.unique(self.response, return_index=True)
        return np.interp(np.clip(np.asarray(r, float), 0.0, 1.0), y, self.inputs[keep])


def predistort(intensity, response: ResponseLUT) -> np.ndarray:
    """8-bit projector levels that make a projector of ``response`` show ``intensity``.

    ``round(255 r^-1(P))`` for desired intensities ``P`` in [0, 1] (any shape): the table
    generalisation of :func:`fringe3d.patterns.gamma.precompensate` (``P ** (1 / gamma)``).

    Parameters
    ----------
    intensity : array_like of float
        Desired projected intensities, fractions of full scale in [0, 1], any shape.
    response : ResponseLUT
        The projector's measured response (projector level fraction -> light fraction).

    Returns
    -------
    numpy.ndarray
        uint8 projector levels, same shape as ``intensity``.
    """
    return np.rint(255.0 * response.invert(intensity)).astype(np.uint8)


def power_law(gamma: float, size: int = 256) -> ResponseLUT:
    """The response table of ``r = x ** gamma`` on ``size`` equally spaced inputs.

    Parameters
    ----------
    gamma : float
        The exponent.
    size : int
        Number of table entries over [0, 1].

    Returns
    -------
    ResponseLUT
        The table."""
    if not gamma > 0:
        raise ValueError(f"gamma must be positive, got {gamma}")
    x = _unit_grid(int(size)).copy()  # the caller's own inputs (a copy costs less than np.linspace)
    return ResponseLUT(x, x ** gamma)


@functools.lru_cache(maxsize=8)
def _unit_grid(size: int) -> np.ndarray:
    """``np.linspace(0.0, 1.0, size)``, read-only and cached per size (the decoder's diagnostic
    builds a power-law table per direction and cycle)."""
    x = np.linspace(0.0, 1.0, size)
    x.flags.writeable = False
    return x


def monotone(values) -> np.ndarray:
    """The least-squares non-decreasing fit of ``values`` (pool-adjacent-violators), (M,) float64."""
    v = np.asarray(values, float).ravel()
    means: list[float] = []
    counts: list[int] = []
    for x in v:
        means.append(float(x))
        counts.append(1)
        while len(means) > 1 and means[-2] > means[-1]:
            n = counts[-2] + counts[-1]
            means[-2] = (means[-2] * counts[-2] + means[-1] * counts[-1]) / n
            counts[-2] = n
            means.pop()
            counts.pop()
    return np.repeat(means, counts)


def fit_response(levels, frames, full_scale: float | None = None, min_contrast: float = 0.1) -> ResponseLUT:
    """Measure the response table from a grey ramp on a flat, matte target.

    Parameters
    ----------
    levels : (L,) int
        Projector grey levels shown (0-255), including 0 and 255, in any order.
    frames : (L, H, W)
        One camera frame per level.
    full_scale, min_contrast
        Pixel selection, as in :func:`fringe3d.patterns.gamma.normalised_response`.

    Returns
    -------
    ResponseLUT
        On the measured levels (sorted), made non-decreasing (:func:`monotone`) and pinned to
        ``r(0) = 0``, ``r(1) = 1``.

    Raises
    ------
    ValueError
        Levels without black or white, one frame per level not given, or too few usable pixels.
    """
    levels = np.asarray(levels)
    r, _ = normalised_response(levels, frames, full_scale, min_contrast)
    order = np.argsort(levels, kind="stable")
    x = levels[order].astype(float) / 255.0
    x, first = np.unique(x, return_index=True)
    y = np.clip(monotone(r[order][first]), 0.0, 1.0)
    y[0], y[-1] = 0.0, 1.0
    return ResponseLUT(x, y)


def load_response(path: str | os.PathLike) -> ResponseLUT:
    """The measured response table of a ``gamma.json`` (``fringe3d capture --gamma``).

    Its ``levels`` and ``response`` (mean normalised camera response per grey level) become a
    :class:`ResponseLUT` as in :func:`fit_response`.

    Parameters
    ----------
    path : str or PathLike
        The ``gamma.json`` file.

    Returns
    -------
    ResponseLUT
        The measured response.

    Raises
    ------
    ValueError
        Naming the file and field, when it is not a gamma file or the table is unusable.
    """
    d = read_json(path, "projector gamma file")
    if d.get("format") != GAMMA_FORMAT:
        raise ValueError(f"{path} is not a projector gamma file (format {d.get('format')!r}, expected "
                         f"{GAMMA_FORMAT!r}); write one with `save_gamma`")
    try:
        levels = np.asarray(d["levels"], float)
        r = np.asarray(d["response"], float)
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{path}: 'levels' and 'response' must be lists of numbers ({e})") from None
    if levels.ndim != 1 or levels.shape != r.shape or 0 not in levels or 255 not in levels \
            or not np.all(np.isfinite(r)):
        raise ValueError(f"{path}: 'levels' (0..255, with 0 and 255) and 'response' must be lists of the same "
                         f"length of finite numbers; got {levels.size} levels and {r.size} responses")
    order = np.argsort(levels, kind="stable")
    x, first = np.unique(levels[order] / 255.0, return_index=True)
    y = np.clip(monotone(r[order][first]), 0.0, 1.0)
    y[0], y[-1] = 0.0, 1.0
    return ResponseLUT(x, y)


def _affine_fit(frames: np.ndarray, model: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel least squares ``frames ≈ a + b * model`` over the first axis; (H, W) each."""
    mm = model.mean(axis=0)
    fm = frames.mean(axis=0)
    dm = model - mm
    var = (dm * dm).sum(axis=0)
    b = (dm * (frames - fm)).sum(axis=0) / np.where(var > 0, var, np.inf)
    return fm - b * mm, b


def _check_set(frames, shifts) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(frames, float)
    if f.ndim != 3 or f.shape[0] < 3:
        raise ValueError(f"frames must be an (N, H, W) stack with N >= 3, got shape {f.shape}")
    d = default_shifts(f.shape[0]) if shifts is None else np.asarray(shifts, float)
    if d.size != f.shape[0]:
        raise ValueError(f"got {d.size} shifts for {f.shape[0]} frames; expected one shift per frame")
    return f, d


def response_phase(frames, response: ResponseLUT, shifts=None, iterations: int = 6):
    """Wrapped phase of a phase-shifted set taken through a known projector response.

    Per pixel, least squares of ``I_k = a + b r(1/2 (1 + cos(phi + delta_k)))`` (Eq. 2.2-2.3 with
    the response) over ``a``, ``b`` (linear, solved exactly) and ``phi`` (Gauss-Newton steps from
    the N-step phase of Eq. 2.4). Exact for noiseless frames whatever ``r``.

    Parameters
    ----------
    frames : (N, H, W)
        One phase-shifted set.
    response : ResponseLUT
        The projector's measured response (:func:`fit_response`).
    shifts : (N,) float, optional
        ``delta_k`` in rad; default ``2 pi k / N``.
    iterations : int
        Gauss-Newton steps.

    Returns
    -------
    phase : (H, W) float32
        rad in (-pi, pi].
    a, b : (H, W) float64
        Per-pixel offset and gain (frame units).
    """
    f, d = _check_set(frames, shifts)
    phi = wrapped_phase(f.astype(np.float32), shifts=d).phase.astype(float)
    slope = np.gradient(response.response, response.inputs)
    dd = d[:, None, None]
    a = b = np.zeros(phi.shape)
    for _ in range(max(1, iterations)):
        p = 0.5 * (1.0 + np.cos(phi[None] + dd))
        model = response.apply(p)
        a, b = _affine_fit(f, model)
        jac = -0.5 * b * np.interp(p, response.inputs, slope) * np.sin(phi[None] + dd)
        resid = f - a - b * model
        den = (jac * jac).sum(axis=0)
        step = (jac * resid).sum(axis=0) / np.where(den > 0, den, np.inf)
        phi = phi + np.clip(step, -0.5, 0.5)
    return (np.mod(phi + np.pi, 2 * np.pi) - np.pi).astype(np.float32), a, b


def linearise_frames(frames, response: ResponseLUT, shifts=None, iterations: int = 6) -> np.ndarray:
    """Map phase-shifted frames back to the pattern values the projector was asked for.

    ``r^-1((I - a) / b)`` with the per-pixel ``a``, ``b`` of :func:`response_phase`. Their N-step
    phase (Eq. 2.4) is free of the response's phase error, and other frames of the same capture
    (code frames, texture) can be linearised with the same ``a``, ``b``.

    Parameters
    ----------
    frames : (N, H, W)
        One phase-shifted set.
    response : ResponseLUT
        The projector's measured response (:func:`fit_response`).
    shifts : (N,) float, optional
        ``delta_k`` in rad; default ``2 pi k / N``.
    iterations : int
        Gauss-Newton steps of :func:`response_phase`.

    Returns
    -------
    (N, H, W) float32
        The pattern values in [0, 1].
    """
    f, d = _check_set(frames, shifts)
    _, a, b = response_phase(f, response, d, iterations)
    return response.invert((f - a) / np.where(b > 0, b, np.inf)).astype(np.float32)
