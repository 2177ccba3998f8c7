"""Spatial (relative) phase unwrapping per isolated object (ch. 5.2.5).

Reliability-sorting unwrapping (Herráez et al. 2002, the dissertation's [164]) through
``skimage.restoration.unwrap_phase``, run separately on each segmented object. The result is
*relative*: every object carries its own unknown offset ``2π·k_s`` (Eq. 5.12), to be fixed by
a temporal reference (:mod:`fringe3d.unwrap.histogram`, :mod:`fringe3d.unwrap.hybrid`). The
decoder's ``"spatial"`` method is :func:`fringe3d.decode.methods.spatial.unwrap_spatial`.
"""
from __future__ import annotations

import numpy as np

from fringe3d.unwrap.segmentation import segment_objects


def unwrap_objects(wrapped: np.ndarray, mask: np.ndarray | None = None,
                   labels: np.ndarray | None = None, min_size: int = 64,
                   seed: int | None = 0) -> tuple[np.ndarray, np.ndarray]:
    """Unwrap a wrapped phase map object by object.

    Parameters
    ----------
    wrapped : (H, W) float
        Wrapped phase in radians (any 2π-periodic range; NaN = invalid).
    mask : (H, W) bool, optional
        Valid pixels; default: finite pixels of ``wrapped``. Ignored if ``labels`` is given.
    labels : (H, W) int, optional
        Object labels (0 = background) from :func:`fringe3d.unwrap.segmentation.segment_objects`;
        computed from ``mask`` (dropping objects under ``min_size`` pixels) when omitted.
    min_size : int
        Smallest object unwrapped, in pixels.
    seed : int or None
        Seed passed to scikit-image (its reliability sort breaks ties randomly).

    Returns
    -------
    phi_r : (H, W) float32
        Continuous relative phase (rad): within each object it differs from the true absolute
        phase by one constant ``2π·k`` (Eq. 5.12). NaN outside the objects.
    labels : (H, W) int32
        The object labels used.
    """
    wrapped = np.asarray(wrapped, dtype=np.float64)
    if wrapped.ndim != 2:
        raise ValueError(f"wrapped phase must be a 2-D (H, W) array, got shape {wrapped.shape}")
    finite = np.isfinite(wrapped)
    if labels is None:
        if mask is None:
            mask = finite
        mask = np.asarray(mask, bool)
        if mask.shape != wrapped.shape:
            raise ValueError(f"mask shape {mask.shape} differs from phase shape {wrapped.shape}")
        labels = segment_objects(mask & finite, min_size=min_size)
    else:
        labels = np.asarray(labels, np.int32)
        if labels.shape != wrapped.shape:
            raise ValueError(f"labels shape {labels.shape} differs from phase shape {wrapped.shape}")
        labels = np.where(finite, labels, 0).astype(np.int32)
    from scipy import ndimage  # heavy (0.25 s with scipy.special): loaded when objects are unwrapped
    from skimage.restoration import unwrap_phase

    phi_r = np.full(wrapped.shape, np.nan, np.float32)
    for lab, sl in enumerate(ndimage.find_objects(labels), start=1):
        if sl is None:
            continue
        inside = labels[sl] == lab
        if not inside.any():
            continue
        crop = np.ma.masked_array(np.where(inside, wrapped[sl], 0.0), mask=~inside)
        if inside.sum() == 1:
            un = crop.filled(0.0)
        else:
            un = unwrap_phase(crop, rng=seed).filled(np.nan)
        region = phi_r[sl]
        region[inside] = un[inside]
    return phi_r, labels
