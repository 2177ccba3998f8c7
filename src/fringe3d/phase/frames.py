"""The one check that an input is a stack of camera frames, ``(F, H, W)``."""
from __future__ import annotations

import numpy as np


def as_frame_stack(frames, *, layout: str = "(F, H, W)") -> np.ndarray:
    """``(F, H, W)`` array from an array or a list of ``(H, W)`` images, with clear errors.

    Parameters
    ----------
    frames : (F, H, W) array_like or sequence of (H, W) arrays
        Integer or float single-channel images (a list is stacked; an array is not copied).
    layout : str
        How the error messages name the expected shape (e.g. ``"(N, H, W)"`` for the N
        phase-shifted frames of one set).

    Returns
    -------
    (F, H, W) ndarray in the frames' dtype.

    Raises
    ------
    ValueError
        An empty list, frames of different shapes (named), colour ``(F, H, W, 3|4)`` input,
        any other number of dimensions, or a non-numeric / boolean dtype.

    Examples
    --------
    >>> import numpy as np
    >>> as_frame_stack([np.zeros((2, 3), np.uint8)] * 4).shape
    (4, 2, 3)
    """
    if isinstance(frames, (list, tuple)):
        if not frames:
            raise ValueError(f"no frames given; expected an {layout} stack")
        shapes = [np.shape(f) for f in frames]
        if len(set(shapes)) != 1:
            first = shapes[0]
            bad = [i for i, s in enumerate(shapes) if s != first]
            raise ValueError(f"frames have different shapes: frame 0 is {first}, frame(s) {bad[:10]} are "
                             f"{sorted(set(shapes[i] for i in bad))}; expected every frame to be {first}")
        frames = np.stack([np.asarray(f) for f in frames])
    frames = np.asarray(frames)
    if frames.ndim == 4 and frames.shape[-1] in (3, 4):
        raise ValueError(f"frames have shape {frames.shape} (colour?); expected single-channel {layout} frames")
    if frames.ndim != 3:
        raise ValueError(f"frames must be an {layout} stack, got shape {frames.shape}")
    if frames.dtype.kind not in "uif" or frames.dtype == np.bool_:
        raise ValueError(f"frames must be integer or float images, got dtype {frames.dtype}")
    return frames
