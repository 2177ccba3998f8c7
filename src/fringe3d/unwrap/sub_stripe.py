"""Sub-stripe projector coordinates of a Gray/binary code from its bit-difference zero crossings.

A code frame minus its inverse, ``D_b = I_b - I_b,inv``, changes sign where the projected
stripe of bit ``b`` changes. Between two neighbouring camera pixels ``p`` and ``q = p + 1``
that decode to adjacent stripes (stripe centres ``c_p``, ``c_q`` one stripe width ``T``
apart), the bit that differs (for a Gray code exactly one; for a binary code the finest of
those that differ) crosses zero at the camera position ``x = p + D_p / (D_p - D_q)``
(linear interpolation), which images the projector stripe edge ``w = (c_p + c_q) / 2``.
Every pixel that lies between two such crossings bounding its own stripe gets the projector
coordinate interpolated linearly between them:

``w(j) = w_0 + (j - x_0) (w_1 - w_0) / (x_1 - x_0)``

along the camera row (and along the camera column); of the two, the scan whose crossings are
closer (the steeper one) is used. A pixel with a crossing on one side only (the first or last
stripe of a run, next to an invalid pixel), along neither axis bounded on both sides, is
extrapolated from that crossing with the neighbouring stripe's scale (``T`` over its
crossings' distance, at most that distance beyond the crossing), clamped to its own stripe
(:data:`INSIDE` within its edges);
a pixel with neither keeps its stripe centre.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


#: Rank offset of a one-sided extrapolation against a two-sided interpolation (camera px).
ONE_SIDED = 1.0e6
#: An extrapolation is clamped this far (projector px) inside its stripe's edges, so that the
#: coordinate, also after a float32 round trip through the phase, stays in the codeword's stripe.
INSIDE = 1.0e-3


@njit(cache=True)
def _crossing(centre, diff, i, p, q, period):
    """Camera position (px along the row) and projector edge ``w`` of the stripe edge between
    pixels ``p`` and ``q`` of row ``i``; NaN, NaN when they are not adjacent stripes."""
    a = centre[i, p]
    c = centre[i, q]
    if not (0.5 * period < abs(c - a) < 1.5 * period):
        return np.nan, np.nan
    for b in range(diff.shape[0] - 1, -1, -1):
        dp = np.float64(diff[b, i, p])
        dq = np.float64(diff[b, i, q])
        if (dp > 0) != (dq > 0):
            return p + (q - p) * dp / (dp - dq), 0.5 * (a + c)
    return np.nan, np.nan


@njit(cache=True, parallel=True)
def _row_crossings(centre, diff, plateau, period, w_out, span_out):
    """Per camera row: coordinate ``w_out`` (NaN where no crossing bounds the pixel's stripe)
    and the camera distance ``span_out`` between the crossings used (inf where none; plus
    ``ONE_SIDED`` for an extrapolation, so that an interpolation along the other axis wins).
    An extrapolation needs the neighbouring stripe at least one camera pixel wide and reaches at
    most that width beyond its crossing. A run of ``plateau`` pixels (a stripe edge where both
    frames of the bit clipped) is skipped: the crossing is interpolated between the pixels on
    either side of it.
    centre (H, W) float64, NaN = invalid; diff (B, H, W) float32; plateau (H, W) bool."""
    h = centre.shape[0]
    n = centre.shape[1]
    for i in prange(h):
        px = np.full(n, np.nan)
        pw = np.full(n, np.nan)
        ppx = np.full(n, np.nan)
        ppw = np.full(n, np.nan)
        lx = lw = llx = llw = np.nan
        prev = -1  # the last pixel before j that is not a plateau pixel
        for j in range(n):
            if plateau[i, j]:
                px[j], pw[j], ppx[j], ppw[j] = lx, lw, llx, llw
                continue
            if prev >= 0 and centre[i, prev] != centre[i, j]:  # also true when either is NaN
                x, e = _crossing(centre, diff, i, prev, j, period)
                if math.isnan(x):
                    lx = lw = llx = llw = np.nan
                else:
                    llx, llw, lx, lw = lx, lw, x, e
            px[j], pw[j], ppx[j], ppw[j] = lx, lw, llx, llw
            prev = j
        nx = nw = nnx = nnw = np.nan
        nxt = -1
        for j in range(n - 1, -1, -1):
            c = centre[i, j]
            if not plateau[i, j]:
                if nxt >= 0 and centre[i, nxt] != c:
                    x, e = _crossing(centre, diff, i, nxt, j, period)
                    if math.isnan(x):
                        nx = nw = nnx = nnw = np.nan
                    else:
                        nnx, nnw, nx, nw = nx, nw, x, e
                nxt = j
            w_out[i, j] = np.nan
            span_out[i, j] = np.inf
            if math.isnan(c):
                continue
            prev_ok = not math.isnan(px[j]) and abs(pw[j] - c) < period
            next_ok = not math.isnan(nx) and abs(nw - c) < period
            if prev_ok and next_ok and abs(nw - pw[j]) > 0.5 * period and nx > px[j]:
                w_out[i, j] = pw[j] + (j - px[j]) * (nw - pw[j]) / (nx - px[j])
                span_out[i, j] = nx - px[j]
            elif prev_ok and not math.isnan(ppx[j]) and 1.0 <= px[j] - ppx[j] and j - px[j] <= px[j] - ppx[j]:
                w = pw[j] + (j - px[j]) * (pw[j] - ppw[j]) / (px[j] - ppx[j])
                w_out[i, j] = min(max(w, c - 0.5 * period + INSIDE), c + 0.5 * period - INSIDE)
                span_out[i, j] = ONE_SIDED + px[j] - ppx[j]
            elif next_ok and not math.isnan(nnx) and 1.0 <= nnx - nx and nx - j <= nnx - nx:
                w = nw + (j - nx) * (nnw - nw) / (nnx - nx)
                w_out[i, j] = min(max(w, c - 0.5 * period + INSIDE), c + 0.5 * period - INSIDE)
                span_out[i, j] = ONE_SIDED + nnx - nx


def sub_stripe_coordinate(centre: np.ndarray, diff: np.ndarray, period: float,
                          plateau: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sub-stripe projector coordinate per camera pixel (see the module docstring).

    Parameters
    ----------
    centre : (H, W) float
        Stripe centre (projector px) of each pixel's codeword; NaN where invalid.
    diff : (B, H, W) float
        Bit differences ``I_b - I_b,inv`` (counts), most significant bit first.
    period : float
        Stripe width ``T`` (projector px).
    plateau : (H, W) bool, optional
        Pixels at a stripe edge whose bit clipped in both frames (no sign, no coordinate): the
        crossing is interpolated between the pixels on either side of a run of them (clipping
        both frames symmetrically about the edge keeps it in the middle).

    Returns
    -------
    w : (H, W) float64
        Projector coordinate (px): interpolated between the stripe's two edge crossings (or
        extrapolated from one) where found, else ``centre``.
    refined : (H, W) bool
        Where ``w`` was interpolated or extrapolated.
    """
    c = np.ascontiguousarray(centre, np.float64)
    d = np.ascontiguousarray(diff, np.float32)
    flat = np.zeros(c.shape, np.bool_) if plateau is None else np.ascontiguousarray(plateau, np.bool_)
    best = np.full(c.shape, np.nan)
    span = np.full(c.shape, np.inf)
    for axis in (1, 0):
        cc = c if axis == 1 else np.ascontiguousarray(c.T)
        dd = d if axis == 1 else np.ascontiguousarray(d.transpose(0, 2, 1))
        pp = flat if axis == 1 else np.ascontiguousarray(flat.T)
        w = np.empty_like(cc)
        s = np.empty_like(cc)
        _row_crossings(cc, dd, pp, float(period), w, s)
        if axis == 0:
            w, s = w.T, s.T
        take = s < span
        best = np.where(take, w, best)
        span = np.where(take, s, span)
    refined = np.isfinite(best)
    return np.where(refined, best, c), refined
