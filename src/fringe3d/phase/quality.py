"""Which pixels carry a trustworthy phase: modulation threshold, saturation, dark frames.

A pixel is valid when its fringe modulation B (Eq. 2.3) reaches ``min_modulation`` and
saturation did not break it: :func:`validity_mask` masks any frame at the sensor's maximum
code; the decoder masks only what clipping breaks (:mod:`fringe3d.phase.clipping` for phase
groups, both frames of a code pair clipped for code bits). Whole frames that are dark or
largely saturated are reported with a :class:`FrameQualityWarning`, except frames dark by
design (a black reference frame) and binary frames, whose full-scale pixels are by design.
"""
from __future__ import annotations

import math
import warnings
from typing import Sequence

import numpy as np

from fringe3d.utils.warning_types import DataQualityWarning

#: Default modulation threshold as a fraction of the full scale.
DEFAULT_MIN_MODULATION_FRACTION = 0.02
#: A frame counts as (nearly) dark when its DARK_PERCENTILE-th percentile pixel is below this
#: fraction of the full scale (a percentile, not the maximum, so a few hot pixels or noise
#: spikes in an otherwise black frame do not hide it).
DARK_FRACTION = 0.02
DARK_PERCENTILE = 99.0
#: Warn when more than this fraction of a frame's pixels are saturated.
SATURATED_WARN_FRACTION = 0.05


class FrameQualityWarning(DataQualityWarning):
    """Frames that are all dark or heavily saturated (their pixels are masked); a
    :class:`fringe3d.utils.warning_types.DataQualityWarning` (so a ``UserWarning``)."""


def full_scale(frames: np.ndarray, bit_depth: int | None = None) -> float:
    """The value a fully exposed pixel reaches: ``2**bit_depth - 1`` for integer frames
    (bit depth defaults to the dtype's: 8 for uint8, 16 for uint16); for float frames
    ``2**bit_depth - 1`` when given, else 1.0 (frames are taken as normalised to [0, 1])."""
    if bit_depth is not None:
        if not 1 <= int(bit_depth) <= 32:
            raise ValueError(f"bit_depth must be between 1 and 32, got {bit_depth}")
        return float(2 ** int(bit_depth) - 1)
    if frames.dtype.kind in "ui":
        return float(np.iinfo(frames.dtype).max)
    return 1.0


def saturation_level(frames: np.ndarray, bit_depth: int | None = None) -> float:
    """Value at or above which a pixel counts as saturated; ``inf`` (no check) for float frames
    without a stated bit depth."""
    if frames.dtype.kind == "f" and bit_depth is None:
        return float("inf")
    return full_scale(frames, bit_depth)


def default_min_modulation(frames: np.ndarray, bit_depth: int | None = None) -> float:
    """2 % of :func:`full_scale` (5.1 counts for 8-bit frames)."""
    return DEFAULT_MIN_MODULATION_FRACTION * full_scale(frames, bit_depth)


def validity_mask(average: np.ndarray, modulation: np.ndarray, frames: np.ndarray | None = None,
                  bit_depth: int | None = None, min_modulation: float | None = None,
                  saturated: np.ndarray | None = None, index=None) -> np.ndarray:
    """(H, W) bool: modulation >= ``min_modulation`` and not saturated, finite average.

    Parameters
    ----------
    average, modulation : (H, W) float arrays (frames' units).
    frames : (F, H, W) array, optional
        Used for the saturation test (any frame of ``index``, default all, at the max code of
        ``bit_depth``) and for the default threshold.
    bit_depth : int, optional
        Sensor bit depth for the saturation level and the default threshold (default: the
        dtype's, see :func:`full_scale`).
    min_modulation : float, optional
        Default :func:`default_min_modulation` (or 2 % of 1.0 without frames).
    saturated : (H, W) bool, optional
        A precomputed saturation map (e.g. from :func:`fringe3d.phase.psp.wrapped_phase`);
        when given, ``frames`` is not searched for saturation.
    index : (N,) int, optional
        Which frames of ``frames`` the saturation test looks at (default all).

    Returns
    -------
    ndarray
        ``(H, W)`` bool, True where the phase is valid.

    Examples
    --------
    >>> import numpy as np
    >>> validity_mask(np.full((2, 2), 100.0), np.array([[50.0, 1.0], [50.0, 50.0]]), min_modulation=5.0)
    array([[ True, False],
           [ True,  True]])
    """
    modulation = np.asarray(modulation)
    average = np.asarray(average)
    if modulation.shape != average.shape:
        raise ValueError(f"average {average.shape} and modulation {modulation.shape} must have one shape")
    if min_modulation is None:
        min_modulation = (default_min_modulation(frames, bit_depth) if frames is not None
                          else DEFAULT_MIN_MODULATION_FRACTION)
    mask = (modulation >= min_modulation) & np.isfinite(average) & np.isfinite(modulation)
    if saturated is not None:
        mask &= ~np.asarray(saturated, dtype=bool)
    elif frames is not None:
        level = saturation_level(frames, bit_depth)
        if np.isfinite(level):
            sel = frames if index is None else frames[np.asarray(index)]
            mask &= ~(sel >= level).any(axis=0)
    return mask


