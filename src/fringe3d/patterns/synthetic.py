"""Synthetic captures from a known projector-coordinate map (no scene, no optics).

Each camera pixel sees projector point ``(u_p, v_p)``; frame ``k`` is
``I_k = a + b * P_k(u_p, v_p) + noise`` with ``P_k`` the ideal pattern value
(:func:`fringe3d.patterns.render.sinusoid_value`: Eq. 2.2 for phase frames, exact 0/1 for
code frames). Optional sub-pixel sampling averages several projector points per camera pixel
(pixel integration), so code stripe edges give intermediate values as in a real camera.
Used by the experiments, the demo and the quick-start example; the full simulator is
:mod:`fringe3d.sim`.
"""
from __future__ import annotations

import numpy as np

from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.render import sinusoid_value


def frames_from_coordinates(ps: PatternSet, u_p: np.ndarray, v_p: np.ndarray, a: float = 30.0, b: float = 180.0,
                            noise: float = 0.0, rng: np.random.Generator | None = None,
                            noise_field: np.ndarray | None = None, dtype=np.float32) -> np.ndarray:
    """Frames ``(F, H, W)`` for the projector coordinates seen by each camera pixel.

    Parameters
    ----------
    ps : PatternSet
    u_p, v_p : (H, W) or (S, H, W) float arrays
        Projector column / row (px) seen by each camera pixel; a leading axis of S sub-samples
        is averaged (pixel integration).
    a, b : float
        Ambient offset and projector gain in grey levels: ``I = a + b * P``; the fringe
        modulation of a phase frame is ``B = b / 2``.
    noise : float
        Standard deviation of additive Gaussian noise (grey levels).
    rng : numpy Generator, optional
        Source of the noise (default ``np.random.default_rng(0)``).
    noise_field : (F, H, W) array, optional
        Unit-variance noise to scale by ``noise`` instead of drawing it (so several noise
        levels share one realisation).
    dtype : dtype
        Output dtype (default float32); ``np.uint8``/``np.uint16`` round and clip to the
        type's range.

    Returns
    -------
    ndarray
        ``(F, H, W)`` frames in grey levels, one per entry of ``ps.frames``, of ``dtype``.

    Examples
    --------
    >>> import numpy as np
    >>> from fringe3d.patterns import sets
    >>> up, vp = np.meshgrid(np.arange(6.0), np.arange(4.0))
    >>> frames = frames_from_coordinates(sets.phase_shift(16, 3, "v", width=32, height=8), up, vp)
    >>> frames.shape, frames.dtype, float(frames[0, 0, 0])  # a + b at the crest of frame 0
    ((3, 4, 6), dtype('float32'), 210.0)
    """
    u_p = np.asarray(u_p, dtype=np.float64)
    v_p = np.asarray(v_p, dtype=np.float64)
    if u_p.shape != v_p.shape or u_p.ndim not in (2, 3):
        raise ValueError(f"u_p and v_p must be (H, W) or (S, H, W) of one shape, got {u_p.shape} and {v_p.shape}")
    shape = u_p.shape[-2:]
    out = np.empty((len(ps),) + shape, dtype=np.float64)
    for i, spec in enumerate(ps.frames):
        val = sinusoid_value(spec, u_p, v_p, ps.width, ps.height)
        out[i] = a + b * (val.mean(axis=0) if val.ndim == 3 else val)
    if noise > 0:
        if noise_field is None:
            rng = np.random.default_rng(0) if rng is None else rng
            out += noise * rng.standard_normal(out.shape)
        else:
            if noise_field.shape != out.shape:
                raise ValueError(f"noise_field has shape {noise_field.shape}, expected {out.shape}")
            out += noise * noise_field
    dt = np.dtype(dtype)
    if dt.kind in "ui":
        info = np.iinfo(dt)
        return np.clip(np.rint(out), info.min, info.max).astype(dt)
    return out.astype(dt)
