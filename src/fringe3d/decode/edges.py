"""Edge and mixed-pixel masking: the per-pixel quality map of a decoded direction.

A pixel whose phase is not the nominal sinusoid's gives a wrong point however good the rest
of the chain is. Several tests find such pixels; each sets one bit of a uint8 quality map
(0 = good, the point is kept):

============  =====  ==================================================================
bit           value  reason
============  =====  ==================================================================
INVALID       1      the method's own mask: low modulation, saturated, undecodable code
EDGE          2      fringe coordinate ``w`` within ``margin`` of the pattern's extent
                     (lit within a blur width of the projector's border, or by its spill)
INCONSISTENT  4      the multi-frequency phases disagree: ``max_g |wrap(phi_g - Phi T_0/T_g)|``
                     above ``max_disagreement`` rad (the unwrapping residual)
GRADIENT      8      ``w`` jumps to a 4-neighbour by more than ``gradient_ratio`` times the
                     local (5 x 5 median) jump and ``gradient_floor`` px (depth edges),
                     grown by one pixel
MOD_DROP      16     fringe contrast ``B / A`` below ``modulation_ratio`` times the largest
                     contrast of the valid 5 x 5 neighbours (silhouette, shadow-edge and
                     spill pixels; independent of the albedo)
RIM           32     within ``rim`` pixels (4-connected) of an INVALID pixel: the rim of a
                     silhouette, shadow or unlit region, mixed by the pixel footprint and blur
ORDER         64     the fringe order's two estimates disagree (the method's
                     ``order_inconsistent``): code + phase, the unwrapped ``w`` lies more than
                     ``max_code_residual`` periods outside the codeword's stripe; hierarchical /
                     heterodyne, a rounding residual above ``max_residual`` rad. Set whatever
                     ``edge_mask`` says (the pixel's order, not its edge, is in doubt)
SATURATED     128    (with INVALID) clipping broke the pixel: a phase biased beyond its
                     bound (:mod:`fringe3d.phase.clipping`) or a code bit whose frame and
                     reference are both clipped (:mod:`fringe3d.decode.methods.code_only`)
============  =====  ==================================================================

The EDGE band holds the pixels lit by projector pixels within ``margin`` (projector px) of the
projector's border. With one fringe direction of angle ``a`` only ``w = v_p cos a + u_p sin a`` is
known: a pixel is in the band when the line ``w = const`` misses the projector shrunk by
``margin`` on every side, i.e. ``w`` lies within ``margin (|cos a| + |sin a|)``
(:func:`oblique_factor`) of the extent ``[w_min, w_max] +- (|cos a| + |sin a|) / 2`` (pixel edges
of the projector; :func:`fringe3d.patterns.conventions.w_range` gives the centres). For a
vertical or horizontal direction that is the whole band; for an oblique one it is only the band
near the two corners the line reaches last: a pixel near the other borders has a ``w`` the
projector's interior also has, so one coordinate cannot tell. With two non-parallel directions
decoded both coordinates ``(u_p, v_p)`` are known (:func:`projector_position`) and the decoder
marks the band along every border (:func:`border_band`). The default margin is
``2 px + 2 sigma_b`` with ``sigma_b`` the effective Gaussian blur (projector px) estimated from the
modulation ratio of two periods (:func:`estimate_blur`).

The neighbourhood filters are the numba ones of :mod:`fringe3d.decode._stencils` (equal to
their ``scipy.ndimage`` counterparts, several times faster), so the quality map of a 1280 x 1024
frame costs a few milliseconds; :func:`fused_quality_map` gives the same map of one direction
(no multi-frequency residual) in three passes, for the fused 3-step path of long sequences, and
:func:`quality_map` uses it with one more pass for ORDER, SATURATED and INCONSISTENT on the
decoder's float32 maps. :func:`disagreement` and the median of :func:`estimate_blur` are numba
passes too (no complex or full-size temporaries).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numba
import numpy as np

from fringe3d.decode._disagreement_kernel import max_wrapped_residual
from fringe3d.decode._fused_quality import finish_quality_map, finished_quality_map, fused_quality_map
from fringe3d.decode._ratio_median import ratio_median
from fringe3d.decode._stencils import dilate3, erode_cross, max5, median5, neighbour_jump

INVALID = 1
EDGE = 2
INCONSISTENT = 4
GRADIENT = 8
MOD_DROP = 16
RIM = 32
ORDER = 64
SATURATED = 128

#: Bit -> name, for summaries and docs.
BITS = {INVALID: "invalid", EDGE: "edge", INCONSISTENT: "inconsistent", GRADIENT: "gradient", MOD_DROP: "mod_drop",
        RIM: "rim", ORDER: "order", SATURATED: "saturated"}

#: Base margin (projector px) added to the blur width.
BASE_MARGIN = 2.0


@dataclass(frozen=True)
class QualityTests:
    """The thresholds of the quality map's tests (:func:`quality_map`), passed whole.

    Attributes
    ----------
    margin : float
        EDGE band width (projector px).
    max_disagreement : float
        INCONSISTENT threshold on the unwrapping residual (rad; ``inf``: off).
    gradient_ratio : float
        GRADIENT: a jump of ``w`` over this many times the local median jump ...
    gradient_floor : float
        ... and over this floor (projector px).
    modulation_ratio : float
        MOD_DROP: contrast ``B / A`` below this share of the 5 x 5 neighbourhood's largest.
    rim : int
        RIM width in pixels (0: off).

    Examples
    --------
    >>> QualityTests(margin=3.0).rim
    1
    """

    margin: float = BASE_MARGIN
    max_disagreement: float = math.inf
    gradient_ratio: float = 4.0
    gradient_floor: float = 1.0
    modulation_ratio: float = 0.5
    rim: int = 1


def estimate_blur(mod_fine: np.ndarray, mod_coarse: np.ndarray, period_fine: float, period_coarse: float,
                  mask: np.ndarray) -> float:
    """Effective Gaussian blur ``sigma_b`` (projector px) from the modulation ratio of two periods.

    A Gaussian blur of ``sigma_b`` multiplies the modulation of period ``T`` by
    ``exp(-2 pi^2 sigma_b^2 / T^2)``, so with ``r = median(B_fine / B_coarse)`` over ``mask``:
    ``sigma_b = sqrt(-ln r / (2 pi^2 (1/T_fine^2 - 1/T_coarse^2)))`` (0 when ``r >= 1``). It
    lumps projector defocus, camera blur and pixel integration, as seen in projector pixels.
    """
    if not period_coarse > period_fine:
        return 0.0
    if np.asarray(mod_fine).dtype == np.float32 and np.asarray(mod_coarse).dtype == np.float32:
        r = ratio_median(mod_fine, mod_coarse, mask)  # two histogram passes, the same median (NaN: none)
    else:
        m = np.asarray(mask, bool) & (mod_coarse > 0)
        if not m.any():
            return 0.0
        r = float(np.median(mod_fine[m] / mod_coarse[m]))
    if not 0 < r < 1:
        return 0.0
    den = 2 * math.pi ** 2 * (1 / period_fine ** 2 - 1 / period_coarse ** 2)
    return float(min(math.sqrt(-math.log(r) / den), period_fine))


def edge_band(w: np.ndarray, extent: tuple[float, float], margin: float) -> np.ndarray:
    """(H, W) bool: ``w`` (px) within ``margin`` of ``extent = (lo, hi)`` or outside it (NaN: False)."""
    lo, hi = extent
    with np.errstate(invalid="ignore"):
        return (w < lo + margin) | (w > hi - margin)


def oblique_factor(angle: float) -> float:
    """``|cos a| + |sin a|``: the range of ``w = v cos a + u sin a`` over a unit square (1 for a
    vertical or horizontal direction, sqrt 2 at 45 deg); scales margins and pixel extents along ``w``."""
    return float(round(abs(math.cos(angle)) + abs(math.sin(angle)), 12))


def edge_margin(option: float | None, blur: float = 0.0) -> float:
    """The edge band's width (projector px, before :func:`oblique_factor`): the decode option
    ``edge_margin`` when given, else :data:`BASE_MARGIN` plus twice the estimated ``blur`` (px;
    0 where a single period gives no estimate, as on the fused 3-step path)."""
    return BASE_MARGIN + 2.0 * blur if option is None else float(option)


def pixel_extent(lo: float, hi: float, angle: float) -> tuple[float, float]:
    """The pattern's extent along ``w`` from pixel edge to pixel edge: its pixel-centre range
    ``[lo, hi]`` (px) widened by half a pixel's extent along ``w`` (:func:`oblique_factor`)."""
    f = oblique_factor(angle)
    return lo - 0.5 * f, hi + 0.5 * f


