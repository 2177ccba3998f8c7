"""Quality map and uncertainty on the fused 3-step path (:class:`~fringe3d.reconstruct.triangulate.FastThreeStep`).

To mask edge and mixed pixels as the decode path does (:mod:`fringe3d.decode.edges`) the
tests need the fringe coordinate ``w``, the average ``A`` and the modulation ``B`` of every
pixel. On the CPU the fused kernel writes them in the same pass as the ray parameters
(:meth:`FastThreeStep.depth_fields`). Given only the ray parameters ``s`` (the CUDA backend),
``w`` is recovered from ``s`` by the linear projector model (the inverse of the closed form the
kernel solved, :meth:`~fringe3d.optics.rays.RayGeometry.fringe_coordinate_at`) and ``A``, ``B``
are recomputed from the three frames. One period only: no multi-frequency disagreement test
and no blur estimate (the edge margin is ``edge_margin`` or 2 px). The noise is the Laplacian
estimate of the average image (:func:`fringe3d.phase.noise.laplacian_noise`); ``sigma_z`` is
``|dz/dw| sigma_w`` with ``sigma_w = sqrt(2/N) sigma / B * T/2pi`` (Eq. 2.4's noise).

The quality map costs about what the fused kernel does (one thread, 1280 x 1024, the
``benchmarks/bench_sequence.py`` scene: 6.5 ms), spread over its row passes, all float32 and
reading the kernel's ``w``, ``A``, ``B`` (nothing recomputed): the jumps of ``w`` 1.3 ms, the
contrast ``B / A`` and its 5-column maxima 1.4, GRADIENT's 25-jump count 1.7 (on that scene 40%
of the valid pixels jump more than the 1 px floor, so nearly every chunk is counted), the bits
2.0. Skipping the count where a lower bound of the median settles it (the middle of the five
rows' 5-column minima leaves 0.7% of the pixels open) was tried: the bound cost what it saved.

Also tried and left out, both byte-identical (one thread, 1280 x 1024, min of 30-40 alternated
runs on a 2-core machine with 32 MB of L3, where the fields stay in the cache and every pass is
bound by its arithmetic): the map made inside the kernel's own pass, the rows streamed through
rings (14.0 against 13.8 ms for the two passes); one pass after the kernel making the map, the
masking, ``keep`` and the noise sums (6.8 against 6.9 ms without the noise, 7.9 against 8.1 with
it: not worth a second copy of the map's row kernels, to be kept equal to the decoder's, and 11 s
more to compile). A float16 ``sigma_z`` made in one pass (no float32 map and cast) saved 0.3 ms of
the writer's 2.6 but ~0.1 ms of a whole frame, for two more kernels to compile.
"""
from __future__ import annotations

import functools
import math
from typing import Callable, NamedTuple

import numpy as np

from fringe3d.decode import edges
from fringe3d.decode.options import DecodeOptions
from fringe3d.phase import noise
from fringe3d.phase.psp import wrapped_phase
from fringe3d.reconstruct._kernels import mask_flagged
from fringe3d.reconstruct.depth import EmptyMaskError
from fringe3d.reconstruct.triangulate import FastThreeStep, ThreeStepFields
from fringe3d.reconstruct.uncertainty import fast_point_sigma


class FastQuality(NamedTuple):
    """Quality map (H, W) uint8; ``sigma_z`` (H, W) and ``sigma_xyz`` (H, W, 3) float32 mm (None
    unless asked); ``average`` and ``modulation`` (H, W) float32, the ``A`` and ``B`` the tests
    used (None where none were computed), whose ``A + B`` is the texture's intensity
    (:mod:`fringe3d.decode.texture`); ``sigma_later`` (uncertainty ``"z later"``) computes
    ``sigma_z`` when called (:func:`sigma_z_map`), else None."""

    quality: np.ndarray
    sigma_z: np.ndarray | None
    sigma_xyz: np.ndarray | None = None
    average: np.ndarray | None = None
    modulation: np.ndarray | None = None
    sigma_later: Callable[[], np.ndarray] | None = None


