"""Surface textures: albedo factors looked up in an object's material coordinates.

A texture is a callable ``texture(uv (N, 2) float) -> (N,) float`` in [0, 1] that multiplies the
object's base albedo. ``uv`` are the object's material coordinates (mm on planes, boards, meshes
and wings; radians (longitude, latitude) on spheres). Every texture also has ``to_dict()`` so that
scene files can store it; :func:`texture_from_dict` reads it back.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np


def _check_fields(obj, positive: tuple[str, ...], unit: tuple[str, ...] = ("contrast",)) -> None:
    """Refuse a texture whose ``positive`` fields are not finite and > 0 or whose ``unit`` fields
    are not in [0, 1] (a period of 0 would divide by zero at every pixel)."""
    name = type(obj).__name__.lower()
    for f in positive:
        v = getattr(obj, f)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} texture field {f}: expected a finite number > 0, got {v!r}")
    for f in unit:
        v = getattr(obj, f)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v <= 1:
            raise ValueError(f"{name} texture field {f}: expected a number in [0, 1], got {v!r}")


@dataclass(frozen=True)
class Checker:
    """Checkerboard of square cells of side ``period`` (material units); dark cells have
    factor ``1 - contrast``."""

    period: float = 10.0
    contrast: float = 0.5

    def __post_init__(self) -> None:
        _check_fields(self, ("period",))

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        cells = np.floor(uv[:, 0] / self.period) + np.floor(uv[:, 1] / self.period)
        odd = np.mod(cells, 2) == 1
        return np.where(odd, 1.0 - self.contrast, 1.0)

    def to_dict(self) -> dict:
        return {"type": "checker", **asdict(self)}


@dataclass(frozen=True)
class Stripes:
    """Smooth sinusoidal stripes along material ``u``: ``1 - contrast*(1+cos(2πu/period))/2``."""

    period: float = 10.0
    contrast: float = 0.5

    def __post_init__(self) -> None:
        _check_fields(self, ("period",))

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        return 1.0 - self.contrast * 0.5 * (1 + np.cos(2 * np.pi * uv[:, 0] / self.period))

    def to_dict(self) -> dict:
        return {"type": "stripes", **asdict(self)}


@dataclass(frozen=True)
class Blotches:
    """Smooth random-looking print: a seeded sum of ``n`` sinusoids in (u, v) with wavelengths
    around ``scale`` (material units), mapped to factors in ``[1 - contrast, 1]``."""

    scale: float = 20.0
    contrast: float = 0.4
    seed: int = 0
    n: int = 6

    def __post_init__(self) -> None:
        _check_fields(self, ("scale", "n"))
        if not isinstance(self.n, int) or self.n > 1000:
            raise ValueError(f"blotches texture field n: expected a whole number in [1, 1000], got {self.n!r}")

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        rng = np.random.default_rng(self.seed)
        ang = rng.uniform(0, np.pi, self.n)
        k = 2 * np.pi / (self.scale * rng.uniform(0.6, 1.6, self.n))
        ph = rng.uniform(0, 2 * np.pi, self.n)
        s = np.zeros(len(uv))
        for a, kk, p in zip(ang, k, ph):
            s += np.cos(kk * (uv[:, 0] * np.cos(a) + uv[:, 1] * np.sin(a)) + p)
        s = 0.5 * (1 + s / self.n)  # in [0, 1]
        return 1.0 - self.contrast * s

    def to_dict(self) -> dict:
        return {"type": "blotches", **asdict(self)}


@dataclass(frozen=True)
class Ramp:
    """Albedo from black to white along material ``u``: factor
    ``clip((u - start) / length, 0, 1) * contrast + 1 - contrast`` (``contrast`` 1: from 0 to 1),
    constant beyond the ramp's ends (material units)."""

    start: float = 0.0
    length: float = 50.0
    contrast: float = 1.0

    def __post_init__(self) -> None:
        _check_fields(self, ("length",))
        if isinstance(self.start, bool) or not isinstance(self.start, (int, float)) or not math.isfinite(self.start):
            raise ValueError(f"ramp texture field start: expected a finite number, got {self.start!r}")

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        return 1.0 - self.contrast + self.contrast * np.clip((uv[:, 0] - self.start) / self.length, 0.0, 1.0)

    def to_dict(self) -> dict:
        return {"type": "ramp", **asdict(self)}


TEXTURES = {"checker": Checker, "stripes": Stripes, "blotches": Blotches, "ramp": Ramp}


def texture_from_dict(d: dict | None, where: str = "texture"):
    """Build a texture from ``{"type": name, ...fields}``; ``None`` gives ``None``."""
    if d is None:
        return None
    if not isinstance(d, dict) or "type" not in d:
        raise ValueError(f"{where}: expected an object with a 'type' field, one of {sorted(TEXTURES)}")
    kind = d["type"]
    if kind not in TEXTURES:
        raise ValueError(f"{where}.type: unknown texture {kind!r}; expected one of {sorted(TEXTURES)}")
    fields = {k: v for k, v in d.items() if k != "type"}
    try:
        return TEXTURES[kind](**fields)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: bad field for texture {kind!r}: {e}") from None
