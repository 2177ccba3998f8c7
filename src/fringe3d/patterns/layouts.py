"""Pattern layouts of other tools, as :class:`PatternSet` s the decoder reads.

:func:`opencv_graycode` is OpenCV's ``cv2.structured_light.GrayCodePattern`` sequence:
``generate()`` returns ``2 * (ceil(log2 W) + ceil(log2 H))`` images, for every column bit
(most significant first) the pattern then its inverse, then the row bits the same way, and
``getImagesForShadowMasks`` adds a white and a black image, captured last. Bit ``k`` of
the column code is bit ``k`` of the reflected Gray code of the projector column ``j``
(``j ^ (j >> 1)``), one projector pixel per stripe, exactly fringe3d's
:func:`fringe3d.patterns.sets.gray_code` with stripe width 1 px.

Other labs' layouts: :func:`combine_directions` joins per-direction sets (columns then rows, or
interleaved bit by bit), :func:`with_white_black` adds a white and a black frame, and
:func:`parse_threshold` / :func:`with_threshold` set what code bits are compared with (a plan's
``options["threshold"]``: the inverse frame, the white/black mean, the phase average or a fixed
level in camera counts).
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


#: Where a layout's white and black frames are: none, before the code, after it.
WHITE_BLACK_PLACES = ("none", "first", "last")


def frame_units(ps: PatternSet) -> list[tuple[FrameSpec, ...]]:
    """The frames of ``ps`` in the units another tool interleaves: a code bit with its inverse
    (consecutive frames of one code group and bit), else each frame alone."""
    units: list[list[FrameSpec]] = []
    for f in ps.frames:
        last = units[-1][-1] if units else None
        if (f.role == "code" and last is not None and last.role == "code" and last.group == f.group
                and last.bit == f.bit):
            units[-1].append(f)
        else:
            units.append([f])
    return [tuple(u) for u in units]


def combine_directions(parts: list[PatternSet], interleave: bool = False, name: str | None = None) -> PatternSet:
    """One :class:`PatternSet` of the per-direction sets ``parts`` (same projector, distinct
    directions): concatenated in order, or with ``interleave`` round robin unit by unit
    (:func:`frame_units`: a code bit with its inverse, or one phase step), most significant bit
    first; a direction with more units than another continues alone at the end. Plans: one per
    direction, in the order of ``parts``.

    Examples
    --------
    >>> v = sets.gray_code(1.0, "v", width=8, height=4, inverse=False)
    >>> h = sets.gray_code(1.0, "h", width=8, height=4, inverse=False)
    >>> [f"{f.direction}{f.bit}" for f in combine_directions([v, h], interleave=True).frames]
    ['v0', 'h0', 'v1', 'h1', 'v2']
    """
    out = parts[0]
    for p in parts[1:]:
        out = out.concat(p)
    if interleave:
        units = [frame_units(p) for p in parts]
        frames = tuple(f for k in range(max(map(len, units))) for u in units if k < len(u) for f in u[k])
        out = replace(out, frames=frames)
    return out if name is None else replace(out, name=name)


def with_white_black(ps: PatternSet, place: str) -> PatternSet:
    """``ps`` with a white (role ``texture``) and a black (role ``reference``) frame, in that
    order, ``"first"`` (before its frames) or ``"last"`` (after them), or unchanged for
    ``"none"``; the decoder thresholds code bits against their mean when the code has no
    inverse frames (or the plan's ``threshold`` is ``"white-black"``)."""
    if place not in WHITE_BLACK_PLACES:
        raise ValueError(f"`white_black` must be one of {', '.join(WHITE_BLACK_PLACES)}, got {place!r}")
    if place == "none":
        return ps
    wb = (FrameSpec(kind="white", role="texture"), FrameSpec(kind="black", role="reference"))
    return replace(ps, frames=wb + ps.frames if place == "first" else ps.frames + wb)


#: How code bits are thresholded (a plan's ``options["threshold"]``), besides a fixed level in
#: camera counts: against the bit's inverse frame, the mean of the white and black frames, or
#: the phase frames' average intensity.
THRESHOLD_MODES = ("inverse", "white-black", "average")


def parse_threshold(value: str | float | None, where: str = "`threshold`") -> str | float | None:
    """A plan's code threshold: one of :data:`THRESHOLD_MODES`, or a fixed level in camera
    counts (a number >= 0; a string holding one is converted); None stays None. ``ValueError``
    naming ``where`` otherwise."""
    if value is None or (isinstance(value, str) and value in THRESHOLD_MODES):
        return value
    try:
        level = float(value) if not isinstance(value, bool) else math.nan
    except (TypeError, ValueError):
        level = math.nan
    if not (math.isfinite(level) and level >= 0):
        raise ValueError(f"{where} {value!r}: expected one of {', '.join(THRESHOLD_MODES)} or a fixed level in "
                         "camera counts (a number >= 0)")
    return level


def with_threshold(ps: PatternSet, threshold: str | float) -> PatternSet:
    """``ps`` with every plan's ``options["threshold"]`` set to ``threshold`` (see
    :func:`parse_threshold`), e.g. from ``fringe3d decode --threshold``."""
    level = parse_threshold(threshold)
    return replace(ps, plans=tuple(replace(p, options={**p.options, "threshold": level}) for p in ps.plans))
