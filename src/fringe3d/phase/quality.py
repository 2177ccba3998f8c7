"""Which pixels carry a trustworthy phase: modulation threshold, saturation, dark frames.

A pixel is valid when its fringe modulation B (Eq. 2.3) reaches ``min_modulation`` and
saturation did not break it: :func:`validity_mask` masks any frame at the sensor's maximum
code; the decoder masks only what clipping breaks (:mod:`fringe3d.phase.clipping` for phase
groups, both frames of a code pair clipped for code bits). Whole frames that are dark or
largely saturated are reported with a :class:`FrameQualityWarning`, except frames dark by
design (a black reference frame) and binary frames, whose full-scale pixels are by design.
"""
from __future__ import annotations

import functools
import math
import warnings
from typing import Sequence

import numba
import numpy as np

from fringe3d.utils._prefetch import prefetch_lines
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
        return float(_int_range(frames.dtype)[1])
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


def _subsample_shares(frames: np.ndarray, step: int, cuts: tuple[float, float]) -> tuple[list[float], list[float]]:
    """The shares (Python floats, one per frame) of the pixels ``frames[:, ::step, ::step]`` at or
    above each of the two ``cuts``: :func:`_share_at_least` of that subsample (the same counts,
    the same float64 divisions), from one compiled pass over the sampled rows (no strided copy)
    for an (F, H, W) array of a native integer, float32 or float64 dtype; numpy's otherwise. A
    cut of ``inf`` counts nothing. Integer frames are compared with ``ceil(cut)`` in their dtype,
    float frames with the cut in their dtype (numpy's comparison with a Python float)."""
    dt = frames.dtype
    nf = frames.shape[0]
    if not (frames.ndim == 3 and dt.isnative and (dt.kind in "ui" or dt in (np.float32, np.float64))):
        sub = np.ascontiguousarray(frames[:, ::step, ::step]).reshape(nf, -1)
        return tuple((_share_at_least(sub, c) if math.isfinite(c) else np.zeros(nf)).tolist()  # type: ignore[return-value]
                     for c in cuts)
    fixed: list[float | None] = []  # a share every frame has whatever its values (0 or 1), else None
    values = []
    for c in cuts:
        if math.isinf(c) and c > 0:
            fixed.append(0.0)
            values.append(dt.type(0))
        elif dt.kind in "ui":
            lo, hi = _int_range(dt)
            k = math.ceil(c)
            fixed.append(0.0 if k > hi else 1.0 if k <= lo else None)
            values.append(dt.type(min(max(k, lo), hi)))
        else:
            fixed.append(None)
            values.append(dt.type(c))
    counts = np.zeros((2, nf), np.int64)
    _count_at_least(frames, step, values[0], values[1], counts)
    n = max(1, -(-frames.shape[1] // step) * -(-frames.shape[2] // step))
    # int / int is the correctly rounded quotient, as float64 count / float64 n
    return tuple([f] * nf if f is not None else [c / n for c in row]  # type: ignore[return-value]
                 for f, row in zip(fixed, counts.tolist()))


@functools.lru_cache(maxsize=None)
def _int_range(dtype: np.dtype) -> tuple[int, int]:
    """``(min, max)`` of an integer dtype (``np.iinfo``, looked up once per dtype)."""
    info = np.iinfo(dtype)
    return int(info.min), int(info.max)


#: Sampled rows read ahead by the compiled sampled passes (:func:`fringe3d.utils._prefetch.prefetch_lines`).
AHEAD = 4


@numba.njit(cache=True, nogil=True)
def _count_at_least(frames, step, cut_a, cut_b, counts):  # pragma: no cover - compiled
    """``counts[:, f] = (#(x >= cut_a), #(x >= cut_b))`` over ``x`` of ``frames[f, ::step, ::step]``.
    Each sampled row is compared whole (contiguous, vectorised) into per-column uint8 tallies,
    which are summed at the sampled columns every 255 rows and at each frame's end. The sampled
    row :data:`AHEAD` rows on (into the next frame at a frame's end) is prefetched: the rows are
    read from memory, not the caches, on the decoder's first look at its frames."""
    nf, h, w = frames.shape
    tally_a = np.zeros(w, np.uint8)
    tally_b = np.zeros(w, np.uint8)
    nr = (h + step - 1) // step
    for f in range(nf):
        na = 0
        nb = 0
        rows = 0
        for r in range(0, h, step):
            k = f * nr + r // step + AHEAD
            if k < nf * nr:
                prefetch_lines(frames[k // nr, (k % nr) * step])
            row = frames[f, r]
            for c in range(w):
                x = row[c]
                tally_a[c] += np.uint8(x >= cut_a)
                tally_b[c] += np.uint8(x >= cut_b)
            rows += 1
            if rows == 255 or r + step >= h:
                for c in range(0, w, step):
                    na += tally_a[c]
                    nb += tally_b[c]
                tally_a[:] = 0
                tally_b[:] = 0
                rows = 0
        counts[0, f] = na
        counts[1, f] = nb


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
    step = max(1, int(math.sqrt(frames.shape[1] * frames.shape[2] / 16384)))
    # the DARK_PERCENTILE-th percentile is below the cut exactly when fewer than (100 - DARK_PERCENTILE) %
    # of the pixels reach it: one comparison pass, as cheap as the maximum it replaces; the
    # saturation share from the same pass (level inf: float frames without a bit depth, none)
    lit_share, sat_frac = _subsample_shares(frames, step, (DARK_FRACTION * fs, level))
    designed = {int(i) for i in dark_by_design}
    lit_cut = 1.0 - DARK_PERCENTILE / 100.0
    dark = [i for i, share in enumerate(lit_share) if share < lit_cut]
    if len(dark) < len(lit_share):  # all frames dark is reported whatever their design
        dark = [i for i in dark if i not in designed]
    exempt = {int(i) for i in binary}
    sat = [i for i, share in enumerate(sat_frac) if share > SATURATED_WARN_FRACTION and i not in exempt]
    if dark:
        cut = f"{DARK_PERCENTILE:g}th percentile < {DARK_FRACTION:.0%} of full scale {fs:g}"
        msg = (f"all frames are dark (nearly black: {cut})" if len(dark) == len(lit_share)
               else f"{len(dark)} dark frame(s) (nearly black: {cut}): {dark}")
        warnings.warn(f"{where}: {msg}; affected pixels are masked", FrameQualityWarning, stacklevel=3)
    if sat:
        worst = max(sat_frac[i] for i in sat)
        warnings.warn(f"{where}: {len(sat)} frame(s) with more than {SATURATED_WARN_FRACTION:.0%} saturated "
                      f"pixels (worst {worst:.0%} at level {level:g}): {sat}; pixels are masked where clipping "
                      "biases the phase beyond its noise", FrameQualityWarning, stacklevel=3)
    return {"dark": dark, "saturated": sat, "saturated_fraction": sat_frac,
            "frames": int(frames.shape[0]), "full_scale": float(fs), "dark_by_design": sorted(designed)}
