"""Temporal phase unwrapping: hierarchical multi-frequency, heterodyne, Gray code + phase.

All methods produce ``Phi = phi + 2 pi k`` (Eq. 1.5) pixel by pixel, from the wrapped phase
of the narrowest period and extra frames; fused numba kernels in
:mod:`fringe3d.unwrap._kernels` (plain-NumPy references in the tests).

Conventions: wrapped phases in (-pi, pi]; absolute phase ``Phi = 2 pi w / T`` with ``w`` the
projector fringe coordinate (manifest). The coarsest (or final beat) phase is taken as
absolute in a window ``[lower, lower + 2 pi)``; :func:`coarse_window` centres the projector's
coordinate range in that window so noise at the pattern edges does not wrap.

Tested noise levels (tests/test_unwrap_temporal.py, closed-form frames A=120, B=80 counts,
Gaussian noise sigma): exact fringe order on 100 % of pixels for heterodyne 18/21/144
(9/3/3 steps) and hierarchical 16/96/1024 (4 steps each) at sigma = 4 (sigma/B = 0.05), and
for 4-step phase + half-period Gray code at sigma = 2 with code edges misplaced by T/8.
"""
from __future__ import annotations

import math
import warnings
from typing import NamedTuple, Sequence

import numpy as np

from fringe3d.gpu.runtime import check_backend
from fringe3d.patterns.conventions import beat_period, w_to_phase
from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.psp import lsq_coefficients
from fringe3d.unwrap import _kernels as kernels
from fringe3d.utils.warning_types import UnwrapRangeWarning


class OrderedPhase(NamedTuple):
    """Absolute phase (H, W) float32 rad and fringe order (H, W) int32 of the narrowest period,
    and the largest rounding residual over the unwrapping steps (H, W) float32 (periods of each
    step's finer phase, 0 to 1/2: how far the coarse estimate is from the fine coordinate)."""

    phase: np.ndarray
    order: np.ndarray
    residual: np.ndarray | None = None


def coarse_window(period: float, w_range: tuple[float, float] | None) -> float:
    """Start (rad) of the window ``[lower, lower + 2 pi)`` in which the coarsest phase is absolute.

    ``w_range=None``: 0 (window [0, 2 pi)). Otherwise the range is centred in the period; if
    the range is wider than ``period`` a :class:`UnwrapRangeWarning` is issued and the window
    starts at ``w_min`` (coordinates beyond ``w_min + period`` alias).

    Parameters
    ----------
    period : float
        Period of the coarsest (or final beat) phase (projector px).
    w_range : tuple of float or None
        ``(w_min, w_max)`` projector fringe coordinates covered (px).

    Returns
    -------
    float
        The window's start ``lower`` (rad).
    """
    if w_range is None:
        return 0.0
    w0, w1 = float(w_range[0]), float(w_range[1])
    span = w1 - w0
    if span >= period:
        warnings.warn(f"coarsest equivalent period {period:g} px is shorter than the projector's fringe "
                      f"coordinate range {span + 1:g} px; absolute phase aliases beyond w = {w0 + period:g}",
                      UnwrapRangeWarning, stacklevel=3)
        return w_to_phase(w0 - 0.5, period)
    return w_to_phase(w0 - 0.5 * (period - span), period)


def stack_phases(phases: Sequence[np.ndarray]) -> np.ndarray:
    """(M, H, W) float32 stack of M wrapped phases of one (H, W) shape, or a clear ValueError."""
    shapes = {np.shape(p) for p in phases}
    if len(shapes) != 1:
        raise ValueError(f"wrapped phases have different shapes {sorted(shapes)}; expected one (H, W) shape")
    st = np.stack([np.asarray(p, dtype=np.float32) for p in phases])
    if st.ndim != 3:
        raise ValueError(f"each wrapped phase must be (H, W), got {st.shape[1:]}")
    return st


def check_periods(periods: Sequence[float], n: int, minimum: int) -> np.ndarray:
    """(n,) float64 periods (px) for ``n`` wrapped phases (at least ``minimum``), all positive."""
    p = np.asarray(periods, dtype=np.float64)
    if p.size != n:
        raise ValueError(f"got {p.size} periods for {n} wrapped phases; expected one period per phase")
    if n < minimum:
        raise ValueError(f"need at least {minimum} wrapped phases, got {n}")
    if np.any(p <= 0):
        raise ValueError(f"periods must be positive, got {p.tolist()}")
    return p


