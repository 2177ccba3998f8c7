"""Fringe-coordinate conventions, each written once (Eq. 2.1-2.2, 1.5, 2.30-2.34).

A fringe pattern at angle ``alpha`` (0 <= alpha < pi) varies along the fringe coordinate

    ``w = v cos(alpha) + u sin(alpha)``                                   (Eq. 2.1-2.2)

with ``u`` the projector column, ``v`` the projector row (pixels, pixel centres at integer
coordinates): ``alpha = pi/2`` (vertical stripes) gives ``w = u``, ``alpha = 0`` (horizontal
stripes) ``w = v``. A phase map of period ``T`` encodes it as the absolute phase
``Phi = 2 pi w / T``, so ``w = Phi T / 2 pi`` (Eq. 2.30-2.31). Two directions give the
projector point ``(u, v)`` (Eq. 2.30-2.34); a coarse absolute phase gives the fringe order of
a finer wrapped one (Eq. 1.5 with the period ratio); two periods beat to the
equivalent period ``T1 T2 / |T2 - T1|`` (three-frequency heterodyne, ch. 2.2.4).

The functions are vectorised and keep the dtype of their array arguments (a float32 array
times a Python float stays float32); scalars in give NumPy scalars out.
"""
from __future__ import annotations

import math
from typing import Literal, Sequence

import numpy as np

TWO_PI = 2.0 * math.pi


def fringe_coordinate(u, v, angle: float):
    """Fringe coordinate ``w = v cos(angle) + u sin(angle)`` (Eq. 2.1).

    Parameters
    ----------
    u, v : array_like
        Column and row (projector pixels; or any pair of components along the pixel axes,
        e.g. spatial frequencies ``(f_u, f_v)``), broadcast against each other.
    angle : float
        Fringe angle alpha in radians.

    Returns
    -------
    ndarray
        ``w`` in the units of ``u, v``, broadcast shape; float inputs keep their dtype,
        integer inputs give float64.

    Examples
    --------
    >>> import math
    >>> float(fringe_coordinate(3.0, 5.0, 0.0)), round(float(fringe_coordinate(3.0, 5.0, math.pi / 2)), 12)
    (5.0, 3.0)
    """
    return np.asarray(v) * math.cos(angle) + np.asarray(u) * math.sin(angle)


def stripe_coordinate(u, v, angle: float):
    """Coordinate along the stripes, ``-v sin(angle) + u cos(angle)``: perpendicular to
    :func:`fringe_coordinate` (used to lay out area-modulated cells along each stripe)."""
    return -np.asarray(v) * math.sin(angle) + np.asarray(u) * math.cos(angle)


def w_range(angle: float, width: int, height: int) -> tuple[float, float]:
    """Smallest and largest fringe coordinate over a projector's pixel centres.

    ``w`` is linear in ``(u, v)``, so its extremes over the ``width x height`` projector lie at
    the corner pixel centres ``u in {0, width - 1}``, ``v in {0, height - 1}`` (Eq. 2.1).
    ``w_min < 0`` only for angles above pi/2.

    Parameters
    ----------
    angle : float
        Fringe angle alpha (rad).
    width, height : int
        Projector resolution (px).

    Returns
    -------
    tuple of float
        ``(w_min, w_max)`` in projector pixels.

    Examples
    --------
    >>> import math
    >>> w_range(math.pi / 2, 800, 600)[1], w_range(0.0, 800, 600)
    (799.0, (0.0, 599.0))
    """
    c, s = math.cos(angle), math.sin(angle)
    corners = [v * c + u * s for v in (0, height - 1) for u in (0, width - 1)]
    return min(corners), max(corners)


def point_at_fringe_coordinate(w, angle: float):
    """Projector point ``(u, v) = w (sin(angle), cos(angle))`` on the line through the origin
    normal to the stripes, whose fringe coordinate (Eq. 2.1) is ``w``."""
    return w * math.sin(angle), w * math.cos(angle)


def phase_to_w(phase, period: float, *, scale_first: bool = True):
    """Fringe coordinate from absolute phase, ``w = Phi T / 2 pi`` (Eq. 2.30-2.31).

    Parameters
    ----------
    phase : array_like
        Absolute phase ``Phi`` (rad).
    period : float
        Fringe period ``T`` (projector pixels).
    scale_first : bool
        ``True``: ``Phi * (T / 2 pi)`` (one multiplication by the precomputed scale);
        ``False``: ``(Phi * T) / 2 pi``. The two differ in the last bit for some values.

    Returns
    -------
    ndarray or scalar
        ``w`` (projector pixels), the shape and dtype of ``phase``.

    Examples
    --------
    >>> import math
    >>> float(phase_to_w(math.pi, 18.0))
    9.0
    """
    if scale_first:
        return phase * (period / TWO_PI)
    return phase * period / TWO_PI


