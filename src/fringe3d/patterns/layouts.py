"""Pattern layouts of other tools, as :class:`PatternSet` s the decoder reads.

:func:`opencv_graycode` is OpenCV's ``cv2.structured_light.GrayCodePattern`` sequence:
``generate()`` returns ``2 * (ceil(log2 W) + ceil(log2 H))`` images, for every column bit
(most significant first) the pattern then its inverse, then the row bits the same way, and
``getImagesForShadowMasks`` adds a white and a black image, captured last. Bit ``k`` of
the column code is bit ``k`` of the reflected Gray code of the projector column ``j``
(``j ^ (j >> 1)``), one projector pixel per stripe, exactly fringe3d's
:func:`fringe3d.patterns.sets.gray_code` with stripe width 1 px.
"""
from __future__ import annotations

import math
from dataclasses import replace

from fringe3d.patterns import sets
from fringe3d.patterns.manifest import FrameSpec, PatternSet


def opencv_graycode_bits(width: int, height: int) -> tuple[int, int]:
    """(column bits, row bits) of OpenCV's Gray-code sequence: ``ceil(log2 W)``, ``ceil(log2 H)``."""
    return max(1, math.ceil(math.log2(width))), max(1, math.ceil(math.log2(height)))


def opencv_graycode_count(width: int, height: int) -> int:
    """Frames of OpenCV's sequence with the white/black pair: ``2 * (bits_u + bits_v) + 2``."""
    bu, bv = opencv_graycode_bits(width, height)
    return 2 * (bu + bv) + 2


def opencv_graycode(width: int, height: int) -> PatternSet:
    """OpenCV's ``GrayCodePattern`` sequence for a ``width`` x ``height`` projector (see the
    module docstring): column pairs, row pairs, white, black; plans ``gray_code_only``.

    Examples
    --------
    >>> ps = opencv_graycode(1024, 768)
    >>> len(ps), [p.method for p in ps.plans]
    (42, ['gray_code_only', 'gray_code_only'])
    """
    cols = sets.gray_code(1.0, "v", width=width, height=height)
    rows = sets.gray_code(1.0, "h", width=width, height=height)
    ps = cols.concat(rows, name=f"opencv-graycode-{width}x{height}")
    plans = tuple(replace(p, method="gray_code_only") for p in ps.plans)
    frames = ps.frames + (FrameSpec(kind="white", role="texture"), FrameSpec(kind="black", role="reference"))
    if len(frames) != opencv_graycode_count(width, height):  # bits_needed must agree with OpenCV's count
        raise ValueError(f"internal: {len(frames)} frames for OpenCV's {opencv_graycode_count(width, height)}")
    return replace(ps, frames=frames, plans=plans)
