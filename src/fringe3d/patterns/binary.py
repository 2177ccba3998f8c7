"""Binary approximations of a sinusoidal fringe (binary defocusing, ch. 5.3, 6.4.1).

All functions take the fringe phase ``theta = 2*pi*w/T + shift`` (any shape) and return 0/1
float32 of the same shape (area modulation also needs the coordinate along the stripes).

* :func:`squared_binary`: on where the sinusoid exceeds 1/2 (cos theta > 0), half-open so a
  period with an even pixel count gets exactly half its pixels on.
* :func:`pulse_width_modulated`: sinusoidal PWM (the dissertation's ref [181]): the sinusoid is
  compared with a triangular carrier of ``pulses`` periods per fringe period, so the duty cycle
  inside each carrier period follows the sinusoid and the low harmonics are pushed to
  ``pulses``-times the fringe frequency, where defocus removes them.
* :func:`area_modulated`: area modulation (ref [182]): along the stripe direction the pattern
  is cut into cells of ``cell`` pixels; in each cell the fraction of on pixels equals the local
  sinusoid value (ordered by a 1-D Bayer ranking so on pixels are spread, not bunched).
"""
from __future__ import annotations

import numpy as np

from fringe3d.patterns.dither import bayer_matrix

TWO_PI = 2.0 * np.pi


def _frac(theta: np.ndarray) -> np.ndarray:
    """Position inside the period in [0, 1) for phase theta, rounded to 1e-9 so that pixels at
    the same position in the period (e.g. a frame shifted by a whole number of pixels) get
    bit-identical values and identical tie decisions."""
    f = np.round(np.mod(np.asarray(theta, dtype=np.float64) / TWO_PI, 1.0), 9)
    return np.where(f >= 1.0, 0.0, f)


def squared_binary(theta: np.ndarray, parity: np.ndarray | None = None) -> np.ndarray:
    """1 where ``cos(theta) > 0``, else 0.

    Pixels whose centre falls exactly on a stripe edge (``cos(theta) = 0``, which happens
    whenever the half period is an even number of pixels) are ties. Without ``parity`` the
    rising edge is on and the falling edge off (half-open, duty cycle exactly 1/2, but the
    stripe's centre moves by half a pixel). With ``parity`` (0/1 per pixel, e.g. a
    checkerboard) the tie pixels alternate, so each row keeps a 1/2 duty cycle and the
    pattern's fundamental keeps the sinusoid's phase on average.

    Parameters
    ----------
    theta : ndarray
        Fringe phase ``2 pi w / T + shift`` at each pixel (rad), any shape.
    parity : ndarray, optional
        0/1 per pixel (broadcast against ``theta``) deciding the tie pixels on stripe edges.

    Returns
    -------
    ndarray
        float32 of 0/1, the shape of ``theta``.
    """
    t = np.mod(_frac(theta) + 0.25, 1.0)
    on = t < 0.5
    if parity is not None:
        eps = 1e-9
        rising = (t < eps) | (t > 1.0 - eps)
        falling = np.abs(t - 0.5) < eps
        par = np.asarray(parity).astype(bool)
        on = np.where(rising, ~par, np.where(falling, par, on))
    return on.astype(np.float32)


def _triangle(x: np.ndarray) -> np.ndarray:
    """Triangle wave of period 1 in [0, 1]: 0 at integers, 1 at half-integers."""
    f = np.mod(x, 1.0)
    return 1.0 - np.abs(1.0 - 2.0 * f)


def pulse_width_modulated(theta: np.ndarray, pulses: int) -> np.ndarray:
    """Sinusoidal PWM: on where ``(1+cos theta)/2 >= triangle(pulses*theta/2pi + 1/2)``.

    ``pulses`` (odd, >= 1) carrier periods per fringe period. The carrier is aligned so that
    its peaks sit at the sinusoid's peak, keeping the pattern symmetric about theta = 0.

    Parameters
    ----------
    theta : ndarray
        Fringe phase ``2 pi w / T + shift`` at each pixel (rad), any shape.
    pulses : int
        Triangular carrier periods per fringe period (odd, >= 1).

    Returns
    -------
    ndarray
        float32 of 0/1, the shape of ``theta``.
    """
    if pulses < 1:
        raise ValueError(f"PWM needs at least one pulse per period, got {pulses}")
    x = _frac(theta)
    s = 0.5 * (1.0 + np.cos(TWO_PI * x))
    carrier = _triangle(pulses * x + 0.5)
    return (s > 1.0 - carrier + 1e-12).astype(np.float32)


def default_pwm_pulses(period: float) -> int:
    """Odd pulse count (>= 3) per fringe period: preferably one that splits the period into
    whole carrier periods of 4-12 pixels (closest to 8), else carrier periods of about 8 px."""
    best = None
    for p in range(3, int(period // 4) + 1, 2):
        c = period / p
        if abs(c - round(c)) < 1e-9 and 4 <= c <= 12 and (best is None or abs(c - 8) < abs(period / best - 8)):
            best = p
    return best if best is not None else max(3, 2 * int(round(period / 16.0)) + 1)


def area_modulated(theta: np.ndarray, along: np.ndarray, cell: int = 4) -> np.ndarray:
    """Area-modulated binary pattern.

    Parameters
    ----------
    theta : array
        Fringe phase at each pixel.
    along : array (same shape), int-valued
        Pixel index along the stripes (perpendicular to the fringe coordinate).
    cell : int
        Cell length in pixels; grey levels are quantised to ``cell + 1`` on-counts per cell.

    Returns
    -------
    ndarray
        float32 of 0/1, the shape of ``theta``.
    """
    if cell < 1:
        raise ValueError(f"area-modulation cell must be >= 1 pixel, got {cell}")
    ranks = bayer_matrix(cell)[0] if cell > 1 else np.zeros(1, dtype=np.int64)
    # 1-D ranking: re-rank the first Bayer row so it is a permutation of 0..cell-1
    order = np.empty(cell, dtype=np.int64)
    order[np.argsort(ranks, kind="stable")] = np.arange(cell)
    thresh = (order.astype(np.float64) + 0.5) / cell
    idx = np.mod(np.asarray(along).astype(np.int64), cell)
    s = 0.5 * (1.0 + np.cos(theta))
    return (s > thresh[idx]).astype(np.float32)