def invalid_bits(valid: np.ndarray) -> np.ndarray:
    """(H, W) uint8 quality map of a validity mask alone: ``edges.INVALID`` (bit value 1: the
    bool's own byte) where not ``valid``, 0 elsewhere."""
    assert edges.INVALID == 1
    return np.logical_not(valid).view(np.uint8)


def fast_quality(fast: FastThreeStep, frames: np.ndarray, index: np.ndarray, shifts, fields: ThreeStepFields,
                 extent: tuple[float, float], options: DecodeOptions, uncertainty: bool | str) -> FastQuality:
    """Quality bits of the fused path's ray parameters ``fields.depth`` (H, W) float32 (mm, NaN
    invalid) from ``frames[index]``; with ``options.edge_mask`` the flagged pixels are set to NaN
    in place. ``fields``: the kernel's :class:`ThreeStepFields`, or one with only ``depth``
    (``w``, ``average``, ``modulation`` None: recomputed here). ``extent`` is the pattern's
    extent along ``w`` (projector px, pixel edges). ``uncertainty``: ``"z"`` for ``sigma_z``
    alone, True for ``sigma_xyz`` as well, ``"z later"`` for ``sigma_z`` left to a function
    (``sigma_later``: the same map when called, on another thread if the caller likes).
    :class:`EmptyMaskError` when no pixel is valid."""
    depth = fields.depth
    valid = np.isfinite(depth)
    if not valid.any():
        raise EmptyMaskError("the decoded phase mask is empty: no pixel has enough fringe modulation "
                             "(check exposure, modulation threshold and that the scene is lit by the projector)")
    if not options.edge_mask and not uncertainty:  # the superfast path pays nothing extra
        return FastQuality(invalid_bits(valid), None)
    w, avg, mod = fields.w, fields.average, fields.modulation
    if w is None or avg is None or mod is None:
        w = fast.tri.fringe_coordinate_at(depth)
        pr = wrapped_phase(frames, shifts=shifts, index=index)
        avg, mod = pr.average, pr.modulation
    if options.edge_mask:
        margin = edges.edge_margin(options.edge_margin) * edges.oblique_factor(fast.mp.angle)  # as decode.assess
        q = edges.fused_quality_map(valid, w, extent, margin, mod, avg,
                                    gradient_ratio=float(options.gradient_ratio),
                                    modulation_ratio=float(options.modulation_ratio), rim=int(options.rim))
        keep = np.empty(q.shape, bool)  # q == 0, from the same pass
        mask_flagged(depth, q, keep)
    else:
        q = invalid_bits(valid)
        keep = valid  # q == 0 exactly where valid
    sigma_z = sigma_xyz = None
    n = len(index)
    if uncertainty == "z later":
        return FastQuality(q, None, None, avg, mod, functools.partial(sigma_z_map, fast, n, w, avg, mod, keep))
    if uncertainty is True:  # every axis; z is the same bits sigma_z_from_phase_noise gives
        sigma_n = noise.laplacian_noise(avg, keep) * math.sqrt(n)  # the average of N frames carries sigma / sqrt(N)
        sigma_w = noise.phase_sigma(sigma_n, mod, n) * np.float32(fast.mp.period / (2 * math.pi))
        sigma_xyz = fast_point_sigma(fast.tri, w, sigma_w, keep)
        sigma_z = np.ascontiguousarray(sigma_xyz[..., 2])
    elif uncertainty:
        sigma_z = sigma_z_map(fast, n, w, avg, mod, keep)
    return FastQuality(q, sigma_z, sigma_xyz, avg, mod)


def sigma_z_map(fast: FastThreeStep, n: int, w: np.ndarray, average: np.ndarray, modulation: np.ndarray,
                keep: np.ndarray) -> np.ndarray:
    """(H, W) float32 ``sigma_z`` (mm; NaN off ``keep``) of the fused path's ``n``-step fringe
    coordinate ``w`` (px), from the Laplacian noise of the ``average`` over ``keep`` and the
    ``modulation`` (:meth:`~fringe3d.optics.rays.RayGeometry.sigma_z_from_phase_noise`)."""
    sigma_n = noise.laplacian_noise(average, keep) * math.sqrt(n)  # the average of N frames carries sigma / sqrt(N)
    return fast.tri.sigma_z_from_phase_noise(w, modulation, sigma_n, n, fast.mp.period, keep)
