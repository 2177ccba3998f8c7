"""What a code bit is compared with: its inverse frame, the white/black mean, the phase
frames' average, or a fixed level (a plan's ``options["threshold"]``).

A code frame's bit is 1 where the frame is brighter than the reference this module returns.
Without ``threshold`` the reference is the inverse frame when the code has inverses, else the
mean ``(W + B) / 2`` of the white and black frames, else the average intensity of the
direction's phase frames (``"average"``); a fixed level (camera counts, the frames' units)
thresholds codes that have none of them (another lab's code thresholded at a set grey level).
"""
from __future__ import annotations

import numpy as np

from fringe3d.decode.context import DecodeContext
from fringe3d.patterns.layouts import THRESHOLD_MODES, parse_threshold


def threshold_mode(ctx: DecodeContext) -> str | float | None:
    """The plan's ``options["threshold"]`` (validated): a mode of
    :data:`fringe3d.patterns.layouts.THRESHOLD_MODES`, a level in counts, or None."""
    return parse_threshold(ctx.plan.options.get("threshold"),
                           f"direction {ctx.direction!r}: plan option 'threshold'")


def code_reference(ctx: DecodeContext, inverse: list[int] | None,
                   average: np.ndarray | None) -> tuple[list[int] | None, np.ndarray | None]:
    """(inverse frame indices, None) when the bits are compared with their inverses, else
    (None, reference (H, W) float32): the white/black mean, the phase ``average`` (None for
    a code-only direction) or a fixed level. ``ValueError`` naming the direction when the
    chosen (or, by default, any) reference is missing."""
    mode = threshold_mode(ctx)
    shape = ctx.frames.shape[1:]
    if mode is not None and not isinstance(mode, str):
        return None, np.full(shape, float(mode), np.float32)
    white, black = ctx.patterns.indices(kind="white"), ctx.patterns.indices(kind="black")
    available = {"inverse": inverse is not None, "white-black": bool(white and black), "average": average is not None}
    order = THRESHOLD_MODES if mode is None else (mode,)
    for m in order:
        if not available[m]:
            continue
        if m == "inverse":
            return inverse, None
        if m == "white-black":
            wb = ctx.frames[white[0]].astype(np.float32) + ctx.frames[black[0]].astype(np.float32)
            return None, 0.5 * wb
        return None, np.asarray(average, np.float32)
    what = f"threshold {mode!r} needs {mode} frames, which" if mode else "the code bits need a reference, which"
    raise ValueError(f"direction {ctx.direction!r}: {what} the manifest does not have (inverse code frames, a white "
                     "and a black frame, or phase frames); set `threshold` (a plan option) to a level in camera "
                     "counts")
