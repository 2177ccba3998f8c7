"""Radiometry and exposure timing: from the projector's pattern value at a surface point to the
noise-free camera signal, and when each frame (and each motion sub-sample) is exposed.

Photometric model (:mod:`fringe3d.sim.settings`), per camera pixel in full-scale units:

``I = gain * (exposure * frame_rate) * (albedo * (ambient + brightness * cos(theta) * R(P))
+ brightness * S * R(P))``

with ``R(P) = P**gamma`` or the tabulated ``RenderSettings.response``, ``P`` the (defocused)
pattern value (:mod:`fringe3d.sim.projector_sampling`) and
``cos(theta)`` the Lambert cosine toward the projector centre, 0 in projector shadow or outside
its image (:class:`~fringe3d.sim.geometry.Geometry`), ``S`` the specular lobe of a glossy object
(:mod:`fringe3d.sim.specular`, 0 on matte ones). The sensor (blur, shot and read noise,
quantisation) follows in :func:`fringe3d.sim.noise.sense`.

>>> from fringe3d.sim.settings import RenderSettings
>>> frame_times(3, RenderSettings(frame_rate=100.0)).tolist()
[0.0, 0.01, 0.02]
>>> motion_subtimes(0.0, RenderSettings(frame_rate=100.0, motion_samples=2))
[0.0025, 0.0075]
"""
from __future__ import annotations

import numpy as np

from .geometry import Geometry
from .settings import RenderSettings


def frame_times(n_frames: int, settings: RenderSettings, start: float = 0.0) -> np.ndarray:
    """Capture time (s) of each frame, ``start + k / frame_rate``."""
    return start + np.arange(n_frames) / settings.frame_rate


def motion_subtimes(t: float, s: RenderSettings) -> list[float]:
    """Sample times (s) within frame ``t``'s exposure (only ``t`` itself when ``motion_samples=1``)."""
    if s.motion_samples <= 1:
        return [t]
    exp = s.exposure if s.exposure is not None else 1.0 / s.frame_rate
    return [t + (j + 0.5) / s.motion_samples * exp for j in range(s.motion_samples)]


def irradiance(geo: Geometry, pattern: np.ndarray, settings: RenderSettings,
               scene_ambient: float = 0.0) -> np.ndarray:
    """Noise-free camera signal (N,) (full-scale units) of each pixel of ``geo``.

    ``pattern`` (N,) is the pattern value before gamma. Ambient light is
    ``settings.ambient + scene_ambient * settings.brightness`` (a scene's ambient level is
    relative to the projector's full white).
    """
    s = settings
    # No clipping for gamma = 1: the FFT defocus model is band-limited, so a blurred binary
    # pattern can overshoot [0, 1] by a few percent (Gibbs) while its harmonics follow the OTF.
    if s.response is not None:
        table = np.asarray(s.response)
        shaped = np.interp(np.clip(pattern, 0.0, 1.0), np.linspace(0.0, 1.0, table.size), table)
    else:
        shaped = pattern if s.gamma == 1.0 else np.power(np.clip(pattern, 0.0, None), s.gamma)
    proj = s.brightness * geo.shade * shaped
    ambient = s.ambient + scene_ambient * s.brightness
    signal = geo.albedo * (ambient + proj)
    if geo.specular is not None:
        signal = signal + s.brightness * geo.specular * shaped
    return s.gain * s.exposure_fraction * signal * geo.hit
