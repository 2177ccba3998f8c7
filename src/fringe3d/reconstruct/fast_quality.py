"""Quality map and uncertainty on the fused 3-step path (:class:`~fringe3d.reconstruct.triangulate.FastThreeStep`).

The fused kernel writes the ray parameter ``s`` of each pixel only. To mask edge and mixed
pixels as the decode path does (:mod:`fringe3d.decode.edges`), the fringe coordinate ``w`` is
recovered from ``s`` by the linear projector model (the inverse of the closed form the kernel
solved, :meth:`~fringe3d.optics.rays.RayGeometry.fringe_coordinate_at`) and the modulation is
recomputed from the three frames. One period only: no multi-frequency disagreement test
and no blur estimate (the edge margin is ``edge_margin`` or 2 px). The noise is the Laplacian
estimate of the average image (:func:`fringe3d.phase.noise.laplacian_noise`).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fringe3d.decode import edges
from fringe3d.decode.options import DecodeOptions
from fringe3d.phase import noise
from fringe3d.phase.psp import PhaseResult, wrapped_phase
from fringe3d.reconstruct.triangulate import FastThreeStep
from fringe3d.reconstruct.uncertainty import fast_point_sigma


class FastQuality(NamedTuple):
    """Quality map (H, W) uint8, ``sigma_xyz`` (H, W, 3) float32 mm (None unless asked) and the
    phase result the tests used (:func:`fringe3d.phase.psp.wrapped_phase`; None where none was
    computed), whose ``A + B`` is the texture's intensity (:mod:`fringe3d.decode.texture`)."""

    quality: np.ndarray
    sigma_xyz: np.ndarray | None
    phase: PhaseResult | None = None


def fast_quality(fast: FastThreeStep, frames: np.ndarray, index: np.ndarray, shifts, depth: np.ndarray,
                 extent: tuple[float, float], options: DecodeOptions, uncertainty: bool) -> FastQuality:
    """Quality bits of the fused path's ray parameters ``depth`` (H, W) float32 (mm, NaN invalid,
    :meth:`FastThreeStep.depth`) from ``frames[index]``; with ``options.edge_mask`` the flagged
    pixels are set to NaN in place. ``extent`` is the pattern's extent along ``w`` (projector
    px, pixel edges)."""
    valid = np.isfinite(depth)
    if not options.edge_mask and not uncertainty:  # the superfast path pays nothing extra
        return FastQuality(np.where(valid, 0, edges.INVALID).astype(np.uint8), None)
    w = fast.tri.fringe_coordinate_at(depth)
    pr = wrapped_phase(frames, shifts=shifts, index=index)
    if options.edge_mask:
        margin = edges.BASE_MARGIN if options.edge_margin is None else float(options.edge_margin)
        margin *= edges.oblique_factor(fast.mp.angle)  # the band's width along w (decode.edges docstring)
        q = edges.fused_quality_map(valid, w, extent, margin, pr.modulation, pr.average,
                                    gradient_ratio=float(options.gradient_ratio),
                                    modulation_ratio=float(options.modulation_ratio), rim=int(options.rim))
        depth[q != 0] = np.nan
    else:
        q = np.where(valid, 0, edges.INVALID).astype(np.uint8)
    sigma = None
    if uncertainty:
        keep = q == 0
        s = noise.laplacian_noise(pr.average, keep)
        sigma_n = s * math.sqrt(len(index))  # the average of N frames carries sigma / sqrt(N)
        sigma_w = noise.phase_sigma(sigma_n, pr.modulation, len(index)) * np.float32(fast.mp.period / (2 * math.pi))
        sigma = fast_point_sigma(fast.tri, w, sigma_w, keep)
    return FastQuality(q, sigma, pr)
