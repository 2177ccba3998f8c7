"""The manifest file's schema (``manifest.json``): types, ranges and sizes checked before use.

Bounds keep a hostile or mistyped manifest from exhausting memory before anything is allocated:
a projector side is at most :data:`~fringe3d.utils.schema.MAX_SIDE` pixels, a set holds at most
:data:`MAX_FRAMES` frames, a phase-shift group at most :data:`MAX_STEPS` steps and a code at most
:data:`MAX_BITS` bits. Direction labels become file names (``phase_<direction>.tif``), so they are
:data:`~fringe3d.utils.schema.Label`\\ s; group labels may also hold ``/`` and ``.`` (``"v/T18"``).
"""
from __future__ import annotations

from typing import Annotated, Any, Literal

import math

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, field_validator, model_validator

from fringe3d.utils.schema import FiniteFloat, Label, Size, Strict, StrictInt

MAX_FRAMES = 4096
MAX_STEPS = 1024
MAX_BITS = 32
#: Largest projector frame (pixels) of a manifest: 2^28, a 16384 x 16384 DMD.
MAX_PIXELS = 1 << 28

Group = Annotated[str, Field(pattern=r"^[A-Za-z0-9_./-]*$", max_length=128)]
Count = Annotated[StrictInt, Field(ge=0, le=MAX_STEPS)]


class FrameModel(Strict):
    kind: StrictStr
    role: StrictStr = "phase"
    direction: Label | Literal[""] = ""
    angle: FiniteFloat = 0.0
    period: Annotated[FiniteFloat, Field(ge=0, le=1e7)] = 0.0
    shift: FiniteFloat = 0.0
    step: Count = 0
    steps: Count = 0
    bit: Annotated[StrictInt, Field(ge=0, le=MAX_BITS)] = 0
    bits: Annotated[StrictInt, Field(ge=0, le=MAX_BITS)] = 0
    inverse: StrictBool = False
    group: Group = ""

    @field_validator("group")
    @classmethod
    def _no_parent(cls, v: str) -> str:
        if ".." in v.split("/") or v.startswith("/"):
            raise ValueError("a group label may not hold '..' or start with '/'")
        return v

    @model_validator(mode="after")
    def _phase_steps(self) -> "FrameModel":
        if self.role == "phase" and not 0 <= self.step < self.steps:
            raise ValueError(f"a phase frame needs steps >= 1 and 0 <= step < steps, got step {self.step} of "
                             f"steps {self.steps}")
        return self


def _finite_numbers(value: Any, at: str = "options") -> None:
    """Refuse NaN/inf anywhere in a plan's free ``options`` (beats, ranges, steps)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{at}: expected a finite number, got {value}")
    if isinstance(value, dict):
        for k, v in value.items():
            _finite_numbers(v, f"{at}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _finite_numbers(v, f"{at}[{i}]")


class PlanModel(Strict):
    direction: Label
    angle: FiniteFloat
    method: StrictStr
    periods: Annotated[list[Annotated[FiniteFloat, Field(gt=0, le=1e7)]], Field(max_length=16)] = []
    options: dict[str, Any] = {}

    @field_validator("options")
    @classmethod
    def _checked_options(cls, v: dict[str, Any]) -> dict[str, Any]:
        _finite_numbers(v)
        for name in ("steps", "beats"):
            flat = v.get(name, [])
            flat = [x for row in flat for x in (row if isinstance(row, list) else [row])] if isinstance(flat, list) \
                else [flat]
            if any(isinstance(x, bool) or not isinstance(x, (int, float)) or not x > 0 for x in flat):
                raise ValueError(f"options.{name}: expected numbers > 0, got {v.get(name)!r}")
            if name == "steps" and any(not isinstance(x, int) or x > MAX_STEPS for x in flat):
                raise ValueError(f"options.steps: expected whole numbers 1..{MAX_STEPS}, got {v.get(name)!r}")
        return v


class PlanOptionsModel(BaseModel):
    """The keys a plan's ``options`` may hold (docs/file-formats.md describes each): written by
    the pattern-set builders and read by the decoder. Documentation and a reference for tests;
    a plan's ``options`` stays a free object (other keys are kept and ignored)."""

    model_config = ConfigDict(extra="allow")

    # written by the builders (patterns.sets, patterns.layouts); informational unless noted
    phase: str | None = None                 # psp, ftp, modified_ftp, ftp+psp, none
    w_range: list[float] | None = None       # [w_min, w_max] projector px; read by unwrapping
    beats: list[list[float]] | None = None   # heterodyne: [[T1, T2, T12], [T12, T3, T123]]
    steps: list[int] | None = None           # heterodyne: the groups' step counts
    code: str | None = None                  # gray or binary
    code_group: str | None = None            # the code frames' group label
    bits: int | None = None                  # code length
    inverse: bool | None = None              # code frames come with inverses
    order_offset: int | None = None          # w0 / stripe width: stripe c starts at w0 + c T
    code_period: float | None = None         # psp-gray: the code's stripe width (px)
    high_group: str | None = None            # hybrid: the high-frequency (FTP) group
    low_group: str | None = None             # hybrid: the low-frequency group
    alpha_opt: float | None = None           # optimal-angle calibration: alpha_opt (rad)
    threshold: str | float | None = None     # code threshold: inverse, white-black, average or counts
    # read by the decoder (DecodeOptions of the same name take precedence)
    z_min: float | None = None
    z_max: float | None = None
    min_modulation_fraction: float | None = None
    white_thr: float | None = None
    black_thr: float | None = None
    edge_thr: float | None = None
    sub_stripe: bool | None = None
    ftp_window: str | None = None
    erode: int | None = None
    min_size: int | None = None
    min_ratio: float | None = None
    max_shift: float | None = None
    cross_motion: bool | None = None


class ManifestModel(Strict):
    format: Literal["fringe3d-pattern-manifest"] = "fringe3d-pattern-manifest"
    version: Annotated[StrictInt, Field(ge=1)] = 1
    name: Annotated[StrictStr, Field(max_length=256)] = ""
    width: Size
    height: Size
    bit_depth: Annotated[StrictInt, Field(ge=1, le=16)] = 8
    frames: Annotated[list[FrameModel], Field(min_length=1, max_length=MAX_FRAMES)]
    plans: Annotated[list[PlanModel], Field(max_length=64)] = []
    packing: dict[str, Any] | None = None

    @field_validator("height")
    @classmethod
    def _bounded_frame(cls, v: int, info) -> int:
        w = info.data.get("width")
        if isinstance(w, int) and w * v > MAX_PIXELS:
            raise ValueError(f"a {w}x{v} projector frame exceeds {MAX_PIXELS} pixels")
        return v
