"""The projector "captures" the board through absolute phase (ch. 2.2.4-2.2.5, Eq. 2.27-2.34).

A fringe direction at angle ``alpha`` encodes the projector fringe coordinate
``w = v_p cos(alpha) + u_p sin(alpha)`` as absolute phase ``Phi = 2 pi w / T`` (manifest
convention). Sampling two such phase maps at a camera circle centre (bilinear interpolation,
because the centre is sub-pixel) gives two linear equations in ``(u_p, v_p)``; for
vertical/horizontal fringes they are simply ``u_p = Phi_v T / 2pi`` and ``v_p = Phi_h T / 2pi``
(Eq. 2.30-2.31); for the optimal-angle pair ``alpha_opt -/+ pi/4`` solving them is the axis
rotation of Eq. (2.32)-(2.34). The defocus OTF is real and symmetric (Eq. 2.26-2.29), so the
phase - and with it this mapping - does not depend on how defocused the projector is.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fringe3d.patterns.conventions import coarse_to_fine_order, direction_matrix, phase_to_w, projector_coordinates
from fringe3d.phase.sampling import sample_bilinear


@dataclass(frozen=True)
class FringeDirection:
    """One decoded fringe direction: absolute phase map (radians), its fringe angle
    ``alpha`` (radians, manifest convention), its period ``T`` (projector pixels), an
    optional modulation map and validity mask (H, W), and optionally the wrapped phase of
    period ``T`` (H, W) that lets :func:`fringe_coordinates` repair masked fringe orders."""

    phase: np.ndarray
    angle: float
    period: float
    modulation: np.ndarray | None = None
    mask: np.ndarray | None = None
    wrapped: np.ndarray | None = None


def repair_orders(phase: np.ndarray, wrapped: np.ndarray, uv: np.ndarray, max_radius: int = 64) -> np.ndarray:
    """Absolute phase with the fringe orders of the 2x2 bilinear neighbourhoods of ``uv``
    restored where the unwrapping left them invalid (NaN).

    A dark circle's centre has low modulation, so the coarse unwrapping phases there fail
    first while the fine wrapped phase ``wrapped`` (same period) is still good. Each invalid
    neighbour pixel with a valid wrapped phase ``phi`` gets the local model of the valid
    absolute phase around it (:func:`local_fit_sample`, radius 8 px, doubled up to
    ``max_radius`` until enough pixels are valid): ``k = round((Phi_model - phi) / 2 pi)``,
    ``Phi = phi + 2 pi k``. Pixels without enough valid phase around stay NaN. The wrapped
    phase of a repaired pixel is trusted as it is: next to saturated pixels (masked for that
    reason, not for unwrapping) it would be biased - dark circles make that unlikely.

    phase, wrapped : (H, W) radians (phase NaN = invalid); uv : (N, 2) (column, row).
    Returns a copy of ``phase`` (float64).
    """
    out = np.array(phase, dtype=np.float64)
    wr = np.asarray(wrapped, dtype=np.float64)
    h, w = out.shape
    uv = np.asarray(uv, float).reshape(-1, 2)
    uv = uv[np.all(np.isfinite(uv), 1) & np.all(uv >= 0, 1) & (uv[:, 0] <= w - 1) & (uv[:, 1] <= h - 1)]
    c0 = np.minimum(uv[:, 0].astype(int), w - 2)
    r0 = np.minimum(uv[:, 1].astype(int), h - 2)
    rows = np.concatenate([r0, r0, r0 + 1, r0 + 1])
    cols = np.concatenate([c0, c0 + 1, c0, c0 + 1])
    todo = np.unique(np.stack([rows, cols], 1), axis=0)
    todo = todo[np.isnan(out[todo[:, 0], todo[:, 1]]) & np.isfinite(wr[todo[:, 0], todo[:, 1]])]
    model = np.full(len(todo), np.nan)
    radius = 8
    while radius <= max_radius and np.isnan(model).any():
        miss = np.isnan(model)
        model[miss] = local_fit_sample(out, None, todo[miss][:, ::-1].astype(float), radius)
        radius *= 2
    ok = np.isfinite(model)
    r, c = todo[ok, 0], todo[ok, 1]
    phi = wr[r, c]
    out[r, c] = phi + 2 * np.pi * coarse_to_fine_order(model[ok], phi)
    return out


def local_fit_sample(phase: np.ndarray, weight: np.ndarray | None, uv: np.ndarray, radius: float,
                     min_valid: int = 24) -> np.ndarray:
    """Phase at sub-pixel points from a weighted quadratic fit over a window (beyond Eq. 2.30).

    Instead of the 4 pixels of a bilinear sample, every valid pixel within ``radius`` of a
    point enters a least-squares fit ``Phi = c0 + c1 du + c2 dv + c3 du^2 + c4 du dv + c5 dv^2``
    (``du, dv`` from the point), weighted by ``weight`` (use modulation^2: the phase variance
    is proportional to 1/B^2); ``c0`` is the sample. On a board the phase is a smooth
    (homographic) function of the pixel, so the fit averages sensor noise over the whole
    circle and its white ring - the local-model idea of Moreno & Taubin's projector
    calibration, applied to phase. Falls back to NaN with fewer than ``min_valid`` pixels.

    phase : (H, W) radians, NaN invalid; weight : (H, W) or None; uv : (N, 2) (column, row);
    radius : px. Returns (N,) float64.
    """
    ph = np.asarray(phase, np.float64)
    wt = np.ones_like(ph) if weight is None else np.asarray(weight, np.float64)
    h, w = ph.shape
    r = max(float(radius), 1.5)
    uv = np.asarray(uv, float).reshape(-1, 2)
    out = np.full(len(uv), np.nan)
    inside = np.all(np.isfinite(uv), 1) & (uv[:, 0] >= 0) & (uv[:, 0] <= w - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= h - 1)
    idx = np.flatnonzero(inside)
    for i in range(0, len(idx), 64):  # chunks bound the (N, P, 6) design array
        out[idx[i:i + 64]] = _local_fit_chunk(ph, wt, uv[idx[i:i + 64]], r, min_valid)
    return out


def _local_fit_chunk(ph, wt, pts, r, min_valid):
    """:func:`local_fit_sample` for points inside the image, all windows gathered at once."""
    h, w = ph.shape
    k = int(np.ceil(r)) + 1
    oy, ox = np.mgrid[-k:k + 1, -k:k + 1]
    cx, cy = np.round(pts[:, 0]).astype(int), np.round(pts[:, 1]).astype(int)
    xs, ys = cx[:, None] + ox.ravel()[None], cy[:, None] + oy.ravel()[None]
    du, dv = (xs - pts[:, :1]) / r, (ys - pts[:, 1:]) / r
    inb = (xs >= 0) & (xs < w) & (ys >= 0) & (ys < h) & (du * du + dv * dv <= 1.0)
    xs, ys = np.clip(xs, 0, w - 1), np.clip(ys, 0, h - 1)
    val, wk = ph[ys, xs], wt[ys, xs]
    ok = inb & np.isfinite(val) & np.isfinite(wk) & (wk > 0)
    val = np.where(ok, val, 0.0)
    A = np.stack([np.ones_like(du), du, dv, du * du, du * dv, dv * dv], -1)  # (N, P, 6)
    keep = ok
    coef = np.zeros((len(pts), 6))
    for _ in range(2):  # fit, drop pixels off by > pi/2 (a stray fringe order), fit again
        wkeep = np.where(keep, wk, 0.0)
        enough = keep.sum(1) >= min_valid
        Aw = A * wkeep[..., None]  # the weighted normal equations as batched matrix products (BLAS)
        AtA = Aw.transpose(0, 2, 1) @ A
        Atb = (Aw.transpose(0, 2, 1) @ val[..., None])[..., 0]
        AtA[~enough] = np.eye(6)  # placeholders, discarded below
        coef = np.linalg.solve(AtA, Atb[..., None])[..., 0]
        keep = ok & (np.abs(np.einsum("npi,ni->np", A, coef) - val) < np.pi / 2)
    good = (keep.sum(1) >= min_valid) & enough
    res = np.full(len(pts), np.nan)
    res[good] = coef[good, 0]
    return res


def fringe_coordinates(direction: FringeDirection, uv: np.ndarray, min_modulation: float = 0.0,
                       window: float = 0.0) -> np.ndarray:
    """Projector fringe coordinate ``w = Phi T / 2pi`` sampled at camera points ``uv (N, 2)``.

    NaN where the phase is invalid (NaN or masked at any of the 4 neighbours) or where the
    bilinearly sampled modulation is below ``min_modulation`` (same units as the map). With
    the direction's wrapped phase known, invalid fringe orders next to a point are first
    restored from the surrounding valid phase (:func:`repair_orders`). ``window > 0`` replaces
    the bilinear sample by a modulation-weighted quadratic fit over that radius in pixels
    (:func:`local_fit_sample`; bilinear where the window holds too few valid pixels, e.g. tiny
    circles); 0 keeps the dissertation's bilinear interpolation.
    """
    phase = np.asarray(direction.phase, dtype=np.float64)
    if direction.mask is not None:
        phase = np.where(np.asarray(direction.mask, bool), phase, np.nan)
    if direction.wrapped is not None and np.shape(direction.wrapped) == phase.shape:
        phase = repair_orders(phase, direction.wrapped, uv)
    if window > 0:
        weight = None if direction.modulation is None else np.asarray(direction.modulation, np.float64) ** 2
        phi = local_fit_sample(phase, weight, uv, window)
        phi = np.where(np.isnan(phi), sample_bilinear(phase, uv), phi)  # too few pixels: bilinear
    else:
        phi = sample_bilinear(phase, uv)
    w = phase_to_w(phi, direction.period, scale_first=False)
    if direction.modulation is not None and min_modulation > 0:
        mod = sample_bilinear(direction.modulation, uv)
        w = np.where(mod >= min_modulation, w, np.nan)
    return w


def projector_points(directions: list[FringeDirection], uv: np.ndarray, min_modulation: float = 0.0,
                     window: float = 0.0) -> np.ndarray:
    """Projector pixel coordinates ``(u_p, v_p)`` of camera points ``uv (N, 2)``.

    Eq. (2.30)-(2.31) for vertical (alpha = pi/2) and horizontal (alpha = 0) fringes, and the
    rotation of Eq. (2.32)-(2.34) for any two non-parallel angles (e.g. alpha_opt -/+ pi/4):
    each direction gives ``w_k = v_p cos(alpha_k) + u_p sin(alpha_k)``; the 2x2 (or least
    squares, for more directions) system is solved per point.

    Parameters
    ----------
    directions : list of FringeDirection
        Two or more decoded fringe directions of non-parallel angles (absolute phase, rad;
        angle, rad; period, projector px).
    uv : (N, 2) float
        Camera points ``(u, v)``, pixels.
    min_modulation : float
        Points where a direction's sampled modulation is below this (the map's units) are NaN;
        0 keeps every point.
    window : float
        Radius, pixels, of the modulation-weighted quadratic phase fit; 0 samples bilinearly
        (see :func:`fringe_coordinates`).

    Returns
    -------
    (N, 2) ndarray (float64)
        Projector ``(u_p, v_p)``, pixels; NaN rows where any direction is invalid.
    """
    if len(directions) < 2:
        raise ValueError(f"projector mapping needs two fringe directions, got {len(directions)}")
    shapes = {np.shape(d.phase) for d in directions}
    if len(shapes) != 1:
        raise ValueError(f"phase maps have different shapes {sorted(shapes)}; expected one camera size")
    angles = [d.angle for d in directions]
    A = direction_matrix(angles)  # rows: (u_p, v_p) coeffs
    if abs(np.linalg.det(A.T @ A)) < 1e-6:
        raise ValueError("fringe directions are (nearly) parallel; need two different angles")
    W = np.stack([fringe_coordinates(d, uv, min_modulation, window) for d in directions], axis=1)  # (N, k)
    sol = projector_coordinates(W, angles)
    sol[~np.all(np.isfinite(W), axis=1)] = np.nan
    return sol


def projector_maps(directions: list[FringeDirection]) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel projector coordinates ``(u_p, v_p)`` (each (H, W) float64, NaN invalid) from
    two or more fringe directions: the per-pixel form of :func:`projector_points` (Eq. 2.30-2.34).

    Parameters
    ----------
    directions : list of FringeDirection
        Two or more decoded fringe directions of non-parallel angles (absolute phase, rad;
        angle, rad; period, projector px).

    Returns
    -------
    u_p, v_p : (H, W) ndarray (float64)
        Projector column and row per camera pixel, pixels; NaN where a direction's phase is NaN
        or masked.
    """
    if len(directions) < 2:
        raise ValueError(f"projector maps need two fringe directions, got {len(directions)}")
    ws = []
    for d in directions:
        ph = np.asarray(d.phase, np.float64)
        if d.mask is not None:
            ph = np.where(np.asarray(d.mask, bool), ph, np.nan)
        ws.append(phase_to_w(ph, d.period, scale_first=False))
    W = np.stack(ws, -1)  # (H, W, k)
    sol = projector_coordinates(W, [d.angle for d in directions])
    return sol[..., 0], sol[..., 1]
