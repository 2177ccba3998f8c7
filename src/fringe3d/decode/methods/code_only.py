"""Decoding method ``gray_code_only``: a Gray- or binary-code capture without phase frames.

Each code bit is 1 where the code frame is brighter than its inverse frame or, without
inverse frames, than the mean of the white and black frames (or the plan's fixed
``threshold`` level; :mod:`fringe3d.decode.code_threshold`). The codeword selects the
projector stripe (:func:`fringe3d.unwrap.temporal.code_centers`), of centre ``c`` (px); the
projector coordinate ``w`` is then refined within the stripe from the zero crossings of the bit
differences between neighbouring pixels (:func:`fringe3d.unwrap.sub_stripe.sub_stripe_coordinate`;
method option ``sub_stripe=False`` keeps ``w = c``). The method returns ``w`` as the absolute
phase ``Phi = 2 pi w / T`` of the nominal period ``T`` = the code's stripe width, so
:meth:`fringe3d.decode.Decoded.projector_coordinate` gives ``w`` and triangulation works unchanged.

Validity (as OpenCV's ``GrayCodePattern.getProjPixel``): every bit must be decided by at
least ``white_thr`` (``|I - I_inv| >= white_thr``; without inverses ``|I - (W + B)/2| >=
white_thr / 2``), except that one undecided bit is accepted when flipping it gives the
neighbouring stripe (the pixel straddles that stripe edge; :func:`decide_edges`) and it still
clears ``edge_thr`` (halved likewise without inverses); and, when white and black frames are
present, the pixel must be lit, ``W - B >= black_thr`` (shadow mask). Defaults: OpenCV's 5 and
40 counts of an 8-bit camera for ``white_thr`` and ``black_thr``; ``edge_thr`` 2 counts with
inverse frames, 3 without (:data:`DEFAULT_EDGE_THR`); all scaled by ``full_scale / 255`` for
other bit depths.

Saturation (by what it breaks): clipping lowers the brighter frame of a pair but never makes
it the darker one, so a bit with one clipped frame is decided by its difference like any other;
only a bit whose frame and reference (inverse, or ``(W + B)/2``) are both at the saturation level
is undecidable (:func:`clipped_pairs`), and is never accepted as a stripe-edge bit. Clean
0 / full-scale frames (OpenCV's ``GrayCodePattern`` images seen at full exposure) thus decode
wherever lit. The shares of pixels with such a pair and of lit pixels it masked are recorded in
``info["quality"][direction]["saturation"]["code"]``.

``edge_thr`` trades kept edge pixels against wrong stripes. A pixel at projector distance
``d`` from a stripe edge has ``|I - I_inv| ~ 2 A |d|`` (``A`` the code amplitude, counts per
projector px for a sharp edge), so with noise ``sigma`` its sign is wrong with probability
``Phi(-2 A |d| / sigma)``: keeping every edge pixel costs a share ``~0.4 sigma / (A T)`` of
wrong stripes (0.22-0.25 % at ``T = 4``, 0.12-0.14 % at ``T = 8`` on the simulator's tiny rig at
the well-designed noise, 0.37-0.41 % / 0.20-0.22 % without inverses), which no decision from
the pixel's own frames avoids; masking the pixels with ``|I - I_inv| < edge_thr`` removes the
most ambiguous ones (``scripts/gray_code_only_accuracy.py`` reports both shares).
"""
from __future__ import annotations

import numpy as np

from fringe3d.decode.code_threshold import code_reference, threshold_mode
from fringe3d.decode.context import DecodeContext
from fringe3d.decode.methods.temporal import code_frames, unwrap_gray_code
from fringe3d.patterns.conventions import point_at_fringe_coordinate, w_range
from fringe3d.patterns.render import sinusoid_value
from fringe3d.patterns.codes import decode_bits
from fringe3d.decode.result import Unwrapped
from fringe3d.phase import quality
from fringe3d.unwrap.sub_stripe import sub_stripe_coordinate
from fringe3d.unwrap.temporal import code_centers

#: OpenCV's ``GrayCodePattern`` defaults, in counts of an 8-bit camera.
DEFAULT_WHITE_THR = 5.0
DEFAULT_BLACK_THR = 40.0
#: Smallest code/inverse difference of a stripe-edge pixel's undecided bit (:func:`decide_edges`),
#: in counts of an 8-bit camera: (with inverse frames, without). Without inverses the threshold
#: ``(W + B)/2`` adds the white and black frames' noise, so the edge needs a wider margin.
DEFAULT_EDGE_THR = (2.0, 3.0)


def code_thresholds(ctx: DecodeContext) -> tuple[float, float]:
    """(white_thr, black_thr) in the frames' units: the options', else OpenCV's defaults
    scaled to the frames' full scale (:func:`fringe3d.phase.quality.full_scale`)."""
    scale = quality.full_scale(ctx.frames, ctx.bit_depth) / 255.0
    white = ctx.method_option("white_thr")
    black = ctx.method_option("black_thr")
    return (DEFAULT_WHITE_THR * scale if white is None else float(white),
            DEFAULT_BLACK_THR * scale if black is None else float(black))


