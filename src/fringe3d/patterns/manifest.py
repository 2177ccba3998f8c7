"""The pattern manifest: what each projected frame is, in projection order.

A :class:`PatternSet` is written as ``manifest.json`` next to the pattern PNGs and copied
into every capture folder, so a capture explains itself: decoders read it to know which
frames are phase-shifted sinusoids (period, fringe angle, shift), which are binary code
bits, and how each fringe direction is to be unwrapped.

Conventions (Eq. 2.1-2.2; docs/architecture.md):

* A fringe pattern at angle ``alpha`` varies along ``w = i*cos(alpha) + j*sin(alpha)``
  (``i`` row, ``j`` column, pixel centres at integer coordinates), Eq. (2.1)-(2.2).
  ``alpha = 0`` gives horizontal stripes (phase encodes the projector row ``v_p``),
  ``alpha = pi/2`` vertical stripes (phase encodes the projector column ``u_p``).
* Intensity of a phase-shifted frame: ``I = 1/2 * (1 + cos(2*pi*w/T + shift))`` with
  ``shift = 2*pi*k/N`` for step ``k`` of ``N`` (3-step sets may use -2pi/3, 0, 2pi/3).
* Absolute phase ``Phi = 2*pi*w/T``, so the projector coordinate is ``w = Phi*T/(2*pi)``.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Iterable

from fringe3d.patterns.manifest_schema import ManifestModel
from fringe3d.patterns.method_registry import method_facts
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.provenance import PROVENANCE_KEY
from fringe3d.utils.schema import validate
from fringe3d.utils.warning_types import DataQualityWarning

MANIFEST_VERSION = 1
MANIFEST_NAME = "manifest.json"
#: Units of a manifest's fields (its ``provenance``).
MANIFEST_UNITS = {"width": "projector px", "height": "projector px", "period": "projector px",
                  "angle": "rad", "shift": "rad", "bit_depth": "bits"}

#: Frame kinds a manifest may hold.
FRAME_KINDS = (
    "sinusoid",          # 8-bit (or higher) sinusoid
    "square",            # squared binary: 1 where the sinusoid > 1/2 (binary defocusing)
    "bayer",             # Bayer ordered dithering of the sinusoid
    "floyd_steinberg",   # Floyd-Steinberg error diffusion of the sinusoid
    "area_modulated",    # area-modulated binary approximation of the sinusoid
    "pwm",               # pulse-width-modulated binary approximation
    "gray_code",         # Gray code stripe (bit ``bit`` of ``bits``)
    "binary_code",       # simple binary code stripe
    "white",             # all-on frame (texture, board image, code threshold)
    "black",             # all-off frame
)
#: What a frame is used for by the decoder.
FRAME_ROLES = ("phase", "code", "reference", "texture")


@dataclass(frozen=True)
class FrameSpec:
    """One projected frame.

    Attributes
    ----------
    kind : str
        One of :data:`FRAME_KINDS`.
    role : str
        One of :data:`FRAME_ROLES`.
    direction : str
        Name of the fringe direction the frame serves (``"v"`` vertical stripes -> ``u_p``,
        ``"h"`` horizontal stripes -> ``v_p``, or any label such as ``"a1"``), ``""`` for
        reference frames.
    angle : float
        Fringe angle alpha in radians, Eq. (2.1); 0 <= alpha < pi.
    period : float
        Fringe period T in projector pixels (phase frames), or the stripe period the code
        is meant to unwrap (code frames). 0 when not applicable.
    shift : float
        Phase shift delta in radians (phase frames).
    step, steps : int
        Index k and count N of the phase-shift step within its group.
    bit, bits : int
        Bit index (0 = most significant) and number of bits (code frames).
    inverse : bool
        True for the inverted copy of a code frame.
    group : str
        Label shared by all frames of one phase-shift set or code, e.g. ``"v/T18"``.
    """

    kind: str
    role: str = "phase"
    direction: str = ""
    angle: float = 0.0
    period: float = 0.0
    shift: float = 0.0
    step: int = 0
    steps: int = 0
    bit: int = 0
    bits: int = 0
    inverse: bool = False
    group: str = ""

    def __post_init__(self) -> None:
        if self.kind not in FRAME_KINDS:
            raise ValueError(f"unknown frame kind {self.kind!r}; expected one of {FRAME_KINDS}")
        if self.role not in FRAME_ROLES:
            raise ValueError(f"unknown frame role {self.role!r}; expected one of {FRAME_ROLES}")
        if not (0.0 <= self.angle < math.pi + 1e-12):
            raise ValueError(f"fringe angle must be in [0, pi) rad, got {self.angle}")
        if self.role == "phase" and not self.period > 0:
            raise ValueError(f"phase frame needs a positive period, got {self.period}")


@dataclass(frozen=True)
class DirectionPlan:
    """How one fringe direction is unwrapped.

    ``method`` is a registered unwrapping method
    (:func:`fringe3d.patterns.method_registry.method_names`); ``periods`` lists the phase groups' periods
    from the one to be unwrapped (narrowest, first) to the coarsest; ``options`` holds
    method-specific settings (JSON-serialisable).
    """

    direction: str
    angle: float
    method: str
    periods: tuple[float, ...] = ()
    options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        method_facts(self.method)  # ValueError naming the registered methods


@dataclass(frozen=True)
class PatternSet:
    """An ordered sequence of projector frames plus how to decode them.

    Attributes
    ----------
    width, height : int
        Projector resolution in pixels.
    frames : tuple[FrameSpec, ...]
        Frames in projection order.
    plans : tuple[DirectionPlan, ...]
        One unwrapping plan per fringe direction.
    bit_depth : int
        1 for binary (DLP 1-bit) output, 8 for 8-bit grey.
    name : str
        Free-form label (e.g. ``"three-frequency-18-21-144"``).
    """

    width: int
    height: int
    frames: tuple[FrameSpec, ...]
    plans: tuple[DirectionPlan, ...] = ()
    bit_depth: int = 8
    name: str = ""

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"projector size must be positive, got {self.width}x{self.height}")
        if self.bit_depth not in (1, 8):
            raise ValueError(f"bit_depth must be 1 or 8, got {self.bit_depth}")
        object.__setattr__(self, "frames", tuple(self.frames))
        object.__setattr__(self, "plans", tuple(self.plans))

    def __len__(self) -> int:
        return len(self.frames)

    # -- queries -----------------------------------------------------------------
    def directions(self) -> list[str]:
        """Fringe directions in order of first appearance."""
        seen: list[str] = []
        for f in self.frames:
            if f.direction and f.direction not in seen:
                seen.append(f.direction)
        return seen

    def plan(self, direction: str) -> DirectionPlan:
        """The unwrapping plan of ``direction`` (``KeyError`` when the manifest has none)."""
        for p in self.plans:
            if p.direction == direction:
                return p
        raise KeyError(f"manifest has no unwrapping plan for direction {direction!r}")

    def indices(self, **match: Any) -> list[int]:
        """Frame indices whose attributes equal every ``match`` item, e.g. ``group="v/T18"``."""
        return [i for i, f in enumerate(self.frames)
                if all(getattr(f, k) == v for k, v in match.items())]

    def groups(self, direction: str | None = None, role: str | None = None) -> list[str]:
        """Group labels in order of first appearance, optionally filtered."""
        out: list[str] = []
        for f in self.frames:
            if direction is not None and f.direction != direction:
                continue
            if role is not None and f.role != role:
                continue
            if f.group and f.group not in out:
                out.append(f.group)
        return out

    def unused_groups(self) -> list[str]:
        """Phase groups no plan decodes: those of a direction whose plan lists ``periods``
        without the group's period (a plan without ``periods`` uses all its direction's groups)."""
        out: list[str] = []
        for f in self.frames:
            if f.role != "phase" or not f.group or f.group in out:
                continue
            plan = next((p for p in self.plans if p.direction == f.direction), None)
            if plan is not None and plan.periods and not any(abs(f.period - t) <= 1e-9 * max(1.0, t)
                                                             for t in plan.periods):
                out.append(f.group)
        return out

    def concat(self, other: "PatternSet", name: str | None = None) -> "PatternSet":
        """Frames of ``self`` then ``other`` (same projector size)."""
        if (self.width, self.height) != (other.width, other.height):
            raise ValueError("cannot concatenate pattern sets of different projector sizes")
        return replace(self, frames=self.frames + other.frames, plans=self.plans + other.plans,
                       bit_depth=max(self.bit_depth, other.bit_depth),
                       name=name if name is not None else f"{self.name}+{other.name}")

    # -- JSON --------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The JSON form written as ``manifest.json`` (:meth:`from_dict` reads it back)."""
        return {
            "format": "fringe3d-pattern-manifest",
            "version": MANIFEST_VERSION,
            "name": self.name,
            "width": self.width,
            "height": self.height,
            "bit_depth": self.bit_depth,
            "frames": [asdict(f) for f in self.frames],
            "plans": [{**asdict(p), "periods": list(p.periods)} for p in self.plans],
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "manifest") -> "PatternSet":
        """Build from a parsed manifest, rejecting unknown or missing fields by name.

        The manifest is first validated against :class:`~fringe3d.patterns.manifest_schema.ManifestModel`
        (types, finiteness, bounded sizes, labels safe as file names); ``where`` names the file in errors.
        """
        if not isinstance(d, dict):
            raise ValueError(f"{where}: expected a JSON object, got {type(d).__name__}")
        validate(ManifestModel, d, where)
        # "packing": bit-plane packing of a pattern folder (patterns.bitplanes), not part of the set
        top = {"format", "version", "name", "width", "height", "bit_depth", "frames", "plans", "packing",
               PROVENANCE_KEY}
        _check_keys(d, top, required={"width", "height", "frames"}, where="manifest")
        if d.get("format", "fringe3d-pattern-manifest") != "fringe3d-pattern-manifest":
            raise ValueError(f"manifest: 'format' is {d['format']!r}, expected 'fringe3d-pattern-manifest'")
        if int(d.get("version", MANIFEST_VERSION)) > MANIFEST_VERSION:
            raise ValueError(f"manifest: version {d['version']} is newer than this fringe3d reads ({MANIFEST_VERSION})")
        fnames = {f.name for f in fields(FrameSpec)}
        pnames = {f.name for f in fields(DirectionPlan)}
        frames = []
        for i, fd in enumerate(d["frames"]):
            _check_keys(fd, fnames, required={"kind"}, where=f"{where} frame {i}")
            frames.append(_built(FrameSpec, fd, f"{where}: field frames[{i}]"))
        plans = []
        for i, pd in enumerate(d.get("plans", [])):
            _check_keys(pd, pnames, required={"direction", "angle", "method"}, where=f"{where} plan {i}")
            plans.append(_built(DirectionPlan, {**pd, "periods": tuple(pd.get("periods", ()))},
                                f"{where}: field plans[{i}]"))
        planned = {p.direction for p in plans}
        unplanned = sorted({f.direction for f in frames if f.role in ("phase", "code") and f.direction} - planned)
        if unplanned:
            raise ValueError(f"{where}: field plans: no unwrapping plan for direction(s) {unplanned}; every "
                             "direction with phase or code frames needs a plan (direction, angle, method)")
        ps = cls(width=int(d["width"]), height=int(d["height"]), frames=tuple(frames),
                 plans=tuple(plans), bit_depth=int(d.get("bit_depth", 8)), name=d.get("name", ""))
        unused = ps.unused_groups()
        if unused:
            warnings.warn(f"{where}: phase group(s) {unused} are used by no plan (their periods are not in "
                          "their direction's plan 'periods'); their frames are not decoded", DataQualityWarning,
                          stacklevel=2)
        return ps

    def save(self, path: str | os.PathLike) -> Path:
        """Write JSON atomically (temporary name, then rename). ``path`` may be a folder."""
        path = Path(path)
        if path.is_dir():
            path = path / MANIFEST_NAME
        write_json(path, self.to_dict(), units=MANIFEST_UNITS)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "PatternSet":
        """Read a manifest file (or ``manifest.json`` inside a folder)."""
        path = Path(path)
        if path.is_dir():
            path = path / MANIFEST_NAME
        return cls.from_dict(read_json(path, "pattern manifest"), where=f"manifest {path}")


def _built(kind, fields_: dict[str, Any], where: str):
    """``kind(**fields_)``, with the constructor's ValueError prefixed by ``where``."""
    try:
        return kind(**fields_)
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def _check_keys(d: dict[str, Any], allowed: Iterable[str], required: Iterable[str], where: str) -> None:
    allowed = set(allowed)
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {unknown}; allowed fields are {sorted(allowed)}")
    missing = sorted(set(required) - set(d))
    if missing:
        raise ValueError(f"{where}: missing required field(s) {missing}")
