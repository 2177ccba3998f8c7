"""Histogram (mode) fringe-order shift per object: ``k_s = mode(k_e)`` (Eq. 5.12–5.15, ch. 6).

A spatially unwrapped phase map ``Φ_r`` is correct up to one rigid shift ``2π·k_s`` per
object (Eq. 5.12). A coarse absolute map ``Φ_ref`` (from low-frequency phase shifting plus
the geometric constraint, or the minimum phase map ``Φ_min`` itself) gives, pixel by pixel, a
noisy estimate ``k_e = round[(Φ_ref·T_ref/T − Φ_r)/2π]`` (Eq. 5.13). Most pixels agree; the
mode of the histogram of ``k_e`` over the object is ``k_s`` (Eq. 5.14), and
``Φ_a = Φ_r + 2π·k_s`` (Eq. 5.15). Chapter 6 uses the same idea ("histogram-based
unwrapping") for modified-FTP frames of the flapping wing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fringe3d.patterns.conventions import TWO_PI, coarse_to_fine_order
from fringe3d.unwrap.geometric import MinimumPhase, fringe_order


@dataclass(frozen=True)
class OrderVote:
    """The mode of one object's fringe-order histogram.

    Attributes
    ----------
    label : int
        Object label.
    k_s : int
        The most common fringe-order difference (Eq. 5.14).
    share : float
        Fraction of the object's voting pixels that agree with ``k_s`` (0..1).
    votes : int
        Number of pixels that voted (finite in both maps).
    """

    label: int
    k_s: int
    share: float
    votes: int


def fringe_order_difference(phi_r: np.ndarray, phi_ref: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Per-pixel fringe-order difference ``k_e = round[(Φ_ref·scale − Φ_r)/2π]`` (Eq. 5.13).

    ``scale = T_ref/T`` converts the reference phase (period ``T_ref``) into the period ``T`` of
    ``Φ_r``. Returns (H, W) float64 with NaN where either input is NaN.

    Parameters
    ----------
    phi_r : (H, W) array_like
        Relative (spatially unwrapped) phase, period ``T`` (rad).
    phi_ref : (H, W) array_like
        Coarse absolute phase, period ``T_ref`` (rad), NaN invalid.
    scale : float
        ``T_ref / T`` (positive).

    Returns
    -------
    ndarray
        ``(H, W)`` float64 integer-valued ``k_e``, NaN where either input is NaN.
    """
    phi_r = np.asarray(phi_r, np.float64)
    phi_ref = np.asarray(phi_ref, np.float64)
    if phi_r.shape != phi_ref.shape:
        raise ValueError(f"phase maps differ in shape: {phi_r.shape} vs {phi_ref.shape}")
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"period ratio T_ref/T must be positive, got {scale}")
    return coarse_to_fine_order(phi_ref, phi_r, scale)


def mode_of_orders(k_e: np.ndarray, labels: np.ndarray, min_votes: int = 1) -> dict[int, OrderVote]:
    """``k_s = mode[k_e]`` over each labelled object (Eq. 5.14).

    Parameters
    ----------
    k_e : (H, W) float
        Integer-valued fringe-order differences; NaN pixels do not vote.
    labels : (H, W) int
        0 = background, 1..n = objects.
    min_votes : int
        Objects with fewer voting pixels are left out of the result.

    Returns
    -------
    dict label -> :class:`OrderVote`. Ties go to the order closest to zero, then the smaller one.
    """
    k_e = np.asarray(k_e, np.float64)
    labels = np.asarray(labels)
    if k_e.shape != labels.shape:
        raise ValueError(f"k_e shape {k_e.shape} differs from labels shape {labels.shape}")
    ok = np.isfinite(k_e) & (labels > 0)
    lab = labels[ok].astype(np.int64)
    k = k_e[ok].astype(np.int64)
    out: dict[int, OrderVote] = {}
    if lab.size == 0:
        return out
    # histogram per object: sort by (label, k) and count runs
    order = np.lexsort((k, lab))
    lab, k = lab[order], k[order]
    start = np.flatnonzero(np.r_[True, (lab[1:] != lab[:-1]) | (k[1:] != k[:-1])])
    counts = np.diff(np.r_[start, lab.size])
    run_lab, run_k = lab[start], k[start]
    for l in np.unique(run_lab):
        sel = run_lab == l
        c, kk = counts[sel], run_k[sel]
        total = int(c.sum())
        if total < min_votes:
            continue
        best = np.flatnonzero(c == c.max())
        pick = best[np.lexsort((kk[best], np.abs(kk[best])))[0]]
        out[int(l)] = OrderVote(int(l), int(kk[pick]), float(c[pick]) / total, total)
    return out


