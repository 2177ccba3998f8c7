"""Rendering pattern frames to projector images (Eq. 2.1-2.2).

Fringe coordinate at projector pixel (row ``v``, column ``u``; pixel centres at integers):
``w = v*cos(angle) + u*sin(angle)``. A phase frame of period ``T`` and shift ``delta`` has the
ideal intensity ``1/2 * (1 + cos(2*pi*w/T + delta))`` (Eq. 2.2); binary kinds approximate it
with 0/1 pixels (see :mod:`fringe3d.patterns.binary` and :mod:`fringe3d.patterns.dither`).
Code frames are Gray / simple binary stripes (:mod:`fringe3d.patterns.codes`).
"""
from __future__ import annotations

import math

import numpy as np

from fringe3d.patterns import binary, codes, dither
from fringe3d.patterns.conventions import fringe_coordinate, stripe_coordinate, w_range, w_to_phase
from fringe3d.patterns.manifest import FrameSpec, PatternSet

BINARY_PHASE_KINDS = ("square", "bayer", "floyd_steinberg", "area_modulated", "pwm")
PHASE_KINDS = ("sinusoid",) + BINARY_PHASE_KINDS


def code_origin(angle: float, width: int, height: int, period: float) -> tuple[float, int]:
    """(w0, stripes) for a code covering the projector: ``w0 = floor(w_min/T)*T``.

    The stripe with codeword 0 starts at ``w0``; the fringe order of a pixel is then
    ``codeword + round(w0 / T)``.
    """
    lo, hi = w_range(angle, width, height)
    m0 = math.floor(lo / period)
    m1 = math.floor(hi / period)
    return m0 * period, m1 - m0 + 1


def _grid(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    v, u = np.mgrid[0:height, 0:width]
    return u, v


def sinusoid_value(spec: FrameSpec, u, v, width: int | None = None, height: int | None = None) -> np.ndarray:
    """Continuous intensity of ``spec`` at projector coordinates ``(u, v)`` (float64 in [0, 1]).

    For phase frames of every kind this is the ideal sinusoid ``1/2(1+cos(2 pi w/T + shift))``
    (Eq. 2.2) that the binary kinds approximate: the simulator's ideal, noise-free mode. Code
    frames give their exact 0/1 stripe value (``width``/``height`` of the projector are then
    needed to place the code's origin), white 1 and black 0.

    Parameters
    ----------
    spec : FrameSpec
        The frame (kind, angle, period, shift; bit, bits and inverse for code frames).
    u, v : array_like
        Projector column and row (px, pixel centres at integers), broadcast against each other.
    width, height : int, optional
        Projector resolution (px); required for code frames only.

    Returns
    -------
    ndarray
        float64 intensity in [0, 1], the broadcast shape of ``u`` and ``v``.
    """
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    shape = np.broadcast(u, v).shape
    if spec.kind == "white":
        return np.ones(shape)
    if spec.kind == "black":
        return np.zeros(shape)
    w = fringe_coordinate(u, v, spec.angle)
    if spec.kind in ("gray_code", "binary_code"):
        return _code_frame(spec, w, width, height).astype(np.float64)
    return 0.5 * (1.0 + np.cos(w_to_phase(w, spec.period) + spec.shift))


def _code_frame(spec: FrameSpec, w: np.ndarray, width: int | None, height: int | None) -> np.ndarray:
    if width is None or height is None:
        raise ValueError("code frames need the projector width and height to place the code origin")
    w0, _ = code_origin(spec.angle, width, height, spec.period)
    bit = codes.code_bit(w, spec.period, w0, spec.bit, spec.bits, gray=spec.kind == "gray_code")
    return (1 - bit) if spec.inverse else bit


def render_frame(spec: FrameSpec, width: int, height: int, *, dither_size: int = 8,
                 area_cell: int = 4, pwm_pulses: int | None = None) -> np.ndarray:
    """Render one frame at projector resolution.

    Parameters
    ----------
    spec : FrameSpec
    width, height : int
        Projector resolution in pixels.
    dither_size : int
        Bayer matrix size for ``kind="bayer"``.
    area_cell : int
        Cell length (pixels along the stripes) for ``kind="area_modulated"``.
    pwm_pulses : int or None
        Carrier periods per fringe period for ``kind="pwm"`` (default about 6 px each).

    Returns
    -------
    (height, width) float32 in [0, 1]; binary kinds give exactly 0 or 1.

    Examples
    --------
    >>> from fringe3d.patterns import sets
    >>> ps = sets.phase_shift(16, 3, "v", width=32, height=8)
    >>> img = render_frame(ps.frames[0], 32, 8)
    >>> img.shape, img.dtype, float(img[0, 0]), float(img[0, 8])
    ((8, 32), dtype('float32'), 1.0, 0.0)
    """
    if width <= 0 or height <= 0:
        raise ValueError(f"projector size must be positive, got {width}x{height}")
    u, v = _grid(width, height)
    if spec.kind in ("white", "black", "gray_code", "binary_code"):
        return sinusoid_value(spec, u, v, width, height).astype(np.float32)
    theta = w_to_phase(fringe_coordinate(u, v, spec.angle), spec.period) + spec.shift
    kind = spec.kind
    if kind == "sinusoid":
        return (0.5 * (1.0 + np.cos(theta))).astype(np.float32)
    if kind == "square":
        return binary.squared_binary(theta, parity=(u + v) % 2)
    if kind == "pwm":
        return binary.pulse_width_modulated(theta, pwm_pulses or binary.default_pwm_pulses(spec.period))
    if kind == "area_modulated":
        along = np.rint(stripe_coordinate(u, v, spec.angle))
        return binary.area_modulated(theta, along, area_cell)
    gray = 0.5 * (1.0 + np.cos(theta))
    if kind == "bayer":
        return dither.bayer_dither(gray, dither_size)
    if kind == "floyd_steinberg":
        return dither.floyd_steinberg(gray)
    raise ValueError(f"cannot render frame kind {kind!r}")


def render_set(ps: PatternSet, **options) -> np.ndarray:
    """All frames of ``ps`` as ``(F, H, W)`` uint8 (0..255; 1-bit sets give only 0 and 255).

    8-bit frames are rounded from ``255 * intensity``. ``options`` go to :func:`render_frame`.

    Parameters
    ----------
    ps : PatternSet
        The pattern set; its ``width``, ``height`` (projector px) and ``bit_depth`` are used.
    **options
        Keyword arguments of :func:`render_frame` (``dither_size``, ``area_cell``,
        ``pwm_pulses``).

    Returns
    -------
    ndarray
        ``(F, height, width)`` uint8, one frame per entry of ``ps.frames``.

    Examples
    --------
    >>> from fringe3d.patterns import sets
    >>> frames = render_set(sets.phase_shift(16, 3, "v", width=32, height=8))
    >>> frames.shape, frames.dtype
    ((3, 8, 32), dtype('uint8'))
    """
    out = np.empty((len(ps), ps.height, ps.width), dtype=np.uint8)
    for i, spec in enumerate(ps.frames):
        img = render_frame(spec, ps.width, ps.height, **options)
        if ps.bit_depth == 1:
            out[i] = np.where(img >= 0.5, 255, 0)
        else:
            out[i] = np.rint(img * 255.0)
    return out
