"""Single-shot absolute 3D: FTP (or π-shift modified FTP) + the geometric constraint (ch. 4).

One fringe image (period ``T``) → FTP wrapped phase (Eq. 4.1–4.4; modified FTP from a
π-shifted pair, Eq. 4.5–4.7) → absolute phase pixel by pixel from the minimum phase map
``Φ_min`` at ``z = z_min`` (Eq. 4.14–4.21) → triangulation (Eq. 2.37).

The band-pass window is centred on the carrier the rig predicts (the gradient of ``Φ_min``),
so the FTP phase runs the same way as the absolute phase even when the fringes fall with the
camera column. The method works while every point stays within one fringe period of
``z_min`` in the projector (``0 ≤ Φ − Φ_min < 2π``, the depth-range limit of ch. 4.4); beyond
it the fringe order is one too small. :func:`single_shot` warns when it sees that happen
(two checks: ``check_wrap_around`` of the geometric module, and per-object disagreement
between the pixel-wise orders and a spatially unwrapped map).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from fringe3d.optics.rays import camera_shape
from fringe3d.optics.rig import Rig
from fringe3d.reconstruct.triangulate import Triangulator
from fringe3d.unwrap.geometric import check_wrap_around, fringe_order, minimum_phase
from fringe3d.unwrap.histogram import fringe_order_difference, mode_of_orders
from fringe3d.unwrap.hybrid import carrier_from_minimum_phase, ftp_group_phase
from fringe3d.unwrap.segmentation import foreground_mask, segment_objects
from fringe3d.unwrap.spatial import unwrap_objects
from fringe3d.utils.camera_size import check_camera_size
from fringe3d.utils.warning_types import DepthRangeWarning

TWO_PI = 2.0 * math.pi
METHODS = ("ftp", "modified_ftp")


@dataclass
class SingleShotResult:
    """Outcome of :func:`single_shot`.

    Attributes
    ----------
    phase : (H, W) float32
        Absolute phase Φ (rad), NaN where invalid.
    wrapped : (H, W) float32
        FTP wrapped phase (rad).
    order : (H, W) float32
        Fringe order k of Eq. (4.21), NaN where invalid.
    mask : (H, W) bool
        Valid pixels (lit objects, FTP modulation).
    points : (H, W, 3) float32
        Triangulated points (mm), NaN where invalid.
    phi_min : (H, W) float32
        Minimum phase map (Eq. 4.19).
    range_check : dict
        ``wrap_pairs`` (neighbour pairs jumping ~2π relative to Φ_min), ``order_disagreement``
        (share of pixels whose order differs from their object's most common offset to a
        spatially unwrapped map), ``warned`` (bool).
    """

    phase: np.ndarray
    wrapped: np.ndarray
    order: np.ndarray
    mask: np.ndarray
    points: np.ndarray
    phi_min: np.ndarray
    range_check: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SingleShotSettings:
    """The FTP window and the thresholds of :func:`single_shot`.

    Attributes
    ----------
    window : {"hanning", "circular"}
        Band-pass window of the FTP (``"circular"``: smoothed circular); default ``"hanning"``.
    min_ratio : float
        Fringe-contrast threshold ``B / A``, dimensionless, of the default mask
        (:func:`fringe3d.unwrap.segmentation.foreground_mask`); default 0.15.
    erode : int
        Rim erosion of the default mask, pixels; default 0.
    warn_share : float
        Warn when more than this share (0-1) of object pixels disagree with their object's
        fringe order; default 1e-3.

    Examples
    --------
    >>> SingleShotSettings(window="circular").min_ratio
    0.15
    """

    window: str = "hanning"
    min_ratio: float = 0.15
    erode: int = 0
    warn_share: float = 1e-3


def single_shot(images, rig: Rig, period: float, z_min: float, method: str = "ftp",
                settings: SingleShotSettings | None = None, angle: float = math.pi / 2, shifts=(0.0, math.pi),
                mask: np.ndarray | None = None) -> SingleShotResult:
    """Absolute 3D from one fringe image (FTP) or a π-shifted pair (modified FTP), ch. 4.

    Parameters
    ----------
    images : (H, W) or (1 or 2, H, W) array
        The fringe image (``method="ftp"``), or the pair ``I1, I2`` (``"modified_ftp"``).
    rig : fringe3d.optics.Rig
    period : float
        Fringe period T (projector pixels).
    z_min : float
        Nearest depth of the measurement volume (mm, camera frame), Eq. (4.15)–(4.17).
    method : ``"ftp"`` or ``"modified_ftp"``
    settings : SingleShotSettings, optional
        FTP window, contrast threshold and rim erosion (px) of the default mask, and the share of
        disagreeing pixels that warns (default ``SingleShotSettings()``).
    angle : float
        Fringe angle (rad); π/2 = vertical fringes encoding ``u_p``.
    shifts : sequence
        Phase shift of each image (rad); the first is removed from the FTP phase.
    mask : (H, W) bool, optional
        Valid pixels; default: :func:`fringe3d.unwrap.segmentation.foreground_mask`.

    Returns
    -------
    :class:`SingleShotResult`
    """
    s = settings if settings is not None else SingleShotSettings()
    window, min_ratio, erode, warn_share = s.window, s.min_ratio, s.erode, s.warn_share
    if method not in METHODS:
        raise ValueError(f"unknown single-shot method {method!r}; expected one of {METHODS}")
    imgs = np.asarray(images)
    if imgs.ndim == 2:
        imgs = imgs[None]
    need = 1 if method == "ftp" else 2
    if imgs.ndim != 3 or imgs.shape[0] != need:
        raise ValueError(f"method {method!r} needs {need} image(s) of shape (H, W), got an array of shape "
                         f"{np.asarray(images).shape}")
    check_camera_size(imgs.shape[1:], camera_shape(rig), what="the images")
    mp = minimum_phase(rig, z_min, period, angle)
    carrier = carrier_from_minimum_phase(mp.phi_min)
    pr = ftp_group_phase(imgs, list(shifts)[:need], carrier, window)
    if mask is None:
        mask = segment_objects(foreground_mask(pr.average, pr.modulation, min_ratio), min_size=64,
                               erode=erode) > 0
    else:
        mask = np.asarray(mask, bool)
        if mask.shape != pr.phase.shape:
            raise ValueError(f"mask shape {mask.shape} differs from the image shape {pr.phase.shape}")
    if not mask.any():
        raise ValueError("no valid pixels: the mask is empty (all-dark frames, or no fringes on any object?)")
    k = fringe_order(pr.phase, mp)
    valid = mask & np.isfinite(k)
    k[~valid] = np.nan
    phase = (pr.phase.astype(np.float64) + TWO_PI * k).astype(np.float32)
    wrap_pairs = check_wrap_around(phase, mp, valid)
    disagreement = order_disagreement(pr.phase, phase, valid)
    warned = wrap_pairs >= 20
    if disagreement > warn_share:
        warned = True
        warnings.warn(f"{100 * disagreement:.2f}% of the object pixels get a fringe order that disagrees with the "
                      f"rest of their object: parts of the scene lie more than one fringe period (T = {period:g} px) "
                      f"beyond z_min = {z_min:g} mm, the geometric constraint's depth range (ch. 4.4)",
                      DepthRangeWarning, stacklevel=2)
    tri = Triangulator(rig, angle=angle, warn_distortion=False)
    points = tri.points_from_phase(np.where(valid, phase, np.nan), period, valid)
    return SingleShotResult(phase=phase, wrapped=pr.phase, order=k, mask=valid, points=points,
                            phi_min=mp.phi_min,
                            range_check={"wrap_pairs": int(wrap_pairs), "order_disagreement": float(disagreement),
                                         "warned": bool(warned)})


def order_disagreement(wrapped: np.ndarray, phase: np.ndarray, mask: np.ndarray) -> float:
    """Share of object pixels whose absolute phase is not ``Φ_r + 2π·mode`` of their object.

    ``Φ_r`` is the wrapped phase unwrapped spatially per object
    (:func:`fringe3d.unwrap.spatial.unwrap_objects`); within a smooth object the pixel-wise
    geometric orders should differ from it by one constant (Eq. 5.12). Pixels off that constant
    are where the geometric constraint broke (depth range exceeded) or where the spatial map has a
    genuine discontinuity.
    """
    phi_r, labels = unwrap_objects(np.where(mask, wrapped, np.nan), mask, min_size=64)
    k = fringe_order_difference(phi_r, phase)
    votes = mode_of_orders(k, labels)
    if not votes:
        return 0.0
    mode = np.zeros(int(labels.max()) + 1)
    for l, v in votes.items():
        mode[l] = v.k_s
    inside = (labels > 0) & np.isfinite(k)
    return float(np.mean(k[inside] != mode[labels[inside]])) if inside.any() else 0.0