def edge_threshold(ctx: DecodeContext, inverse: bool) -> float:
    """``edge_thr`` in the frames' units, in code/inverse-difference terms as ``white_thr``: the
    option's, else :data:`DEFAULT_EDGE_THR` (with / without inverse frames) scaled to the frames'
    full scale."""
    edge = ctx.method_option("edge_thr")
    if edge is not None:
        return float(edge)
    return DEFAULT_EDGE_THR[0 if inverse else 1] * quality.full_scale(ctx.frames, ctx.bit_depth) / 255.0


def white_black(ctx: DecodeContext) -> tuple[np.ndarray, np.ndarray] | None:
    """(white, black) float32 frames of the manifest, or None when either is missing."""
    white = ctx.patterns.indices(kind="white")
    black = ctx.patterns.indices(kind="black")
    if not (white and black):
        return None
    return ctx.frames[white[0]].astype(np.float32), ctx.frames[black[0]].astype(np.float32)


def pixel_code_centers(ctx: DecodeContext, direct: list[int]) -> np.ndarray:
    """Codeword -> stripe centre (px) over the projector's pixel centres: the code frames
    evaluated at integer fringe coordinates ``w`` (pixel centres of ``v``/``h`` stripes), so a
    stripe of pixels ``c T .. c T + T - 1`` has centre ``c T + (T - 1) / 2`` (``c`` for
    OpenCV's one-pixel stripes); cached in the context."""
    key = ("pixel_code_centers", ctx.direction)
    if key not in ctx.cache:
        ps = ctx.patterns
        lo, hi = w_range(ctx.plan.angle, ps.width, ps.height)
        w = np.arange(np.ceil(lo), np.floor(hi) + 1.0)
        u, v = point_at_fringe_coordinate(w, ctx.plan.angle)
        images = np.stack([sinusoid_value(ps.frames[i], u, v, ps.width, ps.height) for i in direct])
        ctx.cache[key] = code_centers(images, w)
    return ctx.cache[key]


def code_differences(ctx: DecodeContext, direct: list[int], inverse: list[int] | None,
                     reference: np.ndarray | None, white_thr: float) -> tuple[np.ndarray, float]:
    """(diff (B, H, W) float32, margin): each bit's ``I - I_inv``, or without inverses ``I - reference``
    (:func:`fringe3d.decode.code_threshold.code_reference`: the white/black mean or a fixed level), and
    the smallest ``|diff|`` that decides a bit (``white_thr``; ``white_thr / 2`` without inverses)."""
    code = ctx.frames[direct].astype(np.float32)
    if inverse is not None:
        return code - ctx.frames[inverse].astype(np.float32), white_thr
    if reference is None:
        raise ValueError(f"direction {ctx.direction!r}: code bits without inverse frames need a reference "
                         "(fringe3d.decode.code_threshold.code_reference)")
    return code - reference, 0.5 * white_thr


def clipped_pairs(ctx: DecodeContext, direct: list[int], inverse: list[int] | None,
                  reference: np.ndarray | None, white: np.ndarray | None, margin: float) -> np.ndarray:
    """(B, H, W) bool: bits whose order clipping erased.

    With inverse frames: the code frame and its inverse both at the saturation level ``L``.
    Clipping never reverses an order (it only lowers the brighter value, down to the level), so a
    bit whose brighter frame alone is clipped is still decided by its difference; only a pair
    clipped on both sides is undecidable, whatever its (clipped, zero) difference says.

    Thresholded against a ``reference`` (H, W): a code value and a reference both clipped are
    undecidable. Where the reference is the white/black mean ``(W + B)/2`` and the ``white``
    frame is clipped, the true threshold is unknown but at least the clipped one, so a code value
    from ``margin`` below the clipped threshold up to just below ``L`` may lie on either side of
    it (an edge pixel whose true level is not known): undecidable. A clipped code value counts as
    lit (its true value is at least ``L``, above the true threshold unless the white frame
    exceeds about ``2 L``), an unclipped one below that band as dark."""
    level = quality.saturation_level(ctx.frames, ctx.bit_depth)
    shape = (len(direct),) + ctx.frames.shape[1:]
    if not np.isfinite(level) or (inverse is None and reference is None):
        return np.zeros(shape, bool)
    code = ctx.frames[direct]
    if inverse is not None:
        return np.asarray((code >= level) & (ctx.frames[inverse] >= level))
    assert reference is not None
    both = (code >= level) & (reference >= level)
    if white is None:
        return np.asarray(both)
    return np.asarray(both | ((white >= level) & (code < level) & (code >= reference - margin)))


