"""Cutting a capture into 3D frames: each 3D frame's window of frames (``mode`` cycle or window,
see :mod:`fringe3d.reconstruct.sequence`)."""
from __future__ import annotations

import numpy as np


def window_starts(n_frames: int, cycle: int, mode: str = "cycle", step: int | None = None) -> list[int]:
    """First frame of each 3D frame's window (see the module docstring)."""
    if cycle <= 0:
        raise ValueError("the manifest lists no frames")
    if n_frames < cycle:
        raise ValueError(f"the capture has {n_frames} frames, fewer than one cycle of the manifest's {cycle}")
    if mode == "cycle":
        if n_frames % cycle:
            raise ValueError(f"{n_frames} frames are not a whole number of {cycle}-frame cycles")
        return list(range(0, n_frames, cycle))
    if mode == "window":
        step = 1 if step is None else int(step)
        if step < 1:
            raise ValueError(f"window step must be >= 1 frame, got {step}")
        return list(range(0, n_frames - cycle + 1, step))
    raise ValueError(f"unknown sequence mode {mode!r}; expected 'cycle' or 'window'")


def window_index(start: int, cycle: int) -> np.ndarray:
    """Frame indices of the window starting at ``start``, in manifest order: pattern ``p`` is
    the frame ``f`` in ``[start, start + cycle)`` with ``f % cycle == p``."""
    f = np.arange(start, start + cycle)
    out = np.empty(cycle, np.int64)
    out[f % cycle] = f
    return out
