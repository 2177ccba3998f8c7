"""The texture of a pattern cycle: one meaning in every output.

``texture`` (H, W) float32 is the scene as the camera sees it under full projector illumination,
as a **fraction of the camera's full scale** (0 = black, 1 = saturated;
:func:`fringe3d.phase.quality.full_scale`), NaN-free and clipped to [0, 1]:

* the white frame of the set when it has one (``kind="white"``);
* otherwise ``A + B`` (average plus modulation, Eq. 2.3: the peak of the fringe, what a white
  frame would show) of the first direction's narrowest phase group.

``decode`` (``texture.tif``, :attr:`fringe3d.decode.result.Decoded.texture`), ``reconstruct``
(``texture.tif``, :attr:`fringe3d.pipeline.Reconstruction.texture`, PLY colours, the sequence
store) all hold this quantity; :data:`TEXTURE_UNIT` names its unit in file descriptions.
"""
from __future__ import annotations

import numpy as np

from fringe3d.phase.psp import wrapped_phase
from fringe3d.phase.quality import full_scale

__all__ = ["TEXTURE_UNIT", "as_fraction", "fringe_texture"]

#: The unit of every texture fringe3d writes.
TEXTURE_UNIT = "fraction of full scale"


def as_fraction(intensity: np.ndarray, frames: np.ndarray, bit_depth: int | None) -> np.ndarray:
    """``intensity`` (H, W) in the frames' units -> float32 fraction of full scale in [0, 1]
    (NaN -> 0); ``frames`` and ``bit_depth`` give the full scale."""
    tex = np.asarray(intensity, np.float32) / np.float32(full_scale(frames, bit_depth))
    return np.clip(np.nan_to_num(tex), 0, 1).astype(np.float32, copy=False)


def fringe_texture(frames: np.ndarray, shifts, index, bit_depth: int | None) -> np.ndarray:
    """Texture ``A + B`` of the phase-shifted frames ``frames[index]`` with ``shifts`` (rad), as a
    fraction of full scale (for a set without a white frame)."""
    pr = wrapped_phase(frames, shifts=shifts, index=index)
    return as_fraction(np.add(pr.average, pr.modulation, dtype=np.float32), frames, bit_depth)
