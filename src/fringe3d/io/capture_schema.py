"""The schema of ``capture.json`` (a capture folder's metadata) and checks of frames against it.

Known fields are typed and bounded; any other field is free metadata and kept as is.
``bit_depth`` is an integer (``true`` is refused), the frames may not exceed it, and float
frames (TIFF) may not hold NaN or infinity.
"""
from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, StrictBool

from fringe3d.utils.schema import Open, PositiveFloat, Size, StrictInt, validate

BIT_DEPTHS = (1, 8, 10, 12, 14, 16)


class CaptureMeta(Open):
    frame_rate: PositiveFloat | None = None
    exposure: PositiveFloat | None = None
    bit_depth: Literal[1, 8, 10, 12, 14, 16] | None = None
    camera: Annotated[list[Size], Field(min_length=2, max_length=2)] | None = None
    complete: StrictBool | None = None
    cycles: Annotated[StrictInt, Field(ge=0)] | None = None


def validate_meta(meta: Any, where: str) -> dict:
    """``meta`` checked against :class:`CaptureMeta` (``ValueError`` naming the field), returned as is."""
    if not isinstance(meta, dict):
        raise ValueError(f"{where}: expected a JSON object, got {type(meta).__name__}")
    if isinstance(meta.get("bit_depth"), bool):  # Literal[1] would accept true
        raise ValueError(f"{where}: field bit_depth: expected one of {', '.join(map(str, BIT_DEPTHS))}, got true")
    validate(CaptureMeta, meta, where)
    return meta


def check_frame_values(frames: np.ndarray, bit_depth: int | None, where: str) -> None:
    """Refuse frames that exceed the stated bit depth or (float frames) hold NaN/inf.

    ``frames`` : (F, H, W) array; ``bit_depth`` from capture.json (None: not stated).
    """
    if frames.dtype.kind == "f":
        if not np.isfinite(frames).all():
            bad = int(np.flatnonzero(~np.isfinite(frames).reshape(len(frames), -1).all(axis=1))[0])
            raise ValueError(f"{where}: frame {bad} holds NaN or infinite values; expected finite intensities")
        return
    if bit_depth is not None and frames.dtype.kind in "ui" and bit_depth < 8 * frames.dtype.itemsize:
        top = int(frames.max(initial=0))
        if top > (1 << bit_depth) - 1:
            raise ValueError(f"{where}: frames reach {top} but capture.json field bit_depth says {bit_depth} bits "
                             f"(at most {(1 << bit_depth) - 1}); correct bit_depth (e.g. 16) or the frames")
