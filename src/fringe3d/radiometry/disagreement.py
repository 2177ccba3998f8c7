"""Projector nonlinearity from the disagreement between fringe frequencies (after Xing & Guo 2018).

An N-step set through a nonlinear projector measures ``Phi = phi + e(phi_w)``, with ``phi_w``
the measured wrapped phase (the table's index, as in :class:`PhaseErrorLUT`) and a ripple ``e``
made of the harmonics ``k N`` of the wrapped phase
(Pan et al. 2009), the same function for every frequency shown with the same shifts. Two
absolute phases of the same pixels, at periods ``T_a`` and ``T_b`` (projector px), must give the
same projector coordinate ``u = T Phi / (2 pi)``; their disagreement

    ``d = T_a Phi_a / (2 pi) - T_b Phi_b / (2 pi) = (T_a e(phi_a) - T_b e(phi_b)) / (2 pi) + c``

is linear in the coefficients of ``e = sum_k a_k sin(k N phi) + b_k cos(k N phi)`` (plus a
constant ``c`` for a phase-origin offset), so least squares over all pixels (refitted without
the outliers a fringe-order error or a mixed pixel makes) estimates ``e``
from the capture itself, also for 3-step sets where no DFT bin is free
(:mod:`fringe3d.radiometry.harmonics` needs N >= 4). Assumes: a matte surface, the same
response and shifts for both frequencies, unwrapped (absolute) phases without order errors.

References
----------
S. Xing and H. Guo, "Correction of projector nonlinearity in multi-frequency phase-shifting
fringe projection profilometry", Opt. Express 26(13), 16277-16291 (2018).
"""
from __future__ import annotations

import numpy as np

from .phase_error import PhaseErrorLUT, bin_centres, wrap


def _basis(phi: np.ndarray, steps: int, orders: int) -> np.ndarray:
    """Columns ``sin(k N phi), cos(k N phi)`` for ``k = 1 .. orders``; (P, 2 orders)."""
    cols = []
    for k in range(1, orders + 1):
        cols += [np.sin(k * steps * phi), np.cos(k * steps * phi)]
    return np.stack(cols, axis=-1)


def disagreement_lut(phase_a, period_a: float, phase_b, period_b: float, steps: int, mask=None,
                     orders: int = 4, bins: int = 256) -> PhaseErrorLUT:
    """Phase-error table of an N-step set estimated from two frequencies' disagreement.

    Parameters
    ----------
    phase_a, phase_b : (H, W) float
        Absolute (unwrapped) phases of the same pixels at two fringe periods, rad.
    period_a, period_b : float
        Their periods, projector px.
    steps : int
        N of both sets (equal shifts ``2 pi k / N``).
    mask : (H, W) bool, optional
        Pixels to use (default: finite in both).
    orders : int
        Ripple harmonics ``N, 2N, ...`` modelled.
    bins : int
        Table size.

    Returns
    -------
    PhaseErrorLUT
        ``e`` on measured wrapped phase; correct either frequency's wrapped phase with
        :meth:`PhaseErrorLUT.correct`.

    Raises
    ------
    ValueError
        Shapes differ, equal periods (no disagreement to measure), or too few pixels.
    """
    a, b = np.asarray(phase_a, float), np.asarray(phase_b, float)
    if a.shape != b.shape:
        raise ValueError(f"phase_a {a.shape} and phase_b {b.shape} must have the same shape")
    if np.isclose(period_a, period_b):
        raise ValueError(f"the two periods must differ to disagree, got {period_a} and {period_b}")
    ok = np.isfinite(a) & np.isfinite(b)
    if mask is not None:
        ok &= np.asarray(mask, bool)
    if ok.sum() < 10 * (2 * orders + 1):
        raise ValueError(f"only {int(ok.sum())} usable pixels to estimate the ripple from")
    pa, pb = a[ok], b[ok]
    d = (period_a * pa - period_b * pb) / (2.0 * np.pi)
    design = (period_a * _basis(wrap(pa), steps, orders) - period_b * _basis(wrap(pb), steps, orders)) / (2 * np.pi)
    design = np.column_stack([design, np.ones(d.size)])
    keep = np.abs(d - np.median(d)) < 0.25 * min(period_a, period_b)  # a fringe-order error jumps by a period
    for _ in range(3):  # refit without outliers (order errors at edges, mixed pixels)
        sol = np.linalg.lstsq(design[keep], d[keep], rcond=None)[0]
        resid = np.abs(d - design @ sol)
        keep = resid <= max(5.0 * 1.4826 * float(np.median(resid[keep])), 1e-9)
    coef = sol[:-1]
    centres = bin_centres(bins)
    return PhaseErrorLUT(centres, _basis(centres, steps, orders) @ coef)
