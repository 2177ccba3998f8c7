"""Render settings: everything between the projector's DMD and the camera's pixel values.

One frozen dataclass, :class:`RenderSettings`, validated on construction so a nonsensical
frame rate, exposure or bit depth fails with a clear message before any rendering.

Photometric model (per camera pixel, intensities in units of the camera's full scale):

``I = gain * (exposure * frame_rate) * albedo * (ambient + brightness * cos(theta) * P**gamma)``

with ``P`` in [0, 1] the (defocused) projector pattern value, ``theta`` the angle between the
surface normal and the direction to the projector centre (Lambertian), ``P = 0`` in projector
shadow or outside the projector's image. Then optional camera blur, shot noise (Poisson on
``I * full_well`` electrons), read noise (Gaussian, sigma in full-scale units), and
quantisation to ``bit_depth`` bits with saturation (``bit_depth=None`` keeps float32).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from fringe3d.optics.defocus import MODELS

BIT_DEPTHS = (8, 10, 12, 16)
NOISE_MODELS = ("simple", "emva")


@dataclass(frozen=True)
class RenderSettings:
    """Settings of the virtual rig's photometry and timing.

    Attributes
    ----------
    ideal : bool
        Evaluate phase-shifted sinusoids analytically at the exact projector coordinate
        (``patterns.render.sinusoid_value``) instead of sampling the pixelated, defocused
        projector image. Non-sinusoid frames still use the projector image.
    defocus : str
        ``"none"``, ``"gaussian"`` or ``"hopkins"`` (see :mod:`fringe3d.optics.defocus`).
    defocus_size : float
        Gaussian sigma or Hopkins omega/lambda, projector pixels, at the focal plane.
    focus_distance : float | None
        Projector focal-plane distance (mm, along the projector axis); ``None`` = uniform blur.
    defocus_growth : float
        Extra defocus size per mm away from the focal plane (pixels/mm).
    gamma : float
        Projector gamma (output = input ** gamma); 1 = linear.
    response : tuple of float | None
        Projector response table (a knee, a toe, a measured curve): output at equally spaced
        inputs 0..1, non-decreasing, in [0, 1]; interpolated linearly. Replaces ``gamma`` when set.
    ambient : float
        Ambient light (full-scale units, before albedo).
    brightness : float
        Projector white on an albedo-1 surface at normal incidence (full-scale units).
    gain : float
        Camera gain (multiplies the signal).
    frame_rate : float
        Frames per second (Hz); frame k is captured at time ``k / frame_rate`` (s).
    exposure : float | None
        Exposure time (s), 0 < exposure <= 1/frame_rate; ``None`` = the full frame period.
    motion_samples : int
        Sub-frame samples averaged over the exposure of a moving scene (motion blur); 1 = none.
    shot_noise : bool
        Poisson photon noise with ``full_well`` electrons at full scale.
    full_well : float
        Electrons at full scale.
    read_noise : float
        Gaussian read noise sigma (full-scale units, e.g. 0.01 = 1%).
    bit_depth : int | None
        8, 10, 12 or 16 (uint8 / uint16 frames with saturation), or ``None`` for float32.
    camera_blur : float
        Gaussian camera blur sigma (camera pixels); 0 = none.
    noise_model : str
        ``"simple"`` (the default: ``shot_noise``, ``read_noise`` in full-scale units) or ``"emva"``:
        the EMVA 1288 linear camera model (:func:`fringe3d.sim.noise.sense_emva`): ``full_well``
        electrons at full-scale irradiance (the well clips there), Poisson shot noise always,
        ``read_noise_e`` electrons of dark noise, ``gain_dn_per_e`` DN per electron, a
        ``dark_offset_dn`` offset, quantisation to ``bit_depth`` bits (required).
    read_noise_e : float
        EMVA dark (read) noise sigma, electrons.
    gain_dn_per_e : float | None
        EMVA overall system gain K (DN/e-); ``None`` = ``(2**bit_depth - 1) / full_well`` (the ADC's
        top at the full well).
    dark_offset_dn : float
        EMVA dark offset (DN) added before quantisation.
    shadows : bool
        Cast shadow rays toward the projector (projector occlusion).
    seed : int
        Seed of the noise generator (same seed, same frames).
    """

    ideal: bool = False
    defocus: str = "none"
    defocus_size: float = 0.0
    focus_distance: float | None = None
    defocus_growth: float = 0.0
    gamma: float = 1.0
    response: tuple[float, ...] | None = None
    ambient: float = 0.05
    brightness: float = 0.8
    gain: float = 1.0
    frame_rate: float = 100.0
    exposure: float | None = None
    motion_samples: int = 1
    shot_noise: bool = False
    full_well: float = 10000.0
    read_noise: float = 0.0
    bit_depth: int | None = 8
    camera_blur: float = 0.0
    noise_model: str = "simple"
    read_noise_e: float = 0.0
    gain_dn_per_e: float | None = None
    dark_offset_dn: float = 0.0
    shadows: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        if self.defocus not in MODELS:
            raise ValueError(f"unknown defocus model {self.defocus!r}; expected one of {MODELS}")
        _finite_nonneg("defocus_size (pixels)", self.defocus_size)
        _finite_nonneg("defocus_growth (pixels/mm)", self.defocus_growth)
        if not (math.isfinite(self.gamma) and self.gamma > 0):
            raise ValueError(f"projector gamma must be a positive number, got {self.gamma}")
        if self.response is not None:
            object.__setattr__(self, "response", _response_table(self.response))
        for name in ("ambient", "brightness", "gain", "read_noise", "camera_blur"):
            _finite_nonneg(name, getattr(self, name))
        if not (math.isfinite(self.frame_rate) and self.frame_rate > 0):
            raise ValueError(f"frame rate must be a positive number of frames per second (Hz), got {self.frame_rate}")
        if self.frame_rate > 1e6:
            raise ValueError(f"frame rate {self.frame_rate:g} Hz is beyond any camera; expected <= 1e6 Hz")
        if self.exposure is not None:
            if not (math.isfinite(self.exposure) and self.exposure > 0):
                raise ValueError(f"exposure must be a positive time in seconds, got {self.exposure}")
            if self.exposure > 1.0 / self.frame_rate * (1 + 1e-9):
                raise ValueError(f"exposure {self.exposure:g} s is longer than the frame period "
                                 f"1/{self.frame_rate:g} Hz = {1 / self.frame_rate:g} s")
        if self.motion_samples < 1:
            raise ValueError(f"motion_samples must be >= 1, got {self.motion_samples}")
        if not (self.full_well > 0):
            raise ValueError(f"full_well must be a positive number of electrons, got {self.full_well}")
        if self.bit_depth is not None and self.bit_depth not in BIT_DEPTHS:
            raise ValueError(f"bit_depth must be one of {BIT_DEPTHS} or None (float32), got {self.bit_depth}")
        self._check_emva()

    def _check_emva(self) -> None:
        if self.noise_model not in NOISE_MODELS:
            raise ValueError(f"noise_model must be one of {NOISE_MODELS}, got {self.noise_model!r}")
        for name in ("read_noise_e", "dark_offset_dn"):
            _finite_nonneg(name, getattr(self, name))
        if self.gain_dn_per_e is not None and not (math.isfinite(self.gain_dn_per_e) and self.gain_dn_per_e > 0):
            raise ValueError(f"gain_dn_per_e must be a positive number of DN per electron, got {self.gain_dn_per_e!r}")
        if self.noise_model == "emva" and self.bit_depth is None:
            raise ValueError("noise_model 'emva' models a digital camera: set bit_depth (8, 10, 12 or 16)")

    @property
    def system_gain(self) -> float:
        """EMVA system gain K (DN/e-): ``gain_dn_per_e`` or ``(2**bit_depth - 1) / full_well``."""
        if self.gain_dn_per_e is not None:
            return float(self.gain_dn_per_e)
        return (2.0 ** (self.bit_depth or 16) - 1.0) / self.full_well

    @property
    def exposure_fraction(self) -> float:
        """Exposure as a fraction of the frame period (1 when ``exposure`` is None)."""
        return 1.0 if self.exposure is None else self.exposure * self.frame_rate

    @property
    def noiseless(self) -> bool:
        return self.noise_model == "simple" and not self.shot_noise and self.read_noise == 0

    def replace(self, **changes) -> RenderSettings:
        """A copy with some fields changed (validated)."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f"unknown render setting(s) {sorted(unknown)}; "
                             f"valid: {sorted(f.name for f in fields(self))}")
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> RenderSettings:
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ValueError(f"render settings: unknown field(s) {unknown}; valid: {sorted(names)}")
        return cls(**d)


