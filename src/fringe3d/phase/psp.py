"""Phase-shifting profilometry: wrapped phase, average intensity and modulation.

Model (Eq. 2.3, manifest convention): ``I_k = A + B cos(phi + delta_k)``, k = 0..N-1.

* Equal shifts ``delta_k = 2 pi k / N`` (Eq. 2.4, sign derived):
  ``phi = atan2(-sum_k I_k sin delta_k, sum_k I_k cos delta_k)``, ``A = mean_k I_k``,
  ``B = (2/N) |sum_k I_k exp(-i delta_k)|``. (Expanding ``cos(phi + delta)`` gives
  ``sum I_k cos delta_k = (N/2) B cos phi`` and ``sum I_k sin delta_k = -(N/2) B sin phi``.)
* Arbitrary shifts: least squares of ``I_k = a + b cos delta_k + c sin delta_k``,
  ``phi = atan2(-c, b)``, ``B = hypot(b, c)``; identical to Eq. (2.4) for equal shifts.
* 3-step (Eq. 1.1-1.4, shifts -2pi/3, 0, +2pi/3): ``phi = atan2(sqrt(3)(I1 - I3), 2 I2 - I1 - I3)``.

Phase noise floor for N equal steps and Gaussian intensity noise sigma:
``sigma_phi = sqrt(2/N) sigma / B``.
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple, Sequence

import numpy as np

from fringe3d.gpu.runtime import check_backend
from fringe3d.phase import _kernels
from fringe3d.phase.frames import as_frame_stack


class PhaseResult(NamedTuple):
    """Wrapped phase (rad, (-pi, pi]), average intensity A and modulation B, each (H, W) float32."""

    phase: np.ndarray
    average: np.ndarray
    modulation: np.ndarray


def default_shifts(n: int) -> np.ndarray:
    """Equal shifts ``2 pi k / n`` (Eq. 2.4), float64 (n,).

    Parameters
    ----------
    n : int
        Number of phase-shifted frames.

    Returns
    -------
    ndarray
        ``(n,)`` float64 shifts (rad).
    """
    return 2.0 * np.pi * np.arange(n) / n


def lsq_coefficients(shifts: Sequence[float] | np.ndarray) -> np.ndarray:
    """(3, N) float64 matrix P with ``(a, b, c) = P @ I`` for ``I_k = a + b cos d_k + c sin d_k``.

    Raises ``ValueError`` when fewer than 3 shifts are given or the shifts cannot separate
    A, B and phi (e.g. two distinct shifts only). Results are cached per shift tuple (the
    pseudo-inverse costs ~0.1 ms, which matters for per-frame decoding); a fresh copy is returned.

    Parameters
    ----------
    shifts : (N,) sequence of float
        Phase shift of each frame (rad).

    Returns
    -------
    ndarray
        ``(3, N)`` float64 pseudo-inverse of the design matrix ``[1, cos d_k, sin d_k]``.
    """
    d = np.asarray(shifts, dtype=np.float64).ravel()
    return _lsq_coefficients(tuple(d.tolist())).copy()


@functools.lru_cache(maxsize=256)
def _lsq_coefficients(shifts: tuple[float, ...]) -> np.ndarray:
    d = np.array(shifts, dtype=np.float64)
    if d.size < 3:
        raise ValueError(f"phase shifting needs at least 3 frames, got {d.size} (shifts {d.tolist()})")
    design = np.stack([np.ones_like(d), np.cos(d), np.sin(d)], axis=1)
    if np.linalg.matrix_rank(design, tol=1e-9) < 3:
        raise ValueError(f"phase shifts {np.round(d, 6).tolist()} rad cannot separate average, "
                         "modulation and phase; expected at least 3 distinct shifts modulo 2pi")
    p = np.linalg.pinv(design)
    p.flags.writeable = False
    return p


def wrapped_phase(frames, shifts=None, index=None, saturation_level: float | None = None,
                  return_saturated: bool = False, backend: str = "cpu", device_output: bool = False):
    """N-step least-squares wrapped phase, average and modulation (Eq. 2.4), fused numba kernel.

    Parameters
    ----------
    frames : (F, H, W) uint8, uint16 or float array (or a list of (H, W) arrays)
        Camera frames; read in place, never converted to a full-size float copy.
    shifts : (N,) float, optional
        Phase shift of each used frame in rad; default ``2 pi k / N``.
    index : (N,) int, optional
        Which frames of ``frames`` to use (default all); lets the decoder pick one group out
        of a whole capture without copying it.
    saturation_level : float, optional
        Flag pixels where any used frame is >= this value (returned when ``return_saturated``).
    return_saturated : bool
        Also return the (H, W) bool saturation map.
    backend : {"cpu", "cuda"}
        ``"cuda"`` runs :func:`fringe3d.gpu.ops.wrapped_phase` on a CUDA device (raises
        :class:`fringe3d.gpu.CudaUnavailableError` without one); it also takes many cycles at
        once, ``frames (C, F, H, W)`` (host or device array), and returns (C, H, W) maps.
    device_output : bool
        ``backend="cuda"`` only: leave the outputs on the device (numba device arrays).

    Returns
    -------
    PhaseResult(phase, average, modulation), each (H, W) float32; phase in (-pi, pi] rad,
    average and modulation in the frames' units. With ``return_saturated`` also an (H, W)
    bool saturation map.

    Example
    -------
    >>> import numpy as np
    >>> d = 2 * np.pi * np.arange(4) / 4
    >>> f = np.stack([100 + 50 * np.cos(0.3 + dk) * np.ones((2, 2)) for dk in d])
    >>> float(wrapped_phase(f).phase[0, 0])  # doctest: +ELLIPSIS
    0.3...
    """
    if check_backend(backend) == "cuda":
        return _wrapped_phase_cuda(frames, shifts, index, saturation_level, return_saturated, device_output)
    frames = as_frame_stack(frames, layout="(N, H, W)")
    idx = np.arange(frames.shape[0]) if index is None else np.asarray(index, dtype=np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= frames.shape[0]):
        raise ValueError(f"frame index {idx.tolist()} out of range for {frames.shape[0]} frames")
    d = default_shifts(idx.size) if shifts is None else np.asarray(shifts, dtype=np.float64)
    if d.size != idx.size:
        raise ValueError(f"got {d.size} phase shifts for {idx.size} frames; expected one shift per frame")
    result, saturated, _ = _wrapped_phase_cpu(frames, d, idx, saturation_level, None)
    return (result, saturated) if return_saturated else result


class ValidPhase(NamedTuple):
    """A group's mask from its PSP pass (:func:`wrapped_phase_and_mask`): ``mask`` (H, W) bool,
    ``phase`` float32 NaN outside it, ``invalid`` uint8 ``~mask`` (0/1) and ``laplacian``, the
    ``(sum |I * L|, count)`` of the average image over the mask's interior
    (:func:`fringe3d.phase.noise.interior_laplacian` of ``(average, mask)``)."""

    mask: np.ndarray
    phase: np.ndarray
    invalid: np.ndarray
    laplacian: tuple[float, int]


def _wrapped_phase_cpu(frames: np.ndarray, shifts: np.ndarray, idx: np.ndarray, saturation_level: float | None,
                       min_modulation: np.float32 | None):
    """The numba pass of :func:`wrapped_phase`: ``(PhaseResult, saturated, valid)``; with
    ``min_modulation`` (float32) ``valid`` is the :class:`ValidPhase` of
    :func:`wrapped_phase_and_mask`, else None."""
    coef = lsq_coefficients(shifts)
    h, w = frames.shape[1:]
    phase = np.empty((h, w), np.float32)
    average = np.empty((h, w), np.float32)
    modulation = np.empty((h, w), np.float32)
    saturated = np.empty((h, w), np.bool_)
    shape, rows = ((h, w), h) if min_modulation is not None else ((0, 0), 0)
    mask, masked, invalid = np.empty(shape, np.bool_), np.empty(shape, np.float32), np.empty(shape, np.uint8)
    sums, counts = np.zeros(rows, np.float64), np.zeros(rows, np.int64)
    sat = math.inf if saturation_level is None else float(saturation_level)
    mode, threshold = _kernels.saturation_test(frames.dtype, sat)
    _kernels.psp_kernel(frames, idx.astype(np.int64), coef, sat, mode, threshold, phase, average, modulation,
                      saturated, np.float32(0.0 if min_modulation is None else min_modulation), mask, masked,
                      invalid, sums, counts, _kernels.ATAN_CONSTANTS)
    valid = None if min_modulation is None else ValidPhase(mask, masked, invalid,
                                                           (float(sums.sum()), int(counts.sum())))
    return PhaseResult(phase, average, modulation), saturated, valid


def wrapped_phase_and_mask(frames: np.ndarray, shifts, index, saturation_level: float | None,
                           min_modulation: np.float32):
    """:func:`wrapped_phase` (CPU, ``return_saturated``) and, from the same pass, the
    :class:`ValidPhase`: ``mask = (modulation >= min_modulation) & ~saturated & isfinite(phase)``
    (H, W) bool, the phase with NaN outside it (float32), ``~mask`` as uint8 and the Laplacian
    noise sums of the average over the mask (new arrays).

    Parameters
    ----------
    frames : (F, H, W) ndarray
        Camera frames, any real dtype.
    shifts : (N,) float
        Phase shift of each used frame (rad).
    index : (N,) int
        Which frames of ``frames`` to use.
    saturation_level : float or None
        As in :func:`wrapped_phase`.
    min_modulation : numpy.float32
        The modulation threshold, compared in float32.

    Returns
    -------
    tuple
        ``(PhaseResult, saturated, ValidPhase)``.
    """
    frames = as_frame_stack(frames, layout="(N, H, W)")
    idx = np.asarray(index, dtype=np.int64)
    d = np.asarray(shifts, dtype=np.float64)
    if d.size != idx.size or (idx.size and (idx.min() < 0 or idx.max() >= frames.shape[0])):
        raise ValueError(f"got {d.size} phase shifts for frame index {idx.tolist()} of {frames.shape[0]} frames; "
                         "expected one shift per frame and indices in range")
    pr, saturated, valid = _wrapped_phase_cpu(frames, d, idx, saturation_level, np.float32(min_modulation))
    assert valid is not None
    return pr, saturated, valid


def _wrapped_phase_cuda(frames, shifts, index, saturation_level, return_saturated, device_output):
    """:func:`wrapped_phase` on the CUDA backend (one (F, H, W) cycle or (C, F, H, W) cycles)."""
    from fringe3d.gpu import ops

    n_frames = tuple(frames.shape)[-3] if hasattr(frames, "shape") and len(frames.shape) >= 3 else len(frames)
    idx = np.arange(n_frames) if index is None else np.asarray(index, dtype=np.int64)
    d = default_shifts(idx.size) if shifts is None else np.asarray(shifts, dtype=np.float64)
    if d.size != idx.size:
        raise ValueError(f"got {d.size} phase shifts for {idx.size} frames; expected one shift per frame")
    if not hasattr(frames, "copy_to_host"):
        frames = np.asarray(frames)
    sat = math.inf if saturation_level is None else float(saturation_level)
    phase, average, modulation, saturated = ops.wrapped_phase(frames, lsq_coefficients(d), idx, sat,
                                                              device_output=device_output)
    result = PhaseResult(phase, average, modulation)
    return (result, saturated) if return_saturated else result


def three_step(i1, i2, i3) -> np.ndarray:
    """3-step wrapped phase, Eq. (1.4), for shifts -2pi/3, 0, +2pi/3 (Eq. 1.1-1.3).

    ``phi = atan2(sqrt(3) (I1 - I3), 2 I2 - I1 - I3)``; inputs (H, W) any real dtype,
    output (H, W) float64 rad in (-pi, pi]. A manifest whose 3-step set uses shifts
    0, 2pi/3, 4pi/3 is the same formula with the frames taken in the order (I3, I1, I2);
    :func:`wrapped_phase` with the manifest's shifts handles any order.

    Parameters
    ----------
    i1, i2, i3 : (H, W) array_like
        Frames at shifts -2pi/3, 0 and +2pi/3, any real dtype.

    Returns
    -------
    ndarray
        ``(H, W)`` float64 wrapped phase (rad, (-pi, pi]).

    Examples
    --------
    >>> import numpy as np
    >>> i1, i2, i3 = (100 + 50 * np.cos(0.5 + d) * np.ones((2, 2)) for d in (-2 * np.pi / 3, 0, 2 * np.pi / 3))
    >>> round(float(three_step(i1, i2, i3)[0, 0]), 12)
    0.5
    """
    a = np.asarray(i1, dtype=np.float64)
    b = np.asarray(i2, dtype=np.float64)
    c = np.asarray(i3, dtype=np.float64)
    if not (a.shape == b.shape == c.shape):
        raise ValueError(f"three_step needs frames of one shape, got {a.shape}, {b.shape}, {c.shape}")
    return np.arctan2(math.sqrt(3.0) * (a - c), 2.0 * b - a - c)