def decide_edges(diff: np.ndarray, margin: float, centres: np.ndarray, period: float,
                 edge_margin: float = 0.0,
                 undecidable: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(decided, straddling (H, W) bool, word (H, W) int64, contrast (H, W) float32): which
    pixels' codewords are trusted, and the raw codewords of ``diff > 0``.

    A pixel is decided when every bit clears ``margin`` (``|diff| >= margin``), or when exactly
    one bit does not, that bit still clears ``edge_margin``, and flipping it selects the adjacent
    stripe (stripe centres ``centres`` one ``period`` apart): the pixel then lies near that
    stripe edge, where the bit's difference is small by construction rather than from a lack of
    light, and its sign places the pixel (the sub-stripe coordinate of
    :mod:`fringe3d.unwrap.sub_stripe` refines it). Below ``edge_margin`` the sign is too likely
    noise (see the module docstring). ``straddling`` is ``decided`` with ``edge_margin`` 0 (every
    stripe-edge pixel). ``contrast`` is the smallest ``|diff|`` of the bits that cleared the
    margin (of all bits where none did). A bit marked ``undecidable`` (B, H, W) bool (both
    frames clipped, :func:`clipped_pairs`) never decides a pixel, not even as an edge bit."""
    nb = diff.shape[0]
    size = np.abs(diff)
    if undecidable is not None:
        size = np.where(undecidable, -np.inf, size)
    weak = size < margin
    n_weak = weak.sum(axis=0)
    word = decode_bits(diff > 0, gray=False)
    flip_bit = (nb - 1 - np.argmax(weak, axis=0)).astype(np.int64)
    with np.errstate(invalid="ignore"):
        step = np.abs(centres[word] - centres[word ^ (np.int64(1) << flip_bit)])
    edge = (n_weak == 1) & (step > 0.5 * period) & (step < 1.5 * period)
    clear = n_weak == 0
    weakest = np.where(weak, size, np.inf).min(axis=0)
    straddling = clear | (edge & (weakest > -np.inf))
    decided = clear | (edge & (weakest >= edge_margin))
    strong = np.where(weak, np.inf, size).min(axis=0)
    contrast = np.where(np.isfinite(strong), strong, np.maximum(size.min(axis=0), 0.0))
    return decided, straddling, word, contrast.astype(np.float32)


def unwrap_code_only(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="gray_code_only"`` (and ``gray_code`` / ``binary_code`` plans of a
    direction without phase frames): the projector coordinate from the code alone, as the
    absolute phase of the nominal period ``T`` (the code frames' stripe width); see the module
    docstring. With inverse frames (and method option ``sub_stripe``, default True) the
    coordinate is refined within the stripe (:func:`fringe3d.unwrap.sub_stripe.sub_stripe_coordinate`)."""
    direct, inverse = code_frames(ctx)
    inverse, reference = code_reference(ctx, inverse, None)
    period = float(ctx.patterns.frames[direct[0]].period)
    white_thr, black_thr = code_thresholds(ctx)
    wb = white_black(ctx)
    diff, margin = code_differences(ctx, direct, inverse, reference, white_thr)
    white = wb[0] if (wb is not None and threshold_mode(ctx) in (None, "white-black")) else None
    clipped = clipped_pairs(ctx, direct, inverse, reference, white, margin)
    centres = pixel_code_centers(ctx, direct)
    edge_margin = edge_threshold(ctx, inverse is not None) * (1.0 if inverse is not None else 0.5)
    decided, straddling, word, contrast = decide_edges(diff, margin, centres, period, edge_margin, clipped)
    centre = centres[word]
    lit = np.isfinite(centre)
    if wb is not None:
        lit &= (wb[0] - wb[1]) >= black_thr
    mask = decided & lit
    both = clipped.any(axis=0)
    ctx.cache[("code_clipped",)] = both & lit & ~decided
    ctx.cache[("saturation", "code")] = {"clipped": float(both.mean()), "masked": float((both & lit & ~decided).mean()),
                                         "rule": "a code bit whose frame and reference are both clipped"}
    if ctx.method_option("sub_stripe", True):
        # the zero crossings come from every edge pixel, also those below edge_thr: a crossing's
        # interpolated position is continuous in the pixel's difference, whatever its sign
        sources = lit & straddling
        coordinate, _ = sub_stripe_coordinate(np.where(sources, centre, np.nan), diff, period,
                                              plateau=lit & both & ~sources)
    else:
        coordinate = centre
    phase = np.where(mask, 2.0 * np.pi * coordinate / period, np.nan).astype(np.float32)
    wrapped = np.angle(np.exp(1j * np.nan_to_num(phase))).astype(np.float32)
    average = (0.5 * (wb[0] + wb[1]) if wb is not None else ctx.frames[direct].astype(np.float32).mean(axis=0))
    modulation = contrast if inverse is not None else 2.0 * contrast
    return Unwrapped(phase, mask, wrapped=wrapped, modulation=modulation.astype(np.float32),
                     average=np.asarray(average, np.float32), period=period, phase_is_masked=True)


def unwrap_code(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="gray_code"`` / ``"binary_code"``: code + phase
    (:func:`fringe3d.decode.methods.temporal.unwrap_gray_code`) when the direction has phase
    frames, else the code alone (:func:`unwrap_code_only`)."""
    return unwrap_gray_code(ctx) if ctx.phase_groups() else unwrap_code_only(ctx)