def _share_at_least(sub: np.ndarray, cut: float) -> np.ndarray:
    """(F,) float64: the share of each row of ``sub`` (F, P) at or above ``cut``; for integer
    counts compared with the integer ``ceil(cut)`` in their own dtype (the same decision as the
    float comparison, without a float64 copy), each row counted by ``np.count_nonzero``."""
    if sub.dtype.kind in "ui":
        info = np.iinfo(sub.dtype)
        k = math.ceil(cut)
        if k > info.max:
            return np.zeros(sub.shape[0])
        if k <= info.min:
            return np.ones(sub.shape[0])
        at = sub >= sub.dtype.type(k)
    else:
        at = sub >= cut
    return np.array([np.count_nonzero(row) for row in at], np.float64) / max(1, sub.shape[1])


def check_frames(frames: np.ndarray, bit_depth: int | None = None, where: str = "frames",
                 dark_by_design: Sequence[int] = (), binary: Sequence[int] = ()) -> dict:
    """Warn (:class:`FrameQualityWarning`) about all-dark or heavily saturated frames.

    Returns ``{"dark": [frame indices], "saturated": [frame indices], "saturated_fraction":
    [...], "frames": F, "full_scale": counts, "dark_by_design": [...]}``. Dark (nearly black):
    the 99th-percentile pixel < 2 % of full scale, so hot pixels and noise spikes do not hide a
    black frame; frames listed in ``dark_by_design`` (a black reference frame, a code frame,
    which is black wherever the scene sees only its off stripes) are not dark frames unless
    every frame is dark. Saturated: more than 5 % of pixels at
    the maximum code, among the frames not in ``binary`` (code, white and black frames: a
    binary frame at full scale is decided by comparison, not biased). The decoder masks the
    pixels whose decision clipping breaks and leaves the rest; dark frames give no modulation.

    Parameters
    ----------
    frames : (F, H, W) ndarray
        Camera frames (integer counts or float).
    bit_depth : int, optional
        Sensor bit depth (default: the dtype's, see :func:`full_scale`).
    where : str
        Prefix naming the frames in the warning messages (e.g. a file name).
    dark_by_design : sequence of int
        Indices of frames that may be dark (black reference, code frames).
    binary : sequence of int
        Indices of binary frames, exempt from the saturation warning.

    Returns
    -------
    dict
        The report described above.
    """
    fs = full_scale(frames, bit_depth)
    level = saturation_level(frames, bit_depth)
    # per-frame statistics on a strided subsample of ~16k pixels (cheap on large frames)
    step = max(1, int(np.sqrt(frames.shape[1] * frames.shape[2] / 16384)))
    sub = np.ascontiguousarray(frames[:, ::step, ::step]).reshape(frames.shape[0], -1)
    # the DARK_PERCENTILE-th percentile is below the cut exactly when fewer than (100 - DARK_PERCENTILE) %
    # of the pixels reach it: one comparison pass, as cheap as the maximum it replaces
    lit_share = _share_at_least(sub, DARK_FRACTION * fs)
    designed = {int(i) for i in dark_by_design}
    dark = [int(i) for i in np.flatnonzero(lit_share < 1.0 - DARK_PERCENTILE / 100.0)]
    if len(dark) < len(lit_share):  # all frames dark is reported whatever their design
        dark = [i for i in dark if i not in designed]
    sat_frac = _share_at_least(sub, level) if np.isfinite(level) else np.zeros(sub.shape[0])
    exempt = {int(i) for i in binary}
    sat = [int(i) for i in np.flatnonzero(sat_frac > SATURATED_WARN_FRACTION) if int(i) not in exempt]
    if dark:
        cut = f"{DARK_PERCENTILE:g}th percentile < {DARK_FRACTION:.0%} of full scale {fs:g}"
        msg = (f"all frames are dark (nearly black: {cut})" if len(dark) == len(lit_share)
               else f"{len(dark)} dark frame(s) (nearly black: {cut}): {dark}")
        warnings.warn(f"{where}: {msg}; affected pixels are masked", FrameQualityWarning, stacklevel=3)
    if sat:
        worst = float(sat_frac[sat].max())
        warnings.warn(f"{where}: {len(sat)} frame(s) with more than {SATURATED_WARN_FRACTION:.0%} saturated "
                      f"pixels (worst {worst:.0%} at level {level:g}): {sat}; pixels are masked where clipping "
                      "biases the phase beyond its noise", FrameQualityWarning, stacklevel=3)
    return {"dark": dark, "saturated": sat, "saturated_fraction": [float(x) for x in sat_frac],
            "frames": int(frames.shape[0]), "full_scale": float(fs), "dark_by_design": sorted(designed)}