def w_to_phase(w, period: float, *, scale_first: bool = False):
    """Absolute phase of a fringe coordinate, ``Phi = 2 pi w / T`` (Eq. 2.2), inverse of
    :func:`phase_to_w`.

    Parameters
    ----------
    w : array_like
        Fringe coordinate (projector pixels).
    period : float
        Fringe period ``T`` (projector pixels).
    scale_first : bool
        ``False`` (default): ``(2 pi * w) / T``; ``True``: ``w * (2 pi / T)``.

    Returns
    -------
    ndarray or scalar
        Absolute phase ``Phi`` (rad), the shape and dtype of ``w``.

    Examples
    --------
    >>> float(w_to_phase(9.0, 18.0))  # doctest: +ELLIPSIS
    3.14159...
    """
    if scale_first:
        return w * (TWO_PI / period)
    return TWO_PI * w / period


def coarse_to_fine_order(coarse_phase, fine_phase, period_ratio: float = 1.0, *,
                 ties: Literal["even", "up"] = "even"):
    """Fringe order of a finer phase from a coarser absolute one (Eq. 1.5):

        ``k = round((Phi_coarse * (T_coarse / T_fine) - phi_fine) / 2 pi)``

    so that ``Phi_fine = phi_fine + 2 pi k``. (The geometric constraint's order, Eq. 4.20-4.21,
    is :func:`fringe3d.unwrap.geometric.fringe_order`.)

    Parameters
    ----------
    coarse_phase : array_like
        Absolute phase of the coarse pattern (rad, period ``T_coarse``).
    fine_phase : array_like
        Wrapped phase of the fine pattern (rad, period ``T_fine``).
    period_ratio : float
        ``T_coarse / T_fine`` (computed by the caller, as one number).
    ties : ``"even"`` or ``"up"``
        Rounding: ``"even"`` is ``numpy.round`` (halves to even), ``"up"`` is
        ``floor(x + 0.5)`` (halves up, as the numba kernels do).

    Returns
    -------
    ndarray
        ``k`` as floats (same dtype as the arithmetic), broadcast shape.

    Examples
    --------
    >>> import math
    >>> float(coarse_to_fine_order(2 * math.pi * 1.1, 0.8 * math.pi, 8.0))  # 8 * 1.1 = 8.8 fringes
    8.0
    """
    if ties == "even":
        return np.round((coarse_phase * period_ratio - fine_phase) / TWO_PI)
    if ties == "up":
        return np.floor((coarse_phase * period_ratio - fine_phase) / TWO_PI + 0.5)
    raise ValueError(f"ties must be 'even' or 'up', got {ties!r}")


def beat_period(t1: float, t2: float) -> float:
    """Equivalent (beat) period ``t1 t2 / |t2 - t1|`` of two phase maps (three-frequency heterodyne, ch. 2.2.4).

    Raises ``ValueError`` for equal periods.

    Parameters
    ----------
    t1, t2 : float
        The two fringe periods (projector px), distinct.

    Returns
    -------
    float
        The beat period (px).

    Examples
    --------
    >>> beat_period(18.0, 21.0), beat_period(126.0, 144.0)
    (126.0, 1008.0)
    """
    if t1 == t2:
        raise ValueError(f"heterodyne needs distinct periods, got {t1} twice")
    return t1 * t2 / abs(t2 - t1)


def direction_matrix(angles: Sequence[float]) -> np.ndarray:
    """``(k, 2)`` float64 matrix ``A`` with rows ``(sin(alpha_i), cos(alpha_i))``, so that the
    fringe coordinates of projector point ``(u, v)`` are ``w = A @ (u, v)`` (Eq. 2.1)."""
    return np.array([[np.sin(a), np.cos(a)] for a in angles])


def projector_coordinates(w, angles: Sequence[float], *, solver: Literal["pinv", "inv"] = "pinv") -> np.ndarray:
    """Projector point ``(u_p, v_p)`` from fringe coordinates along two or more directions
    (Eq. 2.30-2.31 for alpha = pi/2 and 0; Eq. 2.32-2.34 for any two non-parallel angles,
    e.g. the rotated pair ``alpha_opt -/+ pi/4``).

    Parameters
    ----------
    w : (..., k) array_like
        Fringe coordinates, one column per direction (NaN propagates).
    angles : (k,) float
        Fringe angle of each column (rad).
    solver : ``"pinv"`` or ``"inv"``
        ``"pinv"``: least squares, ``w @ pinv(A).T`` (any k >= 2); ``"inv"``: the exact 2x2
        inverse ``w @ inv(A).T`` (k = 2).

    Returns
    -------
    (..., 2) float64 ``(u_p, v_p)``.

    Examples
    --------
    >>> import math
    >>> projector_coordinates([[5.0, 3.0]], [math.pi / 2, 0.0]).round(12).tolist()
    [[5.0, 3.0]]
    """
    A = direction_matrix(angles)
    if solver == "pinv":
        return np.asarray(w, float) @ np.linalg.pinv(A).T
    if solver == "inv":
        return np.asarray(w, float) @ np.linalg.inv(A).T
    raise ValueError(f"solver must be 'pinv' or 'inv', got {solver!r}")
