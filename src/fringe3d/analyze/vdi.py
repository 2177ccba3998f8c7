"""VDI/VDE 2634 Part 2-style acceptance figures for optical 3D measuring systems.

The guideline measures calibrated artefacts and reports (all in mm):

* probing error form ``P_F`` - range of the radial residuals of a sphere fitted with free
  radius (max - min),
* probing error size ``P_S`` - fitted minus calibrated diameter,
* sphere-spacing error ``SD`` - measured minus calibrated distance between the two sphere
  centres of a ball bar,
* flatness error ``F`` - range of the signed residuals of a fitted plane.

The guideline lets up to 0.3 % of the points be dropped as outliers before taking a range;
``exclude`` (a share, default 0) drops the points with the largest absolute residuals of a first
fit and fits again on the rest.
These are simulations of the procedure, not certified values.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .fits import PlaneFit, SphereFit, fit_plane, fit_sphere, keep_smallest, robust_fit

MAX_EXCLUDE = 0.003  # VDI/VDE 2634-2: at most 0.3 % of the points may be excluded


def _keep_index(residuals: np.ndarray, exclude: float) -> np.ndarray:
    """Indices of the residuals kept after dropping the ``exclude`` share with the largest |r|."""
    _check_exclude(exclude)
    return keep_smallest(residuals, exclude)


def _check_exclude(exclude: float) -> None:
    if not 0.0 <= exclude <= MAX_EXCLUDE:
        raise ValueError(f"exclude must be a share between 0 and {MAX_EXCLUDE} (0.3 % per VDI/VDE 2634-2), "
                         f"got {exclude}")


def _kept(residuals: np.ndarray, exclude: float) -> np.ndarray:
    return np.asarray(residuals, float)[_keep_index(residuals, exclude)]


def _refit(fitter, points, mask, exclude):
    """Fit, drop the ``exclude`` share of worst points, fit again on the rest."""
    if exclude > 0:
        _check_exclude(exclude)
    return robust_fit(fitter, points, mask, drop_share=exclude)[0]


def residual_range(residuals: np.ndarray, exclude: float = 0.0) -> float:
    """max - min of the residuals after dropping the ``exclude`` share with the largest |r|."""
    r = _kept(residuals, exclude)
    return float(r.max() - r.min())


@dataclass
class SphereFigures:
    """Probing errors on one sphere (mm): ``form`` (P_F), ``size`` (P_S, None without a
    calibrated diameter), ``diameter`` fitted, ``rms`` of the radial residuals, ``n_points``."""

    form: float
    size: float | None
    diameter: float
    rms: float
    n_points: int
    center: tuple

    def as_dict(self) -> dict:
        return asdict(self)


def probing_errors(points, mask=None, true_diameter: float | None = None, exclude: float = 0.0,
                   fit: SphereFit | None = None) -> SphereFigures:
    """Probing error form ``P_F`` and size ``P_S`` of a measured sphere (mm).

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) array_like
        Measured points, mm (NaN = invalid).
    mask : bool array, optional
        The sphere's points (one value per point); default every finite point.
    true_diameter : float, optional
        Calibrated diameter, mm; without it ``P_S`` (``size``) is None.
    exclude : float
        Share (0 to 0.003, VDI/VDE 2634-2) of the points with the largest absolute residuals of a
        first fit dropped before fitting again.
    fit : SphereFit, optional
        A sphere already fitted to these points; when given, ``points``, ``mask`` and
        ``exclude`` are not used.

    Returns
    -------
    SphereFigures
        ``form`` (range of the radial residuals), ``size`` (fitted minus true diameter),
        fitted diameter, RMS, point count and centre, mm.
    """
    fit = fit or _refit(fit_sphere, points, mask, exclude)
    size = None if true_diameter is None else float(fit.diameter - float(true_diameter))
    return SphereFigures(residual_range(fit.residuals), size, fit.diameter, fit.rms, fit.n_points,
                         tuple(float(v) for v in fit.center))


@dataclass
class SpacingFigures:
    """Ball-bar figures (mm): ``error`` (SD = measured - true, None without a true length),
    ``distance`` measured between the centres, and the two spheres' probing figures."""

    error: float | None
    distance: float
    spheres: tuple

    def as_dict(self) -> dict:
        return {"error": self.error, "distance": self.distance, "spheres": [s.as_dict() for s in self.spheres]}


