"""Projector gamma: fit the projector -> camera response from a grey ramp, pre-compensate patterns.

A projector maps an input grey level ``x = L / 255`` to light ``x ** gamma`` (a power law is the
usual model; consumer projectors are close to 2.2). A camera looking at a matte surface sees
``I(L) = a + b * x ** gamma`` per pixel (ambient ``a``, albedo and irradiance in ``b``), so the
normalised response ``r(L) = (I(L) - I(0)) / (I(255) - I(0)) = x ** gamma`` is the same at every
pixel. :func:`fit_gamma` averages ``r`` over the well-lit, unsaturated pixels and fits ``gamma``
by least squares; :func:`precompensate` maps a desired intensity ``P`` in [0, 1] to the 8-bit
level ``round(255 * P ** (1 / gamma))``, so the projector emits ``≈ P``: phase-shifted sinusoids
stay sinusoidal and the gamma-induced phase error (harmonics, Eq. 2.4's assumption) goes away.

``gamma.json``: ``{"format": "fringe3d-projector-gamma", "version": 1, "gamma": ..., "levels": [...],
"response": [...], "rms_residual": ..., "pixels": ...}``.
"""
from __future__ import annotations

import math
import os

import numpy as np

from fringe3d.utils.jsonfile import read_json, write_json

GAMMA_FORMAT = "fringe3d-projector-gamma"


def normalised_response(levels, frames, full_scale: float | None = None, min_contrast: float = 0.1):
    """Mean normalised response per level and the number of pixels used.

    Parameters
    ----------
    levels : (L,) uint8 grey levels including 0 and 255
    frames : (L, H, W) camera frames (any numeric dtype)
    full_scale : camera full scale (e.g. 255); pixels reaching 98% of it at white are excluded
    min_contrast : pixels whose white - black is below this fraction of the largest are excluded
    """
    levels = np.asarray(levels)
    f = np.asarray(frames, float)
    if f.ndim != 3 or len(f) != len(levels):
        raise ValueError(f"need one (H, W) frame per level: {len(levels)} levels, frames of shape {f.shape}")
    if 0 not in levels or 255 not in levels:
        raise ValueError("the grey ramp must include black (0) and white (255)")
    black, white = f[int(np.flatnonzero(levels == 0)[0])], f[int(np.flatnonzero(levels == 255)[0])]
    span = white - black
    ok = span > min_contrast * span.max()
    if full_scale is not None:
        ok &= white < 0.98 * full_scale
    n = int(ok.sum())
    if n < 10:
        raise ValueError(f"only {n} camera pixels see the projector with enough contrast and no saturation; "
                         f"point the camera at a matte surface lit by the projector and check the exposure")
    r = (f[:, ok] - black[ok]) / span[ok]
    return r.mean(axis=1), n


def fit_gamma(levels, frames, full_scale: float | None = None, min_contrast: float = 0.1) -> dict:
    """Fit ``r(L) = (L / 255) ** gamma`` to a grey-ramp capture; see the module docstring.

    Returns a dict: gamma, levels, response, rms_residual, pixels (the gamma.json contents).
    """
    levels = np.asarray(levels)
    r, n = normalised_response(levels, frames, full_scale, min_contrast)
    x = levels.astype(float) / 255.0
    use = (x > 0) & (x < 1)

    def cost(g):
        return float(np.sum((x[use] ** g - r[use]) ** 2))

    from scipy.optimize import minimize_scalar  # heavy (0.5 s): loaded only when a gamma is fitted

    res = minimize_scalar(cost, bounds=(0.1, 10.0), method="bounded", options={"xatol": 1e-8})
    g = float(res.x)
    rms = math.sqrt(cost(g) / max(1, int(use.sum())))
    return {"format": GAMMA_FORMAT, "version": 1, "gamma": g, "levels": levels.tolist(), "response": r.tolist(),
            "rms_residual": rms, "pixels": n}


def save_gamma(path: str | os.PathLike, fit: dict) -> None:
    write_json(path, fit, units={"levels": "projector grey level (0-255)", "response": "fraction of camera full scale",
                                 "rms_residual": "fraction of camera full scale", "gamma": "1"})


def load_gamma(path: str | os.PathLike) -> float:
    """The gamma of a ``gamma.json`` file (``ValueError`` when it is not one)."""
    d = read_json(path, "projector gamma file")
    if d.get("format") != GAMMA_FORMAT:
        raise ValueError(f"{path} is not a projector gamma file "
                         f"(format {d.get('format')!r}, expected {GAMMA_FORMAT!r}); "
                         f"write one with `save_gamma`")
    g = d.get("gamma")
    if not (isinstance(g, (int, float)) and math.isfinite(g) and g > 0):
        raise ValueError(f"{path}: gamma must be a positive number, got {g!r}")
    return float(g)


def precompensate(intensity: np.ndarray, gamma: float) -> np.ndarray:
    """8-bit levels ``round(255 * P ** (1 / gamma))`` for desired intensities ``P`` in [0, 1]."""
    if not gamma > 0:
        raise ValueError(f"gamma must be positive, got {gamma}")
    p = np.clip(np.asarray(intensity, float), 0.0, 1.0)
    return np.rint(255.0 * p ** (1.0 / gamma)).astype(np.uint8)
