"""Hybrid FTP + PSP absolute phase with motion compensation (ch. 5.2.5, Eq. 5.12–5.15).

Four frames: one high-frequency fringe image ``I_h3`` (period ``T``) and three low-frequency
phase-shifted images ``I_l1..I_l3`` (period ``T_l``), captured one after the other while the
objects move.

1. FTP on ``I_h3`` → wrapped phase; segment the isolated objects; unwrap each spatially →
   continuous relative phase ``Φ_r`` (one unknown ``2π·k_s`` per object, Eq. 5.12).
2. 3-step phase of ``I_l1..I_l3`` unwrapped by the geometric constraint → ``Φ_e``: absolute,
   but with motion-induced error.
3. Per object, shift ``Φ_e`` by the object's bounding-box-centre displacement ``(Δu, Δv)``
   between the two captures and take ``k_e = round{[Φ_e(u+Δu, v+Δv)·T_l/T − Φ_r(u,v)]/2π}``
   (Eq. 5.13), ``k_s = mode(k_e)`` (Eq. 5.14), ``Φ_a = Φ_r + 2π·k_s`` (Eq. 5.15).

:func:`hybrid_phase` does step 3 from phase maps (testable in closed form);
:func:`hybrid_unwrap` the whole chain from wrapped phases; the decoder reaches it through the
``"hybrid"`` method (:func:`fringe3d.decode.methods.hybrid.unwrap_hybrid`) and
:mod:`fringe3d.reconstruct.motion` measures one cycle with it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fringe3d.phase import ftp
from fringe3d.phase.psp import PhaseResult
from fringe3d.unwrap.geometric import MinimumPhase, geometric_unwrap
from fringe3d.unwrap.histogram import OrderVote, apply_order_shift, fringe_order_difference, mode_of_orders
from fringe3d.unwrap.segmentation import foreground_mask, match_objects, segment_objects, shift_image
from fringe3d.unwrap.spatial import unwrap_objects

TWO_PI = 2.0 * np.pi


@dataclass
class HybridResult:
    """Outcome of the fringe-order search of Eq. (5.13)–(5.15).

    Attributes
    ----------
    phase : (H, W) float32
        Absolute phase ``Φ_a`` (rad, period T); NaN outside the objects.
    relative : (H, W) float32
        The relative phase ``Φ_r`` it was shifted from.
    labels : (H, W) int32
        Objects of ``Φ_r``.
    k_e : (H, W) float64
        Per-pixel fringe-order difference (Eq. 5.13); NaN where it could not be formed.
    votes : dict label -> OrderVote
        ``k_s`` per object with the share of pixels agreeing (Eq. 5.14).
    shifts : dict label -> (du, dv)
        Motion compensation used per object (pixels); (0, 0) for unmatched objects.
    unmatched : list[int]
        Objects of ``Φ_r`` with no counterpart in the low-frequency segmentation.
    """

    phase: np.ndarray
    relative: np.ndarray
    labels: np.ndarray
    k_e: np.ndarray
    votes: dict[int, OrderVote]
    shifts: dict[int, tuple[float, float]] = field(default_factory=dict)
    unmatched: list[int] = field(default_factory=list)
    coarse: np.ndarray | None = None
    labels_low: np.ndarray | None = None


def hybrid_phase(phi_r: np.ndarray, labels_r: np.ndarray, phi_e: np.ndarray,
                 period: float, period_low: float, labels_e: np.ndarray | None = None,
                 max_shift: float | None = None, min_votes: int = 1,
                 phi_min: np.ndarray | None = None) -> HybridResult:
    """Fix the rigid fringe-order shift of each object of ``Φ_r`` from ``Φ_e`` (Eq. 5.13–5.15).

    Parameters
    ----------
    phi_r : (H, W) float
        Relative phase per object (period ``period``), NaN outside objects.
    labels_r : (H, W) int
        Objects of ``phi_r`` (0 = background).
    phi_e : (H, W) float
        Absolute phase with motion error (period ``period_low``), NaN invalid.
    period, period_low : float
        ``T`` and ``T_l`` in projector pixels.
    labels_e : (H, W) int, optional
        Objects as seen in the low-frequency frames. When given, each object of ``labels_r``
        is paired with one of ``labels_e`` (nearest bounding-box centre) and ``Φ_e`` is read
        at ``(u + Δu, v + Δv)``; when omitted no motion compensation is applied.
    max_shift : float, optional
        Largest plausible object displacement (pixels) when pairing objects.
    min_votes : int
        Objects with fewer pixels where ``k_e`` is defined get no ``k_s`` (NaN output).
    phi_min : (H, W) float, optional
        Minimum phase map ``Φ_min`` (period ``period_low``, Eq. 4.19). Eq. (5.13) reads ``Φ_e`` at
        the moved pixel, but even a rigidly moving surface changes phase when it moves *across*
        the fringes (the projector coordinate follows the camera column). Given ``Φ_min``, that
        part is removed: ``Φ_e(u+Δu, v+Δv) − [Φ_min(u+Δu, v+Δv) − Φ_min(u, v)]``. Without it
        (the dissertation's form) motion across the fringes must stay well under ``T/2``
        projector pixels; motion along the fringes (free fall with vertical fringes) needs none.

    Returns
    -------
    :class:`HybridResult`
    """
    phi_r = np.asarray(phi_r, np.float64)
    phi_e = np.asarray(phi_e, np.float64)
    labels_r = np.asarray(labels_r, np.int32)
    if not (phi_r.shape == phi_e.shape == labels_r.shape):
        raise ValueError(f"phi_r {phi_r.shape}, labels_r {labels_r.shape} and phi_e {phi_e.shape} "
                         "must have the same (H, W) shape")
    if not (period > 0 and period_low > 0):
        raise ValueError(f"fringe periods must be positive, got T={period}, T_l={period_low}")
    scale = period_low / period
    if phi_min is not None:
        phi_min = np.asarray(phi_min, np.float64)
        if phi_min.shape != phi_r.shape:
            raise ValueError(f"phi_min shape {phi_min.shape} differs from phase shape {phi_r.shape}")
    shifts: dict[int, tuple[float, float]] = {}
    unmatched: list[int] = []
    present = [int(l) for l in np.unique(labels_r) if l > 0]
    if labels_e is None:
        k_e = fringe_order_difference(phi_r, phi_e, scale)
        k_e[labels_r == 0] = np.nan
        shifts = {l: (0.0, 0.0) for l in present}
    else:
        labels_e = np.asarray(labels_e)
        if labels_e.shape != labels_r.shape:
            raise ValueError(f"labels_e shape {labels_e.shape} differs from labels_r shape {labels_r.shape}")
        matches = {m.label_a: m for m in match_objects(labels_r, labels_e, max_shift=max_shift)}
        k_e = np.full(phi_r.shape, np.nan)
        for l in present:
            m = matches.get(l)
            du, dv = (m.du, m.dv) if m is not None else (0.0, 0.0)
            if m is None:
                unmatched.append(l)
            shifts[l] = (du, dv)
            moved = shift_image(phi_e, du, dv)
            if phi_min is not None:
                moved = moved - (shift_image(phi_min, du, dv) - phi_min)
            obj = labels_r == l
            k_e[obj] = fringe_order_difference(phi_r[obj], moved[obj], scale)
    votes = mode_of_orders(k_e, labels_r, min_votes=min_votes)
    phase = apply_order_shift(phi_r, labels_r, votes)
    return HybridResult(phase=phase, relative=phi_r.astype(np.float32), labels=labels_r,
                        k_e=k_e, votes=votes, shifts=shifts, unmatched=unmatched)


def carrier_from_minimum_phase(phi_min: np.ndarray, scale: float = 1.0) -> tuple[float, float]:
    """FTP carrier ``(f_v, f_u)`` (cycles/pixel) predicted by the rig: the median gradient of
    ``Φ_min`` (Eq. 4.19) times ``scale`` (= period of ``phi_min`` / FTP period), over 2π.

    A fringe image alone cannot tell ``cos Φ`` from ``cos(−Φ)``, and on small objects against a
    dark background the spectral peak search can lock onto the objects' own spectrum. The
    calibrated rig knows both the carrier's frequency and which way the phase runs: centring the
    band-pass window there makes the FTP phase grow like the absolute phase.

    Parameters
    ----------
    phi_min : (H, W) array_like
        Minimum phase map (rad), NaN where undefined.
    scale : float
        Period of ``phi_min`` divided by the FTP period.

    Returns
    -------
    tuple of float
        Carrier ``(f_v, f_u)`` (cycles/pixel).
    """
    phi_min = np.asarray(phi_min, np.float64)
    gv, gu = np.gradient(phi_min)
    ok = np.isfinite(gv) & np.isfinite(gu)
    if not ok.any():
        raise ValueError("the minimum phase map has no finite values; cannot predict the FTP carrier")
    return (float(np.median(gv[ok])) * scale / TWO_PI, float(np.median(gu[ok])) * scale / TWO_PI)


def ftp_group_phase(images: np.ndarray, shifts, carrier: tuple[float, float],
                    window: str = "hanning") -> PhaseResult:
    """FTP (one frame, Eq. 4.1–4.4) or modified FTP (π-shifted pair, Eq. 4.5–4.7) on a given
    carrier; returns a ``PhaseResult`` whose wrapped phase is ``Φ`` (frame shift removed).

    Parameters
    ----------
    images : (1 or 2, H, W) array
    shifts : sequence of the frames' phase shifts (rad)
    carrier : (f_v, f_u) cycles/pixel, e.g. :func:`carrier_from_minimum_phase`
    window : ``"hanning"`` or ``"circular"`` (smoothed circular), see ``fringe3d.phase.ftp``

    Returns
    -------
    PhaseResult
        Wrapped phase (rad, (-pi, pi]), average and modulation, each (H, W) float32.
    """
    imgs = np.asarray(images, np.float64)
    if imgs.ndim != 3 or imgs.shape[0] not in (1, 2):
        raise ValueError(f"FTP takes one frame or a pi-shifted pair, got an array of shape {imgs.shape}")
    if imgs.shape[0] == 1:
        r = ftp.ftp_analysis(imgs[0], window=window, carrier=carrier)
        phase, mod, avg = r.phase, r.modulation, r.average
    else:
        phase, mod = ftp.modified_ftp_phase(imgs[0], imgs[1], window=window, carrier=carrier)
        avg = 0.5 * (imgs[0] + imgs[1])
    phase = np.angle(np.exp(1j * (phase - float(shifts[0]))))
    return PhaseResult(phase.astype(np.float32), np.asarray(avg, np.float32), np.asarray(mod, np.float32))


@dataclass(frozen=True)
class HybridSettings:
    """The object segmentation and motion thresholds of :func:`hybrid_unwrap`.

    Attributes
    ----------
    erode : int
        Erosion of each object mask before unwrapping, pixels (FTP is unreliable at the rim);
        default 2.
    min_size : int
        Smallest object, pixels; default 200.
    min_ratio : float
        Fringe-contrast threshold ``B / A``, dimensionless, of
        :func:`fringe3d.unwrap.segmentation.foreground_mask`; default 0.15.
    max_shift : float, optional
        Largest object displacement between the captures, pixels (default None: no limit).
    cross_motion : bool
        Also remove the phase change of motion across the fringes (``phi_min`` of
        :func:`hybrid_phase`); default False, the dissertation's Eq. (5.13).

    Examples
    --------
    >>> HybridSettings(max_shift=12.0).min_size
    200
    """

    erode: int = 2
    min_size: int = 200
    min_ratio: float = 0.15
    max_shift: float | None = None
    cross_motion: bool = False


def hybrid_unwrap(high: PhaseResult, low: PhaseResult, mp_low: MinimumPhase, period: float, period_low: float, *,
                  settings: HybridSettings | None = None, seed: int | None = 0, valid_high: np.ndarray | None = None,
                  valid_low: np.ndarray | None = None) -> HybridResult:
    """The whole hybrid chain from wrapped phases (ch. 5.2.5, Fig. 5.4).

    Parameters
    ----------
    high : PhaseResult-like (``phase``, ``average``, ``modulation``, each (H, W))
        FTP of the high-frequency frame; ``phase`` is the wrapped ``Φ`` (shift removed, sign
        as the absolute phase: see :func:`ftp_group_phase`).
    low : PhaseResult-like
        3-step phase of the low-frequency frames (Eq. 5.9).
    mp_low : fringe3d.unwrap.geometric.MinimumPhase
        ``Φ_min`` for ``period_low`` (Eq. 4.19).
    period, period_low : float
        ``T`` and ``T_l`` (projector pixels).
    settings : HybridSettings, optional
        Rim erosion (px), smallest object (px), contrast threshold, largest displacement (px) and
        cross-fringe motion correction (default ``HybridSettings()``).
    seed : int or None
        Seed of the spatial unwrapping (:func:`fringe3d.unwrap.spatial.unwrap_objects`).
    valid_high, valid_low : (H, W) bool, optional
        Extra validity (e.g. not saturated) of the high / low frames.

    Returns
    -------
    :class:`HybridResult` with ``coarse`` = ``Φ_e`` and ``labels_low``.
    """
    s = settings if settings is not None else HybridSettings()
    erode, min_size, min_ratio = s.erode, s.min_size, s.min_ratio
    fg_h = foreground_mask(high.average, high.modulation, min_ratio)
    if valid_high is not None:
        fg_h &= np.asarray(valid_high, bool)
    labels_r = segment_objects(fg_h, min_size=min_size, erode=erode)
    phi_r, labels_r = unwrap_objects(high.phase, labels=labels_r, seed=seed)
    fg_l = foreground_mask(low.average, low.modulation, min_ratio)
    if valid_low is not None:
        fg_l &= np.asarray(valid_low, bool)
    labels_e = segment_objects(fg_l, min_size=min_size, erode=erode)
    phi_e, _ = geometric_unwrap(low.phase, mp_low, labels_e > 0, check=False)
    res = hybrid_phase(phi_r, labels_r, phi_e, period, period_low, labels_e=labels_e,
                       max_shift=s.max_shift, phi_min=mp_low.phi_min if s.cross_motion else None)
    res.coarse = phi_e
    res.labels_low = labels_e
    return res
