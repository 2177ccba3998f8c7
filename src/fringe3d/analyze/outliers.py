"""Which points a form figure may ignore, and a warning when a few points still dominate it.

Two rules (``exclude``):

* ``None`` (default) - robust: points whose residual from the fit exceeds ``k`` robust sigmas,
  ``|r - median(r)| > k * 1.4826 * MAD(r)`` (``k = 5``), are dropped and the model refitted,
  three times at most (each pass judges every candidate point against the latest fit).
  Gaussian noise loses fewer than one point in a million to this, so P_F and F
  stay the range of the noise, but an isolated fringe-order error (tens of mm) cannot set them.
* a share ``0 <= s <= 0.003`` - VDI/VDE 2634-2: drop the ``floor(s N)`` largest ``|r|``, refit.

Whatever the rule, :func:`form_warning` flags a range far above what the fit RMS allows
(``range > FORM_RATIO * rms``; Gaussian noise gives about ``2 sqrt(2 ln N)`` ~ 10.5 for N = 1 M).
"""
from __future__ import annotations

import warnings

import numpy as np

from .fits import robust_fit
from .vdi import _check_exclude

ROBUST_K = 5.0
ROBUST_PASSES = 3
FORM_RATIO = 15.0


def fit_with_outliers(fit_fn, points, mask, exclude: float | None = None):
    """Fit ``fit_fn`` (``fit_plane`` / ``fit_sphere``) under the outlier rule ``exclude``.

    Parameters
    ----------
    fit_fn : callable ``(points, mask) -> fit``
    points : (H, W, 3) or (N, 3) float, mm
    mask : bool map or None (every finite point)
    exclude : float or None
        None: robust k-sigma rule; a share: the VDI/VDE 2634-2 rule.

    Returns
    -------
    ``(fit, info)`` with ``info = {"rule": str, "excluded_share": float, "excluded_points": int}``.
    """
    if mask is None:
        mask = np.all(np.isfinite(np.asarray(points)), axis=-1)
    if exclude is None:
        fit, used, share = robust_fit(fit_fn, points, mask, k=ROBUST_K, passes=ROBUST_PASSES)
        rule = f"robust: |r - median| > {ROBUST_K:g} x 1.4826 MAD dropped, {ROBUST_PASSES} passes"
    else:
        _check_exclude(exclude)
        fit, used, share = robust_fit(fit_fn, points, mask, drop_share=exclude)
        rule = f"VDI/VDE 2634-2: {exclude:g} share of largest |r| dropped"
    n0 = int(np.sum(np.asarray(mask, bool) & np.all(np.isfinite(np.asarray(points)), axis=-1)))
    return fit, {"rule": rule, "excluded_share": float(share), "excluded_points": int(n0 - fit.n_points)}


def form_warning(what: str, form: float, rms: float) -> str | None:
    """A message (also issued as a ``UserWarning``) when ``form`` (a residual range, mm) exceeds
    ``FORM_RATIO`` times the fit ``rms`` (mm): a few far points, not the surface, set the figure."""
    if not (rms > 0 and form > FORM_RATIO * rms):
        return None
    msg = (f"{what}: the residual range {form:.4g} mm is {form / rms:.0f} x the fit RMS {rms:.3g} mm; "
           "a few far points set it (outliers or a wrong segment), not the surface")
    warnings.warn(msg, stacklevel=3)
    return msg