def projector_position(w1: np.ndarray, angle1: float, w2: np.ndarray, angle2: float) -> tuple[np.ndarray, np.ndarray]:
    """(u_p, v_p) (H, W) float32 projector pixel from the fringe coordinates of two non-parallel
    directions: solves ``w_i = v_p cos a_i + u_p sin a_i`` (Eq. 2.1) for both."""
    c1, s1, c2, s2 = math.cos(angle1), math.sin(angle1), math.cos(angle2), math.sin(angle2)
    det = s1 * c2 - s2 * c1
    if abs(det) < 1e-6:
        raise ValueError(f"fringe directions at {angle1:.4g} and {angle2:.4g} rad are parallel; "
                         "they do not locate a projector pixel")
    w1, w2 = np.asarray(w1, np.float64), np.asarray(w2, np.float64)
    return ((w1 * c2 - w2 * c1) / det).astype(np.float32), ((s1 * w2 - s2 * w1) / det).astype(np.float32)


def border_band(u: np.ndarray, v: np.ndarray, width: int, height: int, margin: float) -> np.ndarray:
    """(H, W) bool: projector pixel ``(u, v)`` within ``margin`` px of the border of a
    ``width x height`` projector (pixel edges at -1/2 and size - 1/2) or outside it (NaN: False)."""
    with np.errstate(invalid="ignore"):
        return ((u < -0.5 + margin) | (u > width - 0.5 - margin)
                | (v < -0.5 + margin) | (v > height - 0.5 - margin))