def _response_table(values) -> tuple[float, ...]:
    r = np.asarray(values, dtype=float).ravel()
    if r.size < 2 or not np.all(np.isfinite(r)) or r.min() < 0 or r.max() > 1 or np.any(np.diff(r) < 0):
        raise ValueError(f"projector response must be >= 2 non-decreasing values in [0, 1] "
                         f"(output at equally spaced inputs 0..1), got {np.round(r, 4).tolist()}")
    return tuple(r.tolist())


def _finite_nonneg(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


@dataclass(frozen=True)
class RenderChanges:
    """Changes to a preset's render settings for one simulated capture
    (:func:`fringe3d.sim.simulate.simulate_capture`); ``None`` keeps the preset's value.

    Attributes
    ----------
    settings : RenderSettings | None
        Replace the preset's settings entirely (the changes below still apply).
    frame_rate : float | None
        Frames per second (Hz).
    exposure : float | None
        Exposure time (s), at most ``1 / frame_rate``.
    noise : float | None
        Read-noise sigma (full-scale units, :attr:`RenderSettings.read_noise`).
    defocus : float | None
        Projector defocus size (projector pixels); a preset without defocus blurs with the
        Gaussian model.
    bit_depth : int | None
        8, 10, 12 or 16 bits; ``None`` writes float32 TIFF frames; ``0`` keeps the preset's.
    exposures : tuple of float | None
        An exposure bracket (s, each at most ``1 / frame_rate``; shortest first): one pattern
        cycle per exposure (:func:`fringe3d.sim.bracket.render_bracket`'s seeds). Static
        scenes, one cycle.
    others : dict
        Any other :class:`RenderSettings` field (applied before the named changes above).
    """

    settings: RenderSettings | None = None
    frame_rate: float | None = None
    exposure: float | None = None
    noise: float | None = None
    defocus: float | None = None
    bit_depth: int | None = 0
    exposures: tuple[float, ...] | None = None
    others: dict = field(default_factory=dict)

    def applied_to(self, base: RenderSettings) -> RenderSettings:
        """``base`` (or :attr:`settings` when set) with these changes and ``others`` applied."""
        s = self.settings or base
        changes = dict(self.others)
        for key, val in (("frame_rate", self.frame_rate), ("exposure", self.exposure),
                         ("read_noise", self.noise), ("defocus_size", self.defocus)):
            if val is not None:
                changes[key] = val
        if self.defocus is not None and s.defocus == "none" and "defocus" not in changes:
            changes["defocus"] = "gaussian"
        if self.bit_depth != 0:
            changes["bit_depth"] = self.bit_depth
        return s.replace(**changes)