def sphere_spacing(points, mask_a, mask_b, true_distance: float | None = None,
                   true_diameter: float | None = None, exclude: float = 0.0) -> SpacingFigures:
    """Sphere-spacing error of a ball bar: fit both spheres (free radius), distance of centres.

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) array_like
        Measured points, mm (NaN = invalid).
    mask_a, mask_b : bool array
        Points of the first and of the second sphere (one value per point).
    true_distance : float, optional
        Calibrated distance between the sphere centres, mm; without it ``error`` is None.
    true_diameter : float, optional
        Calibrated sphere diameter, mm, for each sphere's ``P_S``.
    exclude : float
        Share (0 to 0.003, VDI/VDE 2634-2) of the points with the largest absolute residuals of a
        first fit dropped before fitting again.

    Returns
    -------
    SpacingFigures
        ``error`` (SD = measured - true distance), the measured distance and both spheres'
        :class:`SphereFigures`, mm.
    """
    figs, centres = [], []
    for name, m in (("first", mask_a), ("second", mask_b)):
        try:
            fit = _refit(fit_sphere, points, m, exclude)
        except ValueError as e:
            raise ValueError(f"ball bar, {name} sphere: {e}") from None
        figs.append(probing_errors(points, m, true_diameter, fit=fit))
        centres.append(fit.center)
    dist = float(np.linalg.norm(centres[0] - centres[1]))
    err = None if true_distance is None else dist - float(true_distance)
    return SpacingFigures(err, dist, tuple(figs))


@dataclass
class FlatnessFigures:
    """Flatness error ``F`` (range of the signed plane residuals, mm), ``rms`` (mm), normal."""

    flatness: float
    rms: float
    n_points: int
    normal: tuple

    def as_dict(self) -> dict:
        return asdict(self)


def flatness(points, mask=None, exclude: float = 0.0, fit: PlaneFit | None = None) -> FlatnessFigures:
    """Flatness measurement error ``F`` on a plane artefact (mm).

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) array_like
        Measured points, mm (NaN = invalid).
    mask : bool array, optional
        The plane's points (one value per point); default every finite point.
    exclude : float
        Share (0 to 0.003, VDI/VDE 2634-2) of the points with the largest absolute residuals of a
        first fit dropped before fitting again.
    fit : PlaneFit, optional
        A plane already fitted to these points; when given, ``points``, ``mask`` and
        ``exclude`` are not used.

    Returns
    -------
    FlatnessFigures
        ``flatness`` (range of the signed residuals), RMS (mm), point count and unit normal.
    """
    fit = fit or _refit(fit_plane, points, mask, exclude)
    return FlatnessFigures(residual_range(fit.residuals), fit.rms, fit.n_points,
                           tuple(float(v) for v in fit.normal))


def multiview_sphere_spacing(points, centres, radius: float, true_distance: float | None = None,
                             margin: float = 1.0, exclude: float = 0.0) -> SpacingFigures:
    """VDI/VDE 2634-3 sphere-spacing error of a ball bar measured from several views: the merged
    cloud ``points`` (N, 3) mm is split by the nominal sphere ``centres`` (2, 3) mm (points within
    ``radius + margin`` of each), then :func:`sphere_spacing` (free-radius fits, distance of the
    centres minus ``true_distance``)."""
    P = np.asarray(points, float).reshape(-1, 3)
    C = np.asarray(centres, float)
    if C.shape != (2, 3):
        raise ValueError(f"centres must be two 3D points (2, 3), got shape {C.shape}")
    masks = [np.linalg.norm(P - c, axis=1) < radius + margin for c in C]
    return sphere_spacing(P, masks[0], masks[1], true_distance, 2 * radius, exclude)
