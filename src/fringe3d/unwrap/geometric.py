"""Phase unwrapping by the geometric constraint, Eq. (4.14)-(4.21) (An et al.; ch. 4.2.3, 5.2.3).

With the camera frame as world frame, each camera ray meets the virtual plane ``z = z_min``
(the nearest depth of the measurement volume) at one point (Eq. 4.15-4.17). Projected into the
projector (Eq. 4.18) it gives the smallest projector coordinate that pixel can see, hence the
minimum phase ``Phi_min = 2*pi*w/T`` (Eq. 4.19, ``w = v_p cos(alpha) + u_p sin(alpha)``; ``u_p``
for vertical fringes). A wrapped phase ``phi`` is then unwrapped pixel by pixel:
``k = ceil((Phi_min - phi) / 2pi)``, ``Phi = phi + 2*pi*k`` (Eq. 4.20-4.21).

The rule holds while the scene stays within one fringe period of ``z_min`` in the projector:
``0 <= Phi - Phi_min < 2*pi`` (the depth-range limit, ch. 4.4). :func:`depth_limit` gives the
largest depth each pixel may see; :func:`check_depth_range` and :func:`check_wrap_around` warn
when a scene leaves that range.

Whether the phase grows or falls with depth along a ray depends on the rig (which side the
projector sits on and the fringe direction); :class:`MinimumPhase` stores that sign per pixel
and the falling case uses ``k = floor(...)`` so that ``-2*pi < Phi - Phi_min <= 0``.
Telecentric rigs (world = projector frame) use ``z`` of the projector frame.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from fringe3d.gpu.runtime import check_backend
from fringe3d.optics.rays import RayGeometry, check_map, projector_fringe_coordinate
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import TWO_PI, w_to_phase
from fringe3d.utils.warning_types import DepthRangeWarning



@dataclass(frozen=True, eq=False)
class MinimumPhase:
    """The minimum phase map of one rig, ``z_min`` and fringe direction (Eq. 4.14-4.19).

    Attributes
    ----------
    phi_min : (H, W) float32
        ``Phi_min`` in rad; NaN where the pixel's ray does not reach ``z = z_min`` in front of
        the camera.
    sign : (H, W) int8
        +1 where the absolute phase grows with depth along the ray, -1 where it falls
        (0 where undefined).
    z_min : float
        The virtual plane's depth (mm, world frame).
    period : float
        Fringe period T (projector pixels).
    angle : float
        Fringe angle alpha (rad): pi/2 for vertical fringes (``u_p``), 0 for horizontal.
    """

    phi_min: np.ndarray
    sign: np.ndarray
    z_min: float
    period: float
    angle: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.phi_min.shape


def minimum_phase(rig: Rig, z_min: float, period: float, angle: float = math.pi / 2,
                  geometry: RigGeometry | None = None) -> MinimumPhase:
    """Minimum phase map ``Phi_min`` for every camera pixel, Eq. (4.14)-(4.19).

    Parameters
    ----------
    rig : fringe3d.optics.Rig
    z_min : float
        Depth (mm, world frame) of the nearest plane of the measurement volume.
    period : float
        Fringe period T in projector pixels of the phase to be unwrapped.
    angle : float
        Fringe angle (rad); pi/2 = vertical fringes encoding ``u_p``.
    geometry : fringe3d.optics.RigGeometry, optional
        The rig's precomputed geometry, whose camera rays are shared
        (:func:`fringe3d.optics.rays.camera_planes`; the same map).

    Raises
    ------
    ValueError
        When ``z_min`` lies behind (or at) a pinhole camera, so no ray reaches it, or the
        period is not positive.

    Returns
    -------
    MinimumPhase
        ``Phi_min`` (H, W) float32 rad and the per-pixel sign, with ``z_min``, period and angle.
    """
    if not period > 0:
        raise ValueError(f"fringe period must be positive (projector pixels), got {period}")
    z_min = float(z_min)
    if not math.isfinite(z_min):
        raise ValueError(f"z_min must be a finite depth in mm, got {z_min}")
    tri = RayGeometry(rig, angle, geometry)
    X0 = tri.ray_points_at_z(z_min)
    if not np.isfinite(X0[..., 0]).any():
        raise ValueError(f"z_min = {z_min:g} mm lies behind (or at) the camera: no camera ray reaches the "
                         "plane z = z_min. With the camera frame as world frame the scene is at z > 0; "
                         "expected z_min > 0, the nearest depth of the measurement volume")
    dz = max(1e-3, 1e-4 * abs(z_min))
    X1 = tri.ray_points_at_z(z_min + dz)
    w0 = projector_fringe_coordinate(rig, X0, angle)
    w1 = projector_fringe_coordinate(rig, X1, angle)
    with np.errstate(invalid="ignore"):
        sign = np.sign(w1 - w0)
    sign = np.where(np.isfinite(sign), sign, 0).astype(np.int8)
    phi_min = w_to_phase(w0, period, scale_first=True).astype(np.float32)
    return MinimumPhase(phi_min, sign, z_min, float(period), float(angle))


def fringe_order(wrapped: np.ndarray, mp: MinimumPhase) -> np.ndarray:
    """Fringe order ``k`` (H, W) float32 (NaN where undefined), Eq. (4.20)-(4.21):
    ``k = ceil((Phi_min - phi)/2pi)`` where the phase grows with depth, ``floor`` where it falls.

    Parameters
    ----------
    wrapped : (H, W) array_like
        Wrapped phase ``phi`` (rad) of fringes with ``mp.period`` and ``mp.angle``.
    mp : MinimumPhase
        From :func:`minimum_phase`.

    Returns
    -------
    ndarray
        ``(H, W)`` float32 fringe order ``k``, NaN where undefined (``mp.sign`` 0 or NaN input).
    """
    wrapped = check_map(wrapped, mp.shape, "wrapped phase")
    x = (mp.phi_min.astype(np.float64) - wrapped) / TWO_PI
    k = np.where(mp.sign > 0, np.ceil(x), np.floor(x))
    k[mp.sign == 0] = np.nan
    return k.astype(np.float32)


def geometric_unwrap(wrapped: np.ndarray, mp: MinimumPhase, mask=None, check: bool = True, backend: str = "cpu",
                     device_output: bool = False):
    """Absolute phase ``Phi = phi + 2*pi*k`` by the geometric constraint, Eq. (4.21).

    Parameters
    ----------
    wrapped : (H, W) float
        Wrapped phase ``phi`` (rad) of fringes with ``mp.period`` and ``mp.angle``.
    mp : MinimumPhase
        From :func:`minimum_phase` (computed once per rig / z_min / period).
    mask : (H, W) bool, optional
        Valid pixels (e.g. modulation mask).
    check : bool
        Run :func:`check_wrap_around` and warn when the scene seems to exceed the depth range.
    backend : {"cpu", "cuda"}
        ``"cuda"``: :func:`fringe3d.gpu.ops.geometric_unwrap` on a CUDA device; ``wrapped`` and
        ``mask`` may then also be (C, H, W) stacks of cycles (host or device arrays), and the
        wrap-around check runs on host results only.
    device_output : bool
        ``backend="cuda"`` only: leave ``(Phi, mask)`` on the device.

    Returns
    -------
    (Phi, mask) : (H, W) float32 rad (NaN invalid), (H, W) bool
    """
    if check_backend(backend) == "cuda":
        from fringe3d.gpu import ops

        Phi, valid = ops.geometric_unwrap(wrapped, mp.phi_min, mp.sign, mask, device_output=device_output)
        if check and not device_output:
            for p, v in zip(Phi.reshape((-1,) + mp.shape), valid.reshape((-1,) + mp.shape)):
                check_wrap_around(p, mp, v)
        return Phi, valid
    k = fringe_order(wrapped, mp)
    Phi = (np.asarray(wrapped, np.float64) + TWO_PI * k).astype(np.float32)
    valid = np.isfinite(Phi)
    if mask is not None:
        valid &= check_map(mask, mp.shape, "mask").astype(bool)
    Phi[~valid] = np.nan
    if check:
        check_wrap_around(Phi, mp, valid)
    return Phi, valid


def depth_limit(rig, mp: MinimumPhase) -> np.ndarray:
    """Largest depth (H, W) float32 (mm, world z) each pixel can measure with ``mp``: where
    ``|Phi - Phi_min|`` reaches 2*pi, one fringe period beyond ``z_min`` (ch. 4.4).
    Computed with the linear projector model; +inf where a whole period lies beyond the ray's
    vanishing point (unlimited range), NaN where undefined.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
        The rig ``mp`` was computed for.
    mp : MinimumPhase
        From :func:`minimum_phase`.

    Returns
    -------
    ndarray
        ``(H, W)`` largest depth (mm, world z); +inf unlimited, NaN undefined.
    """
    tri = RayGeometry(rig, mp.angle)
    w_lim = (mp.phi_min.astype(np.float64) / TWO_PI + mp.sign) * mp.period
    w_lim[mp.sign == 0] = np.nan
    z = tri.points(w_lim)[..., 2]
    # no solution in front of the camera: one period lies beyond the ray's vanishing point,
    # so the whole ray beyond z_min is in range
    z[np.isnan(z) & (mp.sign != 0)] = np.inf
    return z


def check_depth_range(rig, mp: MinimumPhase, z_max: float | np.ndarray, mask=None) -> dict:
    """Warn when depths up to ``z_max`` (scalar or (H, W) map, mm) exceed the geometric
    constraint's valid range; returns ``{"ok", "share_beyond", "limit_min", "limit_median"}``.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
        The rig ``mp`` was computed for.
    mp : MinimumPhase
        From :func:`minimum_phase`.
    z_max : float or (H, W) ndarray
        Largest depth the scene reaches (mm, world z), per pixel or for all.
    mask : (H, W) bool, optional
        Pixels to check (default all with a defined limit).

    Returns
    -------
    dict
        ``ok`` (bool), ``share_beyond`` (fraction of checked pixels at or beyond the limit),
        ``limit_min`` and ``limit_median`` (mm) of :func:`depth_limit` over the checked pixels.
    """
    lim = depth_limit(rig, mp)
    z = np.broadcast_to(np.asarray(z_max, float), lim.shape)
    sel = ~np.isnan(lim) & np.isfinite(z)
    if mask is not None:
        sel &= check_map(mask, mp.shape, "mask").astype(bool)
    beyond = sel & (z >= lim)
    share = float(beyond.sum() / max(sel.sum(), 1))
    out = {"ok": share == 0.0, "share_beyond": share,
           "limit_min": float(np.min(lim[sel])) if sel.any() else float("nan"),
           "limit_median": float(np.median(lim[sel])) if sel.any() else float("nan")}
    if not out["ok"]:
        warnings.warn(f"the scene reaches beyond the geometric constraint's depth range at {100 * share:.2f}% of the "
                      f"pixels: with z_min = {mp.z_min:g} mm and period {mp.period:g} px the range ends at "
                      f"z = {out['limit_min']:.1f} mm (nearest) .. {out['limit_median']:.1f} mm (median); "
                      "those pixels get the wrong fringe order (ch. 4.4). Raise z_min or use a longer period.",
                      DepthRangeWarning, stacklevel=2)
    return out


def check_wrap_around(Phi: np.ndarray, mp: MinimumPhase, mask=None, min_pairs: int = 20) -> int:
    """Warn when the unwrapped phase looks like it wrapped around the depth range.

    A surface that crosses the range limit makes ``r = sign*(Phi - Phi_min)`` jump from just
    below 2*pi to just above 0 between neighbouring pixels. Counts neighbouring valid pixel
    pairs whose ``r`` differs by more than 1.5*pi (a heuristic: a genuine depth step of nearly a
    full period also triggers it, and such steps are equally out of range, ch. 4.4). Warns when
    at least ``min_pairs`` pairs are found; returns the count.

    Parameters
    ----------
    Phi : (H, W) array_like
        Unwrapped phase (rad).
    mp : MinimumPhase
        The minimum phase it was unwrapped with.
    mask : (H, W) bool, optional
        Valid pixels (default all).
    min_pairs : int
        Number of jumping pairs at which to warn.

    Returns
    -------
    int
        The number of neighbouring pixel pairs whose ``r`` jumps by more than 1.5*pi.
    """
    r = mp.sign * (np.asarray(Phi, np.float64) - mp.phi_min)
    if mask is not None:
        r = np.where(mask, r, np.nan)
    with np.errstate(invalid="ignore"):
        n = int(np.sum(np.abs(np.diff(r, axis=0)) > 1.5 * math.pi) + np.sum(np.abs(np.diff(r, axis=1)) > 1.5 * math.pi))
    if n >= min_pairs:
        warnings.warn(f"the geometric-constraint unwrapped phase jumps by about 2*pi relative to Phi_min at {n} "
                      f"neighbouring pixel pairs: the scene probably extends beyond one fringe period from "
                      f"z_min = {mp.z_min:g} mm (the depth-range limit, ch. 4.4). Lower z_min only if it is not "
                      "already the nearest depth; otherwise use a longer period or a temporal method.",
                      DepthRangeWarning, stacklevel=2)
    return n


def propose_z_min(reference, margin: float = 5.0, percentile: float = 0.0) -> float:
    """Propose ``z_min`` from a reference measurement (ch. 4.2.3).

    Parameters
    ----------
    reference : (H, W, 3) point map or (H, W) depth map (mm), NaN invalid
        E.g. a plane or the scene measured once with a temporal method.
    margin : float
        Subtracted from the nearest depth (mm), leaving room for noise and closer objects.
    percentile : float
        Use this percentile of the depths instead of the minimum (robust to outliers).

    Returns
    -------
    float
        Proposed ``z_min`` (mm, world z): the nearest (or percentile) depth minus ``margin``.
    """
    ref = np.asarray(reference, float)
    z = ref[..., 2] if (ref.ndim == 3 and ref.shape[-1] == 3) else ref
    z = z[np.isfinite(z)]
    if z.size == 0:
        raise ValueError("the reference measurement has no valid depth; cannot propose z_min "
                         "(expected a point or depth map with some finite values)")
    if margin < 0:
        raise ValueError(f"margin must be >= 0 mm, got {margin}")
    zmin = float(np.percentile(z, percentile)) if percentile > 0 else float(z.min())
    return zmin - float(margin)


def cached_minimum_phase(geometry: RigGeometry, z_min: float, period: float, angle: float) -> MinimumPhase:
    """:func:`minimum_phase` of ``geometry.rig``, computed once per :class:`RigGeometry`.

    Sequences decode thousands of cycles with the same rig; the engine owns the geometry, so the
    map lives as long as the engine.

    Parameters
    ----------
    geometry : fringe3d.optics.RigGeometry
        The rig's precomputed geometry (keeps the map).
    z_min : float
        Depth (mm, world frame) of the nearest plane of the measurement volume.
    period : float
        Fringe period T (projector pixels).
    angle : float
        Fringe angle (rad).

    Returns
    -------
    MinimumPhase
        As :func:`minimum_phase`; the same object for repeated calls with one geometry.
    """
    key = ("minimum_phase", float(z_min), float(period), float(angle))
    return geometry.memo(key, lambda: minimum_phase(geometry.rig, z_min, period, angle, geometry=geometry))
