"""One compiled pass for the second-to-first harmonic ratio of an N-step set (private;
:func:`fringe3d.radiometry.harmonics.estimate_gamma`).

The same least squares as the NumPy reference on the complex DFT bins
(``tests/reference_implementations.py``: ``harmonic_bins_reference``, ``harmonic_ratio_reference``),
without the (2, H, W) complex bins, the float64 products and the masked copies: each pixel's
bins 1 and 2 are summed from its N samples frame by frame, then folded into the sums of the
fit; a last pass sums the squared residuals (the standard error without the cancellation of an expanded sum of squares).
"""
from __future__ import annotations

import functools

import numba
import numpy as np


@numba.njit(cache=True)
def _ratio_pass(frames, mask, threshold, cos1, sin1, cos2, sin2):  # pragma: no cover - compiled
    """(ratio, standard error, pixels) over the pixels of ``mask`` whose ``|S_1| > threshold``;
    ``frames`` (N, P) of any real dtype (each value taken as float64, exactly), ``mask`` (P,)
    bool, the DFT weights already divided by N.

    Per pixel ``y = S_2 e^{-2 i phi}`` against ``model = |S_1|``, or for N = 4 ``y = Re S_2``
    against ``model = c_1 cos 2 phi`` (see ``harmonics._ratio``)."""
    n, npx = frames.shape
    re1 = np.zeros(npx)
    im1 = np.zeros(npx)
    re2 = np.zeros(npx)
    im2 = np.zeros(npx)
    for k in range(n):  # the bins, frame by frame (contiguous, vectorised)
        a, b, c, d = cos1[k], sin1[k], cos2[k], sin2[k]
        for p in range(npx):
            v = np.float64(frames[k, p])
            re1[p] += a * v
            im1[p] -= b * v
            re2[p] += c * v
            im2[p] -= d * v
    nyquist = n == 4
    num = 0.0
    den = 0.0
    count = 0
    for p in range(npx):  # y into (re2, im2), the model into re1, weight 0 for pixels left out
        a2 = re1[p] * re1[p] + im1[p] * im1[p]
        amp = np.sqrt(a2)
        use = mask[p] and amp > threshold
        inv = 1.0 / a2 if use else 0.0
        co = (re1[p] * re1[p] - im1[p] * im1[p]) * inv       # Re e^{2 i phi}
        si = 2.0 * re1[p] * im1[p] * inv                     # Im e^{2 i phi}
        if nyquist:
            yr = re2[p]
            yi = 0.0
            model = 2.0 * amp * co
        else:
            yr = re2[p] * co + im2[p] * si
            yi = im2[p] * co - re2[p] * si
            model = amp
        if not use:
            yr = 0.0
            yi = 0.0
            model = 0.0
        re1[p] = model
        re2[p] = yr
        im2[p] = yi
        num += model * yr
        den += model * model
        count += use
    if count == 0:
        return 0.0, 0.0, 0
    ratio = num / den
    res = 0.0
    for p in range(npx):  # pixels left out add 0
        dr = re2[p] - ratio * re1[p]
        res += dr * dr + im2[p] * im2[p]
    return ratio, np.sqrt(res / max(1, count - 1) / den), count


def harmonic_ratio_pass(frames: np.ndarray, mask: np.ndarray, threshold: float) -> tuple[float, float, int]:
    """``c_2 / c_1``, its standard error and the pixels used, of an equally shifted (N, H, W)
    set over ``mask`` (H, W) bool where the first-bin magnitude exceeds ``threshold``."""
    n = frames.shape[0]
    f = np.asarray(frames)
    if not (f.dtype.isnative and (f.dtype.kind in "ui" or f.dtype in (np.float32, np.float64))):
        f = f.astype(np.float64)  # the pass reads native integers, float32 and float64 as they are
    f = np.ascontiguousarray(f).reshape(n, -1)
    m = np.ascontiguousarray(np.broadcast_to(np.asarray(mask, bool), frames.shape[1:])).reshape(-1)
    ratio, sigma, count = _ratio_pass(f, m, float(threshold), *_dft_weights(n))
    return float(ratio), float(sigma), int(count)


@functools.lru_cache(maxsize=16)
def _dft_weights(n: int) -> tuple[np.ndarray, ...]:
    """``cos``, ``sin`` of bin 1 and of bin 2 of an N-step set, divided by N (cached per N, read-only)."""
    ang = 2.0 * np.pi * np.arange(n) / n
    out = (np.cos(ang) / n, np.sin(ang) / n, np.cos(2 * ang) / n, np.sin(2 * ang) / n)
    for a in out:
        a.flags.writeable = False
    return out