# -- hierarchical -------------------------------------------------------------------------
def hierarchical(phases: Sequence[np.ndarray], periods: Sequence[float],
                 w_range: tuple[float, float] | None = None) -> OrderedPhase:
    """Hierarchical multi-frequency unwrapping: each coarser absolute phase unwraps the next
    finer one, ``k = round(((T_low/T_high) Phi_low - phi_high) / 2 pi)`` (Eq. 1.5).

    Exact while each level's error ``|(T_low/T_high) dPhi_low - dphi_high| < pi``; an
    exact-zero wrapped phase is no tie here (the rounding is against the coarser estimate, not
    against a stripe centre).

    Parameters
    ----------
    phases : sequence of (H, W) ndarray
        M wrapped phases (rad), narrowest period first; the last (coarsest) must cover the
        projector (period >= coordinate range) to be absolute.
    periods : sequence of float
        M periods in projector pixels, same order.
    w_range : tuple of float, optional
        ``(w_min, w_max)`` projector fringe coordinates covered, see :func:`coarse_window`.

    Returns
    -------
    OrderedPhase
        For the narrowest period, with the largest rounding residual over the levels (periods
        of the finer phase; ties at exactly 1/2 go up).
    """
    st = stack_phases(phases)
    p = check_periods(periods, st.shape[0], 1)
    lower = coarse_window(p[-1], w_range)
    order = np.empty(st.shape[1:], np.int32)
    phase = np.empty(st.shape[1:], np.float32)
    residual = np.empty(st.shape[1:], np.float32)
    kernels.hierarchical_kernel(st, p, lower, order, phase, residual)
    return OrderedPhase(phase, order, residual)


