"""Projector-nonlinearity diagnostic: the harmonic content of a capture and the recommended fix.

For an equally shifted N-step set with N >= 4 the second-harmonic ratio ``c_2 / c_1``
(:func:`fringe3d.radiometry.harmonics.estimate_gamma`) is measured over the whole capture; the
predicted phase ripple is the phase-error table of the matching power-law response (its
``N``-times-per-fringe error, Pan et al. 2009; Zhang & Yau 2007), in rad and, for a fringe
period ``T`` in projector pixels, in pixels ``e T / 2 pi``. The diagnostic stays quiet when the
ratio is within ``significance`` standard errors of 0 or the ripple is below ``threshold_rad``.

References
----------
See :mod:`fringe3d.radiometry.harmonics`.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .harmonics import estimate_gamma
from .phase_error import lut_from_response
from .response import power_law

#: True phases simulated for the predicted ripple (:func:`lut_from_response`'s ``samples``): 8 per
#: table bin instead of its default 32 (a quarter of the work, which the decoder pays per
#: direction and cycle); the ripple within 1e-3 of itself + 1e-6 rad of the default table's
#: (``tests/test_radiometry_compensation.py``).
RIPPLE_SAMPLES = 2048


@dataclass(frozen=True)
class NonlinearityReport:
    """What :func:`diagnose` found (JSON-ready through :meth:`as_dict`).

    Attributes
    ----------
    steps : int
    nonlinear : bool
        The capture shows a projector nonlinearity worth correcting.
    harmonic_ratio, harmonic_ratio_sigma : float
        ``c_2 / c_1`` and its standard error.
    gamma : float
        Power-law gamma that explains the ratio.
    ripple_order : int
        The ripple's frequency in cycles per fringe (``N``).
    ripple_rad : float
        Predicted peak phase error, rad.
    ripple_px : float | None
        The same in projector pixels (``None`` without a period).
    fix : str | None
        The recommended fix (``None`` when quiet).
    """

    steps: int
    nonlinear: bool
    harmonic_ratio: float
    harmonic_ratio_sigma: float
    gamma: float
    ripple_order: int
    ripple_rad: float
    ripple_px: float | None
    fix: str | None

    def as_dict(self) -> dict:
        # the fields are scalars and strings: a shallow dict is dataclasses.asdict without its deep copies
        return {f.name: getattr(self, f.name) for f in fields(self)}


def diagnose(frames, mask=None, period: float | None = None, threshold_rad: float = 0.005,
             significance: float = 5.0) -> NonlinearityReport:
    """Say whether an N-step capture (N >= 4, equal shifts) suffers from a nonlinear projector.

    Parameters
    ----------
    frames : (N, H, W)
        One equally shifted phase-shift set.
    mask : (H, W) bool, optional
        Pixels to use.
    period : float, optional
        Fringe period in projector pixels, to express the ripple in pixels.
    threshold_rad : float
        Ripple below this (rad) is not reported.
    significance : float
        The ratio must exceed this many standard errors.

    Returns
    -------
    NonlinearityReport

    Raises
    ------
    ValueError
        N < 4 (see :func:`fringe3d.radiometry.harmonics.estimate_gamma`).
    """
    est = estimate_gamma(frames, mask)
    ripple = lut_from_response(power_law(est.gamma), steps=est.steps, samples=RIPPLE_SAMPLES).amplitude
    px = None if period is None else float(ripple * period / (2.0 * np.pi))
    nonlinear = abs(est.ratio) > significance * est.ratio_sigma and ripple > threshold_rad
    fix = None
    if nonlinear:
        size = f"{ripple:.3g} rad" + ("" if px is None else f" = {px:.3g} px")
        fix = (f"the projector is nonlinear (gamma ~ {est.gamma:.2f}): the phase ripples {est.steps} times per "
               f"fringe by up to {size}; decode with `compensate='harmonic'`, or measure the response "
               f"with a grey ramp and decode with `compensate='response'`, or pre-distort the patterns "
               f"(`pattern_gamma` {est.gamma:.2f})")
    return NonlinearityReport(est.steps, bool(nonlinear), est.ratio, est.ratio_sigma, est.gamma, est.steps,
                              float(ripple), px, fix)