def apply_order_shift(phi_r: np.ndarray, labels: np.ndarray, votes: dict[int, OrderVote]) -> np.ndarray:
    """``Φ_a = Φ_r + 2π·k_s`` per object (Eq. 5.15); objects without a vote become NaN.

    Parameters
    ----------
    phi_r : (H, W) array_like
        Relative phase (rad).
    labels : (H, W) int
        Objects of ``phi_r`` (0 = background, NaN in the output).
    votes : dict
        Label -> :class:`OrderVote`, e.g. from :func:`mode_of_orders`.

    Returns
    -------
    ndarray
        ``(H, W)`` float32 absolute phase ``Φ_a`` (rad).
    """
    phi_r = np.asarray(phi_r, np.float64)
    labels = np.asarray(labels)
    nlab = int(labels.max()) if labels.size else 0
    shift = np.full(nlab + 1, np.nan)
    for l, v in votes.items():
        if 0 < l <= nlab:
            shift[l] = TWO_PI * v.k_s
    return (phi_r + shift[labels]).astype(np.float32)


def histogram_unwrap(phi_r: np.ndarray, labels: np.ndarray, phi_ref: np.ndarray,
                     scale: float = 1.0, min_votes: int = 1) -> tuple[np.ndarray, dict[int, OrderVote]]:
    """Shift each object's relative phase by the mode of its fringe-order difference to a reference.

    Parameters
    ----------
    phi_r : (H, W) float
        Spatially unwrapped (relative) phase, period ``T`` (rad).
    labels : (H, W) int
        Objects of ``phi_r`` (0 = background).
    phi_ref : (H, W) float
        Coarse absolute phase (rad), period ``T_ref`` (NaN = invalid), already aligned with
        ``phi_r`` (no motion between them; see :mod:`fringe3d.unwrap.hybrid` otherwise).
    scale : float
        ``T_ref / T``.
    min_votes : int
        Objects with fewer voting pixels get no vote (NaN).

    Returns
    -------
    phi_a : (H, W) float32
        Absolute phase (Eq. 5.15), NaN outside voted objects.
    votes : dict label -> :class:`OrderVote`
    """
    k_e = fringe_order_difference(phi_r, phi_ref, scale)
    votes = mode_of_orders(k_e, labels, min_votes=min_votes)
    return apply_order_shift(phi_r, labels, votes), votes


def minimum_phase_orders(phi_r: np.ndarray, labels: np.ndarray, mp: MinimumPhase,
                         min_votes: int = 1) -> tuple[np.ndarray, dict[int, OrderVote]]:
    """``k_s`` per object from the minimum phase map alone (single-group histogram unwrapping).

    Each pixel's geometric-constraint order ``k_e = ceil[(Φ_min − Φ_r)/2π]`` (Eq. 4.21; ``floor``
    where the phase falls with depth) is a vote; the mode fixes the object (Eq. 5.14). Unlike
    pixel-wise Eq. (4.21) this tolerates the parts of an object beyond the depth range as long
    as most of it lies within one period of ``z_min``.

    Parameters
    ----------
    phi_r : (H, W) array_like
        Relative phase (rad), period ``mp.period``.
    labels : (H, W) int
        Objects of ``phi_r`` (0 = background).
    mp : MinimumPhase
        ``Φ_min`` for the period of ``phi_r`` (Eq. 4.19).
    min_votes : int
        Objects with fewer voting pixels get no vote (NaN).

    Returns
    -------
    phi_a : ndarray
        ``(H, W)`` float32 absolute phase (rad), NaN outside voted objects.
    votes : dict
        Label -> :class:`OrderVote`.
    """
    k_e = fringe_order(np.asarray(phi_r, np.float64), mp).astype(np.float64)
    votes = mode_of_orders(k_e, labels, min_votes=min_votes)
    return apply_order_shift(phi_r, labels, votes), votes
