"""Host entry of the fused 3-step path with every per-pixel output made on the device: ray
parameters masked by the quality tests, the quality map, ``sigma_z`` and the texture
(:mod:`fringe3d.gpu.quality_kernels`), for many cycles at once.

The caller (:class:`fringe3d.reconstruct.frame.FrameReconstructor`) turns its decode options and
rig into the plain numbers of :class:`QualitySettings` and :class:`SigmaRows`; here they only
go up and into the kernels. A chunk of cycles takes seven launches on one stream, its
intermediate maps (``w``, ``A``, ``B``, the jumps, the contrast, the jump test, the noise sums)
kept in pooled device scratch arrays that are never copied back.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fringe3d.gpu.ops import ThreeStepGeometry, _check_index, _cycles, _maps, three_step_constants
from fringe3d.gpu.runtime import cuda_module
from fringe3d.gpu.streaming import DEFAULT_CHUNK, THREADS, launch_grid, run_batched
from fringe3d.utils.camera_size import check_camera_size


class QualitySettings(NamedTuple):
    """The fused path's quality rules as numbers (:func:`fringe3d.decode._fused_quality.fused_quality_map`'s
    arguments, :class:`fringe3d.decode.options.DecodeOptions`).

    Attributes
    ----------
    edge_tests : bool
        Run EDGE, GRADIENT, MOD_DROP and RIM (else INVALID alone).
    lo, hi : float
        Valid range of the fringe coordinate ``w`` with the edge margin taken off (px).
    gradient_ratio, gradient_floor : float
        GRADIENT flags a jump of ``w`` above ``max(gradient_ratio * median, gradient_floor)`` (px).
    modulation_ratio : float
        MOD_DROP flags a contrast ``B / A`` below this fraction of its 5 x 5 neighbourhood's largest.
    rim : int
        RIM flags valid pixels within this many 4-neighbour steps of an invalid one (0: none).
    full_scale : float
        Value of a fully exposed pixel (frames' units), for the texture.
    """

    edge_tests: bool
    lo: float
    hi: float
    gradient_ratio: float
    gradient_floor: float
    modulation_ratio: float
    rim: int
    full_scale: float


class SigmaRows(NamedTuple):
    """The pinhole rays' ``ds/dw`` terms of ``sigma_z``
    (:meth:`fringe3d.optics.rays.RayGeometry.sigma_z_from_phase_noise`).

    Attributes
    ----------
    num, qd, pd : (H, W) float64
        ``P3.O~ Q.D - Q.O~ P3.D``, ``Q.D`` and ``P3.D`` of each pixel's ray.
    t_scale : float
        Projector pixels per radian, ``period / 2π`` (px/rad).
    steps : int
        Phase steps ``N`` (3).
    """

    num: np.ndarray
    qd: np.ndarray
    pd: np.ndarray
    t_scale: float
    steps: int


class FusedOutputs(NamedTuple):
    """Per cycle (C, H, W) (or (H, W) for one cycle): ``depth`` float32 ray parameters (mm, NaN
    where the quality is not 0), ``quality`` uint8 bits, ``sigma_z`` float32 mm (None unless
    asked), ``texture`` float32 fraction of full scale (None unless asked)."""

    depth: np.ndarray
    quality: np.ndarray
    sigma_z: np.ndarray | None
    texture: np.ndarray | None


def sigma_constants(rows: SigmaRows) -> tuple:
    """``rows``' maps uploaded once: ``(num, qd, pd)`` (P,) float64 device arrays."""
    cuda = cuda_module()
    return tuple(cuda.to_device(np.ascontiguousarray(a, np.float64).ravel()) for a in (rows.num, rows.qd, rows.pd))


class DeviceInputs(NamedTuple):
    """What :func:`three_step_outputs` reuses between calls: the fused kernel's ``geometry``,
    its uploaded ``constants`` (:func:`fringe3d.gpu.ops.three_step_constants`), and the sigma
    terms ``sigma`` with their uploaded maps ``sigma_maps`` (:func:`sigma_constants`) or None
    where no ``sigma_z`` is wanted."""

    geometry: ThreeStepGeometry
    constants: tuple
    sigma: SigmaRows | None = None
    sigma_maps: tuple | None = None


def device_inputs(geometry: ThreeStepGeometry, sigma: SigmaRows | None) -> DeviceInputs:
    """:class:`DeviceInputs` with everything uploaded now."""
    return DeviceInputs(geometry, three_step_constants(geometry), sigma,
                        sigma_constants(sigma) if sigma is not None else None)


def three_step_outputs(frames, index, inputs: DeviceInputs, min_mod2: float, settings: QualitySettings,
                       texture: bool, chunk: int = DEFAULT_CHUNK, device_output: bool = False) -> FusedOutputs:
    """The fused 3-step + geometric + triangulation kernel with the quality tests, ``sigma_z``
    (when ``inputs.sigma`` is given) and the texture (when ``texture``), all on the device.

    frames (F, H, W) or (C, F, H, W), host or device; ``index`` the 3 frames of the phase group;
    ``min_mod2`` the squared modulation threshold (frames' units squared). Host frames go up in
    double-buffered chunks of ``chunk`` cycles (:func:`fringe3d.gpu.streaming.run_batched`); the
    outputs come back finished (:class:`FusedOutputs`), equal to the CPU path's
    (:func:`fringe3d.reconstruct.fast_quality.fast_quality` with ``uncertainty="z"``) up to
    float rounding. ``device_output`` leaves them on the device (numba device arrays).
    """
    cuda = cuda_module()
    stack, hw, single = _cycles(frames)
    g, st = inputs.geometry, settings
    check_camera_size(hw, g.D_planes.shape[1:], what="the frames")
    H, W = hw
    p = H * W
    d_idx = cuda.to_device(_check_index(index, stack.shape[1]))
    _, d_coef, d_pm, d_sg = inputs.constants[:4]
    rays = inputs.constants[4:]
    f32 = np.float32
    mm2, sc, full = float(min_mod2), float(g.scale), f32(st.full_scale)
    bits_args = (f32(st.lo), f32(st.hi), f32(st.modulation_ratio), int(st.rim), bool(st.edge_tests))
    want_sigma = inputs.sigma is not None and inputs.sigma_maps is not None
    n_blocks = (p + THREADS - 1) // THREADS
    from fringe3d.gpu import quality_kernels as qk

    def launch(src, arrays, stream):
        n = src.shape[0]
        depth, quality = arrays[0], arrays[1]
        sigma = arrays[2] if want_sigma else None
        k = 2 + int(want_sigma) + int(texture)
        s, w, avg, mod, jump, contrast, t, sums, counts, c_sigma = arrays[k:]
        tex = arrays[k - 1] if texture else s  # s: a stand-in the kernel does not write
        blocks, threads = launch_grid(p, n)
        qk.three_step_fields_kernel[blocks, threads, stream](src, d_idx, d_coef, mm2, d_pm, d_sg, sc, *rays, full, s,
                                                             w, avg, mod, texture, tex)
        qk.jump_contrast_kernel[blocks, threads, stream](s, w, avg, mod, H, W, jump, contrast)
        qk.gradient_test_kernel[blocks, threads, stream](s, jump, H, W, f32(st.gradient_ratio),
                                                         f32(st.gradient_floor), t)
        qk.quality_bits_kernel[blocks, threads, stream](s, w, t, contrast, H, W, *bits_args, quality, depth)
        if sigma is not None:
            assert inputs.sigma is not None and inputs.sigma_maps is not None
            steps = int(inputs.sigma.steps)
            qk.laplacian_partials_kernel[blocks, threads, stream](avg, quality, H, W, sums, counts)
            qk.noise_kernel[(n + THREADS - 1) // THREADS, THREADS, stream](
                sums, counts, math.sqrt(steps), f32(math.sqrt(2.0 / steps)), c_sigma)
            qk.sigma_z_kernel[blocks, threads, stream](w, mod, quality, c_sigma, f32(inputs.sigma.t_scale),
                                                       *inputs.sigma_maps, rays[1], sigma)

    outputs = [((p,), np.float32), ((p,), np.uint8)] + ([((p,), np.float32)] if want_sigma else []) \
        + ([((p,), np.float32)] if texture else [])
    scratch = [((p,), np.float32)] * 6 + [((p,), np.bool_), ((n_blocks,), np.float64), ((n_blocks,), np.int32),
                                          ((1,), np.float32)]
    res = run_batched(cuda, stack, launch, outputs, chunk, device_output, scratch)
    maps = [_maps(r, stack.shape[0], hw, single, device_output) for r in res]
    k = 2 + int(want_sigma)
    return FusedOutputs(maps[0], maps[1], maps[2] if want_sigma else None, maps[k] if texture else None)