def disagreement(phase: np.ndarray, period: float, wrapped: Sequence[np.ndarray],
                 periods: Sequence[float]) -> np.ndarray:
    """(H, W) float32 largest unwrapping residual (rad) over the coarser groups:
    ``max_g |wrap(phi_g - Phi T_0 / T_g)|`` with ``Phi`` the absolute phase of period ``T_0``,
    ``wrap(x) = x - 2 pi round(x / 2 pi)`` in float64 per pixel (one numba pass per group); 0
    where every residual is NaN."""
    out = np.zeros(np.shape(phase), np.float32)
    for phi_g, t_g in zip(wrapped, periods):
        max_wrapped_residual(np.asarray(phase), np.asarray(phi_g), period / t_g, out)
    return out


def _neighbour_jump(w: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(H, W) float32 largest ``|w - w_neighbour|`` over the valid 4-neighbours (0 without any)."""
    return neighbour_jump(w, valid)


def gradient_jump(w: np.ndarray, valid: np.ndarray, ratio: float, floor: float) -> np.ndarray:
    """(H, W) bool: the jump of ``w`` (px) to a valid 4-neighbour exceeds ``ratio`` times its
    5 x 5 median and ``floor`` px (depth discontinuities; both sides of the jump are set), grown
    by one pixel (8-connected)."""
    g = _neighbour_jump(w, valid)
    ref = median5(g)
    # grown by one pixel: a mixed pixel halfway up a step has two half-size jumps, its neighbours a full one
    return valid & dilate3(valid & (g > np.maximum(ratio * ref, floor)))


def modulation_drop(modulation: np.ndarray, average: np.ndarray, valid: np.ndarray, ratio: float) -> np.ndarray:
    """(H, W) bool: fringe contrast ``B / A`` below ``ratio`` times the largest contrast of the
    valid pixels in the 5 x 5 neighbourhood.

    The contrast does not depend on the albedo, so texture does not trigger it; it drops where a
    pixel mixes two phases (a silhouette before a lit background: the fringes partly cancel while
    the averages add) and where the light is projector spill beyond its border.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(valid & (average > 0), modulation / average, 0.0).astype(np.float32)
    ref = max5(c)
    return valid & (c < ratio * ref)


def quality_map(mask: np.ndarray, w: np.ndarray | None = None, extent: tuple[float, float] | None = None,
                modulation: np.ndarray | None = None, average: np.ndarray | None = None,
                residual: np.ndarray | None = None, order: np.ndarray | None = None,
                saturated: np.ndarray | None = None, tests: QualityTests = QualityTests()) -> np.ndarray:
    """(H, W) uint8 quality map (bits of the module docstring) of one direction.

    With float32 ``w``, ``modulation`` and ``average`` and ``w`` finite on the valid pixels (the
    decoder's case) the map comes from four numba passes (:func:`_quality_map_fused`), else
    from one whole-image pass per bit; the bits are the same.

    Parameters
    ----------
    mask : (H, W) bool
        The method's validity mask (False sets INVALID).
    order : (H, W) bool, optional
        Pixels of ``mask`` whose fringe-order estimates disagree (sets ORDER; the other tests
        then treat them as invalid, so RIM grows around them).
    w : (H, W) float, optional
        Projector fringe coordinate ``w = Phi T / 2 pi`` (px); None skips EDGE and GRADIENT.
    extent : (lo, hi), optional
        The pattern's extent along ``w`` (px); None skips EDGE.
    modulation, average : (H, W) float, optional
        Modulation ``B`` and average ``A``; None skips MOD_DROP.
    residual : (H, W) float, optional
        Unwrapping residual (rad, :func:`disagreement`); None skips INCONSISTENT.
    saturated : (H, W) bool, optional
        Where clipping broke the pixel; sets SATURATED on the invalid ones.
    tests : QualityTests
        The tests' thresholds (EDGE margin, INCONSISTENT, GRADIENT, MOD_DROP, RIM).

    Returns
    -------
    (H, W) uint8
        The bits; 0 where the pixel passed every test.
    """
    if w is not None and modulation is not None and average is not None and all(
            np.asarray(x).dtype == np.float32 for x in (w, modulation, average)):
        valid = np.asarray(mask, bool)
        if order is not None:
            valid = valid & ~np.asarray(order, bool)
        if not nan_where(w, valid):
            return _quality_map_fused(mask, valid, w, extent, modulation, average, residual, order, saturated,
                                      tests)
    margin, max_disagreement, rim = tests.margin, tests.max_disagreement, tests.rim
    valid = np.asarray(mask, bool)
    q = _bits(~valid, INVALID)
    if saturated is not None:
        q |= _bits(~valid & saturated, SATURATED)
    if order is not None:
        bad = valid & np.asarray(order, bool)
        valid = valid & ~bad
        q |= _bits(bad, ORDER)
    if w is not None and extent is not None:
        q |= _bits(valid & edge_band(w, extent, margin), EDGE)
    if residual is not None and math.isfinite(max_disagreement):
        with np.errstate(invalid="ignore"):
            q |= _bits(valid & (residual > max_disagreement), INCONSISTENT)
    if w is not None:
        q |= _bits(gradient_jump(w, valid, tests.gradient_ratio, tests.gradient_floor), GRADIENT)
    if modulation is not None and average is not None:
        q |= _bits(modulation_drop(modulation, average, valid, tests.modulation_ratio), MOD_DROP)
    if rim > 0:
        q |= _bits(rim_of_invalid(valid, rim), RIM)
    return q


def quality_map_finite(mask: np.ndarray, w: np.ndarray, extent: tuple[float, float] | None,
                       modulation: np.ndarray, average: np.ndarray, residual: np.ndarray | None = None,
                       saturated: np.ndarray | None = None, tests: QualityTests = QualityTests()) -> np.ndarray:
    """:func:`quality_map` (no ``order``) of a ``w`` the caller knows to be finite wherever
    ``mask`` is set (the decoder's fused pass tells it): the map of :func:`quality_map`, without
    its pass that looks for a NaN of ``w`` on the mask.

    Parameters
    ----------
    mask : (H, W) bool
        The method's validity mask; ``w`` is finite on it.
    w : (H, W) float
        Projector fringe coordinate (px).
    extent : (lo, hi), optional
        The pattern's extent along ``w`` (px); None skips EDGE.
    modulation, average : (H, W) float
        Modulation ``B`` and average ``A``.
    residual : (H, W) float, optional
        Unwrapping residual (rad); None skips INCONSISTENT.
    saturated : (H, W) bool, optional
        Where clipping broke the pixel.
    tests : QualityTests
        The tests' thresholds.

    Returns
    -------
    (H, W) uint8
        The bits of :func:`quality_map`.
    """
    if not all(np.asarray(x).dtype == np.float32 for x in (w, modulation, average)):
        return quality_map(mask, w, extent, modulation, average, residual, saturated=saturated, tests=tests)
    if tests.rim == 1 and math.isfinite(np.float32(tests.gradient_ratio)) and (
            residual is None or np.asarray(residual).dtype == np.float32):  # every row finished as it is made
        lo, hi = extent if extent is not None else (-math.inf, math.inf)
        margin = tests.margin if extent is not None else 0.0
        return finished_quality_map(mask, w, (lo + margin, hi - margin), modulation, average, saturated, residual,
                                    (tests.gradient_ratio, tests.gradient_floor, tests.modulation_ratio,
                                     tests.max_disagreement))
    valid = np.asarray(mask, bool)
    return _quality_map_fused(mask, valid, w, extent, modulation, average, residual, None, saturated, tests)


def _quality_map_fused(mask: np.ndarray, valid: np.ndarray, w: np.ndarray, extent: tuple[float, float] | None,
                       modulation: np.ndarray, average: np.ndarray, residual: np.ndarray | None,
                       order: np.ndarray | None, saturated: np.ndarray | None, tests: QualityTests) -> np.ndarray:
    """:func:`quality_map` from four numba passes (float32 ``w``, ``modulation``, ``average``,
    ``w`` finite on ``valid = mask & ~order``): the bits of :func:`fused_quality_map` on
    ``valid``, then ORDER, SATURATED and INCONSISTENT (:func:`finish_quality_map`); equal bit for
    bit (``tests/test_assess_kernels.py``)."""
    band = (extent, tests.margin) if extent is not None else ((-math.inf, math.inf), 0.0)
    q = fused_quality_map(valid, w, band[0], band[1], modulation, average, gradient_ratio=tests.gradient_ratio,
                          gradient_floor=tests.gradient_floor, modulation_ratio=tests.modulation_ratio, rim=tests.rim)
    finish_quality_map(q, mask, order, saturated, residual, tests.max_disagreement)
    return q


def order_bits(mask: np.ndarray, order: np.ndarray | None,
               saturated: np.ndarray | None = None) -> np.ndarray:
    """(H, W) uint8: INVALID where ``mask`` is False (with SATURATED where ``saturated`` says
    clipping broke it), ORDER where ``order`` is set on a valid pixel (the map of a direction
    without the edge tests)."""
    valid = np.asarray(mask, bool)
    q = _bits(~valid, INVALID)
    if saturated is not None:
        q |= _bits(~valid & saturated, SATURATED)
    if order is not None:
        q |= _bits(valid & np.asarray(order, bool), ORDER)
    return q


def _bits(flag: np.ndarray, bit: int) -> np.ndarray:
    """(H, W) uint8: ``bit`` where ``flag`` is set, else 0 (no int64 temporaries)."""
    return flag.astype(np.uint8) * np.uint8(bit)


def rim_of_invalid(valid: np.ndarray, width: int) -> np.ndarray:
    """(H, W) bool: valid pixels within ``width`` 4-connected steps of an invalid one (the image's
    own border does not count)."""
    return valid & ~erode_cross(valid, int(width))


def bit_counts(q: np.ndarray) -> dict[str, int]:
    """Pixels per reason (a pixel may count under several)."""
    q = np.asarray(q)
    if q.dtype != np.uint8 or q.ndim != 2:
        return {name: int(np.count_nonzero(q & bit)) for bit, name in BITS.items()}
    counts = np.zeros((max(1, q.shape[0]), 8), np.int64)
    _bit_count_rows(np.ascontiguousarray(q), counts)
    total = counts.sum(axis=0)
    return {name: int(total[bit.bit_length() - 1]) for bit, name in BITS.items()}


@numba.njit(cache=True)
def _bit_count_rows(q, counts):  # pragma: no cover - compiled
    """``counts[i, b]``: the pixels of row ``i`` of ``q`` (H, W) uint8 with bit ``b`` set, in one
    pass: eight pixels a 64-bit word, bit ``b`` of each byte summed in the byte lanes of one
    word for up to 255 words, then the lanes added (~0.1 ms a 1280 x 1024 map: one thread, no
    parallel region to start, or to wait for on a busy machine)."""
    H, W = q.shape
    nw = W // 8
    ones = np.uint64(0x0101010101010101)
    low = np.uint64(0x00FF00FF00FF00FF)
    add4 = np.uint64(0x0001000100010001)
    for i in range(H):
        words = q[i, :nw * 8].view(np.uint64)
        c = np.zeros(8, np.int64)
        for k0 in range(0, nw, 255):
            part = words[k0:min(nw, k0 + 255)]
            a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = np.uint64(0)
            for k in range(part.shape[0]):
                x = part[k]
                a0 += x & ones
                a1 += (x >> np.uint64(1)) & ones
                a2 += (x >> np.uint64(2)) & ones
                a3 += (x >> np.uint64(3)) & ones
                a4 += (x >> np.uint64(4)) & ones
                a5 += (x >> np.uint64(5)) & ones
                a6 += (x >> np.uint64(6)) & ones
                a7 += (x >> np.uint64(7)) & ones
            for b, a in enumerate((a0, a1, a2, a3, a4, a5, a6, a7)):
                pairs = (a & low) + ((a >> np.uint64(8)) & low)  # four 16-bit lanes of at most 510
                c[b] += np.int64((pairs * add4) >> np.uint64(48))
        for j in range(nw * 8, W):
            x = q[i, j]
            for b in range(8):
                c[b] += (x >> b) & 1
        for b in range(8):
            counts[i, b] = c[b]


def nan_where(x: np.ndarray, where: np.ndarray) -> bool:
    """``np.isnan(x)[where].any()`` of (H, W) ``x`` and bool ``where``, in one pass without temporaries."""
    x, where = np.asarray(x), np.asarray(where, bool)
    if x.ndim != 2 or x.dtype not in (np.float32, np.float64) or not x.dtype.isnative or x.shape != where.shape:
        return bool(np.isnan(x, where=where, out=np.zeros(np.shape(where), bool)).any())
    found = np.zeros(max(1, x.shape[0]), np.uint8)
    _nan_rows(np.ascontiguousarray(x), np.ascontiguousarray(where), found)
    return bool(found.any())


@numba.njit(cache=True)
def _nan_rows(x, where, found):  # pragma: no cover - compiled
    """``found[i]``: row ``i`` of ``x`` has a NaN where ``where`` (one thread, as :func:`_bit_count_rows`)."""
    H, W = x.shape
    for i in range(H):
        f = np.uint8(0)
        for j in range(W):
            v = x[i, j]
            f |= np.uint8(where[i, j]) & np.uint8(v != v)
        found[i] = f
