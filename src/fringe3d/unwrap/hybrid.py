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
:mod:`fringe3d.reconstruct.motion` runs the whole chain from frames, and the decoder reaches
it through the ``"hybrid"`` unwrapper registered at the bottom of this module.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .histogram import OrderVote, apply_order_shift, fringe_order_difference, mode_of_orders
from .segmentation import match_objects, shift_image


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
