"""Spatial (relative) phase unwrapping per isolated object (SPEC §4, ch. 5.2.5).

Reliability-sorting unwrapping (Herráez et al. 2002, the dissertation's [164]) through
``skimage.restoration.unwrap_phase``, run separately on each segmented object. The result is
*relative*: every object carries its own unknown offset ``2π·k_s`` (Eq. 5.12), to be fixed by
a temporal reference (:mod:`fringe3d.unwrap.histogram`, :mod:`fringe3d.unwrap.hybrid`).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from skimage.restoration import unwrap_phase

from .segmentation import segment_objects


def unwrap_group_per_object(ctx, group, phi_min, opts: dict, min_size: int, erode: int):
    """Wrapped phase of one phase group, its isolated objects, each unwrapped spatially.

    FTP / modified-FTP groups (fewer than 3 frames) are analysed on the carrier the rig
    predicts (the gradient of ``phi_min``, the minimum-phase map of Eq. 4.19) when
    ``phi_min`` is given; phase-shifted groups by least squares. Objects are the
    foreground (``opts["min_ratio"]``) split into connected regions of at least
    ``opts["min_size"]`` (default ``min_size``) pixels, eroded by ``opts["erode"]``
    (default ``erode``). Returns ``(phi_r (H, W) relative phase, NaN outside objects,
    labels (H, W) int, the group's PhaseResult)``.
    """
    from .hybrid import carrier_from_minimum_phase, ftp_group_phase, not_saturated
    from .segmentation import foreground_mask

    if len(group.indices) < 3 and phi_min is not None:
        pr = ftp_group_phase(ctx.frames[list(group.indices)], group.shifts, carrier_from_minimum_phase(phi_min),
                             window=str(opts.get("ftp_window", "hanning")))
        valid = not_saturated(ctx, group.indices)
    else:
        pr = ctx.group_phase(group)
        valid = ctx.group_mask(group)
    fg = foreground_mask(pr.average, pr.modulation, float(opts.get("min_ratio", 0.15))) & valid
    labels = segment_objects(fg, min_size=int(opts.get("min_size", min_size)), erode=int(opts.get("erode", erode)))
    phi_r, labels = unwrap_objects(pr.phase, labels=labels)
    return phi_r, labels, pr


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


def _register() -> None:
    from .registry import register

    @register("spatial")
    def unwrap_spatial(ctx):
        """Plan ``method="spatial"``: the narrowest group's wrapped phase unwrapped per object.

        RELATIVE phase: each object is off by an unknown ``2π·k`` (Eq. 5.12); use ``"histogram"``,
        ``"hybrid"`` or a temporal method for absolute 3D. For FTP groups, a rig and ``z_min``
        (when given) fix the carrier and thus the phase's sign; without them the decoder's
        carrier search decides it. Options: ``min_size``, ``erode``, ``min_ratio``,
        ``ftp_window``."""

        groups = sorted(ctx.groups_for_plan(), key=lambda g: g.period)
        if not groups:
            raise ValueError(f"direction {ctx.direction!r}: method 'spatial' found no phase group")
        g = groups[0]
        opts = {**ctx.plan.options, **ctx.options}
        z_min = ctx.z_min if ctx.z_min is not None else opts.get("z_min")
        phi_min = None
        if len(g.indices) < 3 and ctx.rig is not None and z_min is not None:
            from .geometric import _context_geometry, cached_minimum_phase

            rig, z_min = _context_geometry(ctx, "spatial")
            phi_min = cached_minimum_phase(rig, z_min, g.period, g.angle).phi_min
        phi_r, labels, _ = unwrap_group_per_object(ctx, g, phi_min, opts, min_size=64, erode=0)
        return phi_r, np.isfinite(phi_r), {"labels": labels}


_register()