# -- heterodyne ---------------------------------------------------------------------------
def beat_chain(periods: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Equivalent periods and signs of the heterodyne chain.

    ``beat(Ta, Tb) = Ta Tb / |Tb - Ta|``; the chain beats the first two periods, then that
    beat with the third, and so on: (18, 21, 144) -> (126, 1008). Returns (beat_periods (M-1,),
    signs (M-1,)) with sign +1 when the left period is the shorter one.

    Parameters
    ----------
    periods : (M,) sequence of float
        Fringe periods (projector px), narrowest first, consecutive ones distinct.

    Returns
    -------
    beat_periods : ndarray
        ``(M-1,)`` float64 equivalent periods (px).
    signs : ndarray
        ``(M-1,)`` float64, +1 or -1.
    """
    p = [float(x) for x in periods]
    beats, signs = [], []
    cur = p[0]
    for nxt in p[1:]:
        if abs(nxt - cur) < 1e-9 * max(nxt, cur):
            raise ValueError(f"heterodyne needs distinct periods, got {cur:g} and {nxt:g} in {p}")
        beats.append(beat_period(cur, nxt))
        signs.append(1.0 if cur < nxt else -1.0)
        cur = beats[-1]
    return np.array(beats), np.array(signs)


def heterodyne(phases: Sequence[np.ndarray], periods: Sequence[float],
               w_range: tuple[float, float] | None = None) -> OrderedPhase:
    """Multi-frequency heterodyne unwrapping (three-frequency 18/21/144 of the calibration set).

    The wrapped phases (narrowest first) are beaten pairwise along :func:`beat_chain`
    (18 & 21 -> 126, 126 & 144 -> 1008); the last beat, absolute when its period covers the
    projector, unwraps the previous beat, which unwraps the narrowest phase. Returns
    :class:`OrderedPhase` for ``periods[0]``.

    Parameters
    ----------
    phases : sequence of (H, W) ndarray
        M >= 2 wrapped phases (rad), narrowest period first.
    periods : sequence of float
        M periods (projector px), same order.
    w_range : tuple of float, optional
        ``(w_min, w_max)`` projector fringe coordinates covered, see :func:`coarse_window`.

    Returns
    -------
    OrderedPhase
        Absolute phase and fringe order of ``periods[0]``, with the rounding residual.
    """
    st = stack_phases(phases)
    p = check_periods(periods, st.shape[0], 2)
    beats, signs = beat_chain(p)
    lower = coarse_window(beats[-1], w_range)
    order = np.empty(st.shape[1:], np.int32)
    phase = np.empty(st.shape[1:], np.float32)
    residual = np.empty(st.shape[1:], np.float32)
    kernels.heterodyne_kernel(st, signs, beats, p, lower, order, phase, residual)
    return OrderedPhase(phase, order, residual)


# -- Gray / binary code + phase -----------------------------------------------------------
#: Largest accepted distance (in fringe periods) of a code + phase pixel's unwrapped coordinate
#: from its codeword's stripe (:func:`gray_code_order`); beyond it the code and the phase
#: disagree and the decoder masks the pixel (quality bit ``ORDER``, :mod:`fringe3d.decode.edges`).
MAX_CODE_RESIDUAL = 0.125


class CodeUnwrapped(NamedTuple):
    """Absolute phase (float32, NaN on unused codewords), fringe order (int32), valid (bool) and
    the code/phase residual (float32, fringe periods: the unwrapped coordinate's distance from
    the codeword's stripe; NaN on unused codewords, inf where the code cannot tell the order)."""

    phase: np.ndarray
    order: np.ndarray
    valid: np.ndarray
    residual: np.ndarray | None = None


class CodeStripes(NamedTuple):
    """Per raw codeword (each (2**B,)): stripe centre, lower and upper edge (projector px, NaN for
    unused codewords) and, as int64 bit masks of the raw codeword (bit ``B-1-q`` for code bit
    ``q``), the code bits that change at the stripe's lower edge and at its upper edge (0 where
    no stripe adjoins)."""

    centre: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    lower_bits: np.ndarray
    upper_bits: np.ndarray


def _codewords(code_images: np.ndarray) -> np.ndarray:
    """Raw codewords (...) int64 of binary projector code images (B, ...) (MSB first, 0/1 or 0/255)."""
    bits = np.asarray(code_images) > (0.5 * np.max(code_images) if np.max(code_images) > 0 else 0.5)
    nb = bits.shape[0]
    if nb > 24:
        raise ValueError(f"a code with {nb} bits is not supported (at most 24)")
    code = np.zeros(bits.shape[1:], np.int64)
    for q in range(nb):
        code = code * 2 + bits[q]
    return code


def code_centers(code_images: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Lookup table raw codeword -> centre of the projector interval it covers.

    code_images (B, ...) binary projector images of the code bits (most significant first,
    values 0/1 or 0/255); w (...) the fringe coordinate of each projector pixel. Returns
    (2**B,) float64 centres (px) ``(min w + max w) / 2`` per codeword, NaN for codewords no
    projector pixel carries. Works for Gray and simple binary codes alike.

    Parameters
    ----------
    code_images : (B, ...) array_like
        Projector images of the code bits, most significant first, 0/1 or 0/255.
    w : (...) array_like
        Fringe coordinate of each projector pixel (px).

    Returns
    -------
    ndarray
        ``(2**B,)`` float64 stripe centres (px), NaN for unused codewords.
    """
    return code_stripes(code_images, w).centre


def code_stripes(code_images: np.ndarray, w: np.ndarray) -> CodeStripes:
    """Stripe table of a projected code: :class:`CodeStripes` from the code's projector images.

    code_images (B, ...) and w (...) as in :func:`code_centers`. A codeword's stripe runs from
    its smallest to its largest sample ``w``, widened by half the sampling step on each side
    (so neighbouring stripes share their edge); centre ``(min w + max w) / 2``. Two codewords are
    neighbours when their stripes meet; the bits that differ between them change at that edge.

    Parameters
    ----------
    code_images : (B, ...) array_like
        Projector images of the code bits, most significant first, 0/1 or 0/255.
    w : (...) array_like
        Fringe coordinate of each projector pixel (px).

    Returns
    -------
    CodeStripes
        Per raw codeword: centre, lower and upper edge (px) and the bits changing at each edge.
    """
    code = _codewords(code_images).ravel()
    nb = np.asarray(code_images).shape[0]
    ww = np.asarray(w, np.float64).ravel()
    lo = np.full(2 ** nb, np.inf)
    hi = np.full(2 ** nb, -np.inf)
    np.minimum.at(lo, code, ww)
    np.maximum.at(hi, code, ww)
    used = np.isfinite(lo)
    centre = np.full(2 ** nb, np.nan)
    centre[used] = 0.5 * (lo[used] + hi[used])
    steps = np.diff(np.unique(ww))
    half = 0.5 * float(steps.min()) if steps.size else 0.0
    lower = np.where(used, lo - half, np.nan)
    upper = np.where(used, hi + half, np.nan)
    words = np.flatnonzero(used)
    words = words[np.argsort(centre[words])]
    flips_lo = np.zeros(2 ** nb, np.int64)
    flips_hi = np.zeros(2 ** nb, np.int64)
    for a, b in zip(words[:-1], words[1:]):
        if lower[b] - upper[a] <= half + 1e-9 * max(1.0, abs(upper[a])):  # the stripes meet
            flips_hi[a] = flips_lo[b] = a ^ b
    return CodeStripes(centre, lower, upper, flips_lo, flips_hi)


def _code_bits(frames: np.ndarray, code_index: Sequence[int], inverse_index: Sequence[int] | None,
               threshold: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(code_idx, inverse_idx (-1: none), threshold (H, W) float32) for the kernel, or ValueError."""
    ci = np.asarray(code_index, dtype=np.int64)
    if inverse_index is None:
        ii = np.full(ci.size, -1, np.int64)
        if threshold is None:
            raise ValueError("gray_code_order needs inverse frames or a threshold image")
    else:
        ii = np.asarray(inverse_index, dtype=np.int64)
        if ii.size != ci.size:
            raise ValueError(f"{ci.size} code frames but {ii.size} inverse frames; expected one inverse per bit")
    thr = (np.zeros(frames.shape[1:], np.float32) if threshold is None
           else np.ascontiguousarray(threshold, dtype=np.float32))
    return ci, ii, thr


def gray_code_order(frames: np.ndarray, code_index: Sequence[int], wrapped: np.ndarray, period: float,
                    stripes: CodeStripes, inverse_index: Sequence[int] | None = None,
                    threshold: np.ndarray | None = None, coordinate: np.ndarray | None = None,
                    contrast: np.ndarray | None = None) -> CodeUnwrapped:
    """Fringe order from Gray (or binary) code frames and the wrapped phase together.

    Each bit is 1 where the code frame is brighter than its inverse frame (``inverse_index``)
    or, without inverse frames, than ``threshold`` (H, W) (e.g. the phase frames' average);
    its difference ``D_q`` (frame minus inverse or threshold, counts) is the bit's analog value.
    The codeword selects a stripe ``[lo, hi]`` (``stripes``, see :func:`code_stripes`). The code's
    own estimate of the projector coordinate is

    ``w_c = lo + (hi - lo) D_lo / (D_lo + D_hi)``

    with ``D_lo`` (``D_hi``) the largest ``|D_q|`` of the bits that change at the stripe's
    lower (upper) edge, or a clear bit's ``|D|`` (``contrast`` (H, W), else the pixel's largest
    ``|D_q|``) for an edge without a neighbouring stripe: the stripe centre inside the stripe,
    where the bits are clear, moving to the edge the pixel sits at, whose bits fade there. Where
    every bit of one edge also changes at the other (a binary code's last bit), that edge counts
    as clear while the other edge's own bits are (``D_hi = max(D_hi, contrast - min |D_own lo|)``).
    A binary code's edge where every bit changes leaves no clear bit in the pixel: pass
    ``contrast``, a clear bit's ``|D|`` (the pixel's largest ``|D_q|`` where that is larger),
    e.g. ``2 B`` of the phase frames with inverse frames, ``B`` without (code and fringes spanning
    the same projector range; blur lowers a fine fringe's ``B``, so it rather underestimates).
    The fringe
    order puts the unwrapped coordinate nearest ``w_c``:
    ``k = floor(w_c / T - phi / 2 pi + 1/2)`` (Eq. 1.5; ties, ``|w - w_c| = T/2``, go up).

    Boundary convention: a pixel whose phase is ~0 on a period boundary that is also a stripe
    edge (stripes as wide as the period, aligned with the phase wraps) takes the order of the
    edge its fading bit marks, never a coin toss between ``k`` and ``k + 1``: with ``w_c`` at
    that edge the tie is half a period away. Exact while ``|w - w_c| < T/2``: always for stripes
    of at most half a period (the complementary code), and for a period-wide code where the
    edge bits fade over more than the phase noise. Stripes wider than the period leave the order
    open inside the stripe: pass ``coordinate`` (H, W) (the code's sub-stripe estimate of
    ``w``, px, NaN where unknown, :func:`fringe3d.unwrap.sub_stripe.sub_stripe_coordinate`),
    which then replaces ``w_c``; pixels without one get residual inf (stripes wider than ``T`` by
    more than one projector pixel, the margin of the outermost stripes, which reach the
    projector's pixel edges).

    The residual (fringe periods) is the unwrapped coordinate's distance outside the stripe
    ``[lo, hi]`` (with ``coordinate``: from ``coordinate``): ~0 where code and phase agree; a
    misread code bit that moves the pixel to a stripe of the other half period (complementary
    code) leaves it up to 1/4. It is inf where a bit that does not change at the edge the pixel
    is nearest is weak (``|D_q|`` below half the pixel's largest): no stripe has such a word
    next to its edge (a binary code read where several bits change and some are misread, which
    gives the word of a stripe two away, consistent with the phase). Mask pixels above
    :data:`MAX_CODE_RESIDUAL`.

    frames (F, H, W) any real dtype; wrapped (H, W) rad. Returns :class:`CodeUnwrapped`.

    Parameters
    ----------
    frames : (F, H, W) ndarray
        Camera frames, any real dtype.
    code_index : sequence of int
        Index into ``frames`` of each code bit's frame, most significant bit first.
    wrapped : (H, W) array_like
        Wrapped phase (rad) of period ``period``.
    period : float
        Fringe period ``T`` (projector px).
    stripes : CodeStripes
        The code's stripe table (:func:`code_stripes`), ``2**B`` entries.
    inverse_index : sequence of int, optional
        Index of each bit's inverse frame (one per bit).
    threshold : (H, W) array_like, optional
        Bit threshold (counts) where there are no inverse frames.
    coordinate : (H, W) array_like, optional
        Sub-stripe estimate of ``w`` (px, NaN unknown) that replaces ``w_c``.
    contrast : (H, W) array_like, optional
        A clear bit's ``|D|`` (counts).

    Returns
    -------
    CodeUnwrapped
        Absolute phase (rad), fringe order, validity and residual (fringe periods), each (H, W).
    """
    frames = np.asarray(frames)
    ci, ii, thr = _code_bits(frames, code_index, inverse_index, threshold)
    if stripes.centre.size != 2 ** ci.size:
        raise ValueError(f"codeword table has {stripes.centre.size} entries, expected 2**{ci.size}")
    wr = np.ascontiguousarray(wrapped, dtype=np.float32)
    if wr.shape != frames.shape[1:] or thr.shape != frames.shape[1:]:
        raise ValueError(f"wrapped phase {wr.shape} / threshold {thr.shape} must match frames {frames.shape[1:]}")
    coord = (np.empty((0, 0)) if coordinate is None else np.ascontiguousarray(coordinate, np.float64))
    ref = np.empty((0, 0), np.float32) if contrast is None else np.ascontiguousarray(contrast, np.float32)
    if contrast is not None and ref.shape != wr.shape:
        raise ValueError(f"contrast {ref.shape} must match frames {frames.shape[1:]}")
    if coordinate is not None and coord.shape != wr.shape:
        raise ValueError(f"coordinate {coord.shape} must match frames {frames.shape[1:]}")
    order = np.empty(wr.shape, np.int32)
    phase = np.empty(wr.shape, np.float32)
    valid = np.empty(wr.shape, np.bool_)
    residual = np.empty(wr.shape, np.float32)
    def table(t: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(t, np.float64)

    kernels.code_order_kernel(frames, ci, ii, thr, wr, float(period), table(stripes.centre), table(stripes.lower),
                              table(stripes.upper), np.ascontiguousarray(stripes.lower_bits, np.int64),
                              np.ascontiguousarray(stripes.upper_bits, np.int64), ref, coord,
                              order, phase, valid, residual)
    return CodeUnwrapped(phase, order, valid, residual)


# -- fused three-frequency decode (the calibration set's hot path) ---------------------------
class FusedResult(NamedTuple):
    """Output of :func:`three_frequency_decode`, each (H, W): absolute phase float32 (NaN
    where invalid), wrapped phase of the narrowest period float32, its modulation and average
    float32, validity mask bool, texture float32 (average + modulation; None from the
    decoder's pass with its assessment, :func:`fringe3d.decode._fused_assess.three_frequency_assess`)."""

    phase: np.ndarray
    wrapped: np.ndarray
    modulation: np.ndarray
    average: np.ndarray
    mask: np.ndarray
    texture: np.ndarray | None


def three_frequency_decode(frames: np.ndarray, indices: Sequence[Sequence[int]], shifts: Sequence[Sequence[float]],
                           periods: Sequence[float] = (18.0, 21.0, 144.0),
                           w_range: tuple[float, float] | None = None, min_modulation: float = 0.0,
                           saturation_level: float = math.inf,
                           max_residual: float = 0.5 * math.pi, backend: str = "cpu",
                           device_output: bool = False) -> FusedResult:
    """Three-frequency heterodyne decode of raw frames in one fused pass (numba).

    Per pixel: the three least-squares wrapped phases (Eq. 2.4; e.g. 9 + 3 + 3 steps), the
    beats (18 & 21 -> 126, 126 & 144 -> 1008), the absolute phase of the narrowest period,
    its modulation and average, and the mask (every group's modulation >= ``min_modulation``
    and no frame >= ``saturation_level``, and both unwrapping steps consistent: the scaled
    coarse phase minus the fine phase lies within ``max_residual`` rad of a multiple of 2π;
    near π the fringe order is a coin toss, as on mixed silhouette pixels). No full-size
    intermediate arrays.

    frames (F, H, W) uint8/uint16/float; ``indices[g]`` / ``shifts[g]`` the frame indices and
    shifts (rad) of group g, narrowest period first. Equals :func:`heterodyne` applied to
    :func:`fringe3d.phase.psp.wrapped_phase` results (tested).

    ``backend="cuda"`` runs the same decode on a CUDA device (:func:`fringe3d.gpu.ops.three_frequency`;
    :class:`fringe3d.gpu.CudaUnavailableError` without one); it also takes ``(C, F, H, W)``
    cycles (host or device array) and returns (C, H, W) maps, left on the device with
    ``device_output``.

    Parameters
    ----------
    frames : (F, H, W) ndarray
        Camera frames, uint8/uint16/float (``(C, F, H, W)`` with ``backend="cuda"``).
    indices : sequence of 3 sequences of int
        Frame indices of each group, narrowest period first.
    shifts : sequence of 3 sequences of float
        Phase shifts (rad) of each group's frames.
    periods : sequence of 3 float
        Fringe periods (projector px), narrowest first.
    w_range : tuple of float, optional
        ``(w_min, w_max)`` projector fringe coordinates covered, see :func:`coarse_window`.
    min_modulation : float
        Smallest modulation of every group for a valid pixel (frames' units).
    saturation_level : float
        A pixel with any frame at or above this value is invalid (default: no check).
    max_residual : float
        Largest accepted distance (rad) of each unwrapping step from a multiple of 2π.
    backend : {"cpu", "cuda"}
        Where to decode.
    device_output : bool
        ``backend="cuda"`` only: leave the outputs on the device.

    Returns
    -------
    FusedResult
        Absolute phase (rad), wrapped phase, modulation, average, mask and texture, each (H, W).
    """
    cuda = check_backend(backend) == "cuda"
    if not cuda:
        frames = as_frame_stack(frames)
    if len(indices) != 3 or len(shifts) != 3 or len(periods) != 3:
        raise ValueError("three_frequency_decode needs exactly three groups (indices, shifts, periods)")
    idx = [np.asarray(i, dtype=np.int64) for i in indices]
    for i in idx:
        if i.size and (i.min() < 0 or i.max() >= tuple(frames.shape)[-3]):
            raise ValueError(f"frame index {i.tolist()} out of range for {tuple(frames.shape)[-3]} frames")
    coef = [lsq_coefficients(s).astype(np.float32) for s in shifts]
    for i, c in zip(idx, coef):
        if c.shape[1] != i.size:
            raise ValueError(f"group has {i.size} frames but {c.shape[1]} shifts")
    beats, signs = beat_chain(periods)
    lower = coarse_window(beats[-1], w_range)
    params = np.array([signs[0], signs[1], beats[1] / beats[0], beats[0] / periods[0], lower,
                       float(min_modulation), min(float(saturation_level), 3e38), float(max_residual)],
                      dtype=np.float32)
    if cuda:
        from fringe3d.gpu import ops

        return FusedResult(*ops.three_frequency(frames, idx, coef, params, device_output=device_output))
    h, w = frames.shape[1:]
    out = FusedResult(np.empty((h, w), np.float32), np.empty((h, w), np.float32), np.empty((h, w), np.float32),
                      np.empty((h, w), np.float32), np.empty((h, w), np.bool_), np.empty((h, w), np.float32))
    kernels.three_frequency_kernel(frames, idx[0], coef[0], idx[1], coef[1], idx[2], coef[2], params,
                                   out.phase, out.wrapped, out.modulation, out.average, out.mask, out.texture)
    return out
