"""Host side of the three-frequency decode with its assessment on the device
(:mod:`fringe3d.gpu.temporal_kernels`): one cycle's frames go up once, every per-pixel map is made
and kept on the device, and only a few numbers come back between the launches (the clipped
pixels' counts, a 1/64 sample and the float64 moments of the noise model, the radix histograms of
the blur's median) until the finished maps are copied back.

:class:`DeviceDecode` holds the maps of one cycle and offers the steps in the order the decoder's
assessment takes them; :mod:`fringe3d.decode.device_temporal` drives it with the decode options
(this layer knows plain numbers only).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fringe3d.gpu.fused_outputs import QualitySettings
from fringe3d.gpu.ops import _check_index
from fringe3d.gpu.runtime import cuda_module, is_device_array
from fringe3d.gpu.streaming import THREADS


class AssessArrays(NamedTuple):
    """The fused three-frequency pass's inputs (those of
    :func:`fringe3d.unwrap._kernels.three_frequency_assess_kernel`).

    Attributes
    ----------
    indices : tuple of three (N_g,) int64
        Frame indices of each group, narrowest period first.
    coef : tuple of three (3, N_g) float32
        Least-squares coefficients of each group.
    params : (9,) float32
        ``(s12, s123, r_top, r_mid, lower, min_modulation, sat_level, max_residual, clip_level)``.
    design1 : (N_1, 3) float32
        Group 1's design matrix ``[1, cos d_k, sin d_k]``.
    scales : (3,) float64
        ``(T_1 / T_2, T_1 / T_3, 1 / (N_1 - 3))``.
    coef64 : (3, N_2 + N_3) float64
        Groups 2 and 3's coefficients side by side.
    """

    indices: tuple
    coef: tuple
    params: np.ndarray
    design1: np.ndarray
    scales: np.ndarray
    coef64: np.ndarray


class TemporalQuality(NamedTuple):
    """The quality map's rules as numbers: ``tests`` those of the fused quality map
    (:class:`fringe3d.gpu.fused_outputs.QualitySettings`; ``lo``, ``hi`` the extent with the edge
    margin taken off, ``edge_tests`` the decode option ``edge_mask``, which also drops the
    flagged pixels from the mask), ``max_disagreement`` INCONSISTENT's threshold (rad; inf: off)
    and ``w_scale`` the fringe coordinate per radian, ``T_1 / 2 pi`` (px/rad)."""

    tests: QualitySettings
    max_disagreement: float
    w_scale: float


class TemporalMaps(NamedTuple):
    """One cycle's finished maps, (H, W) host arrays: ``phase`` float32 (NaN outside ``mask``),
    ``mask`` bool, ``quality`` uint8, ``phase_sigma`` float32 rad, ``texture`` float32 fraction
    of full scale, ``wrapped``, ``modulation``, ``average`` float32 of group 1."""

    phase: np.ndarray
    mask: np.ndarray
    quality: np.ndarray
    phase_sigma: np.ndarray
    texture: np.ndarray
    wrapped: np.ndarray
    modulation: np.ndarray
    average: np.ndarray


def _grid(n: int) -> tuple[int, int]:
    return max(1, (n + THREADS - 1) // THREADS), THREADS


class DeviceDecode:
    """One cycle's three-frequency decode and assessment maps on the device.

    Parameters
    ----------
    frames : (F, H, W) array, host or device
        The cycle, manifest order.
    arrays : AssessArrays
        The fused pass's inputs.

    Notes
    -----
    Construction runs the fused pass (:func:`fringe3d.gpu.temporal_kernels.three_frequency_assess_kernel`);
    the methods then take the assessment's steps on the maps it left on the device.
    """

    def __init__(self, frames, arrays: AssessArrays):
        from fringe3d.gpu import temporal_kernels as tk

        cuda = cuda_module()
        self.cuda, self.tk = cuda, tk
        if frames.ndim != 3:
            raise ValueError(f"frames must be one cycle (F, H, W), got shape {frames.shape}")
        F, H, W = frames.shape
        self.shape = (H, W)
        P = H * W
        self.n = P
        if is_device_array(frames):
            d_frames = frames.reshape(F, P)
        else:
            a = np.asarray(frames)
            if a.dtype.kind not in "uif":
                raise ValueError(f"frames must hold real numbers (uint8, uint16 or float), got {a.dtype}")
            d_frames = cuda.to_device(np.ascontiguousarray(a).reshape(F, P))
        idx = [cuda.to_device(_check_index(i, F)) for i in arrays.indices]
        coef = [cuda.to_device(np.ascontiguousarray(c, np.float32)) for c in arrays.coef]
        n1 = len(arrays.indices[0])
        f32 = np.float32
        self.phase, self.wrapped, self.modulation, self.average, self.texture_raw = (
            cuda.device_array(P, f32) for _ in range(5))
        self.mask = cuda.device_array(P, np.bool_)
        self.clipped = cuda.device_array((3, P), np.bool_)
        self.variance = cuda.device_array(P if n1 >= 4 else 1, f32)
        self.residual = cuda.device_array(P, f32)
        self.modulation3 = cuda.device_array(P, f32)
        self.quality = cuda.device_array(P, np.uint8)
        tk.three_frequency_assess_kernel[_grid(P)](
            d_frames, idx[0], coef[0], idx[1], coef[1], idx[2], coef[2],
            cuda.to_device(np.ascontiguousarray(arrays.params, f32)),
            cuda.to_device(np.ascontiguousarray(arrays.design1, f32)),
            cuda.to_device(np.ascontiguousarray(arrays.scales, np.float64)),
            cuda.to_device(np.ascontiguousarray(arrays.coef64, np.float64)),
            self.phase, self.wrapped, self.modulation, self.average, self.mask, self.texture_raw, self.clipped,
            self.variance, self.residual, self.modulation3)
        self.broken = None

    # -- clipping -----------------------------------------------------------------------------
    def clipped_counts(self) -> np.ndarray:
        """(3,) int64: each group's pixels with a frame at the clipping level."""
        counts = self.cuda.device_array((_grid(self.n)[0], 3), np.int32)
        self.tk.count_rows_kernel[_grid(self.n)](self.clipped, counts)
        return counts.copy_to_host().sum(axis=0, dtype=np.int64)

    def clipped_maps(self) -> np.ndarray:
        """(3, H, W) bool: each group's clipping flags (copied back)."""
        return self.clipped.copy_to_host().reshape((3,) + self.shape)

    def apply_broken(self, broken: np.ndarray) -> None:
        """Drop the pixels where clipping broke the phase ((H, W) bool, host) from the mask;
        they get SATURATED in the quality map."""
        self.broken = self.cuda.to_device(np.ascontiguousarray(broken, np.bool_).ravel())
        self.tk.apply_broken_kernel[_grid(self.n)](self.broken, self.mask, self.phase)

    # -- the noise model ----------------------------------------------------------------------
    def sample(self, step: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(average, variance, mask)[::step, ::step]`` (host arrays): the reference point's sample."""
        H, W = self.shape
        hs, ws = (H + step - 1) // step, (W + step - 1) // step
        cuda = self.cuda
        xs, ys, ms = cuda.device_array(hs * ws, np.float32), cuda.device_array(hs * ws, np.float32), \
            cuda.device_array(hs * ws, np.bool_)
        self.tk.strided_sample_kernel[_grid(hs * ws)](self.average, self.variance, self.mask, H, W, step, xs, ys, ms)
        return tuple(a.copy_to_host().reshape(hs, ws) for a in (xs, ys, ms))

    def moments(self, model: tuple[float, float] | None, limit: float, ref: tuple[float, float]) -> np.ndarray:
        """(5,) float64 ``(n, sum dx, sum dy, sum dx^2, sum dx dy)`` of the variance against the
        average (:func:`fringe3d.phase._noise_kernel.line_moments`; per-block sums added here)."""
        c0, c1 = model if model is not None else (0.0, 0.0)
        partials = self.cuda.device_array((_grid(self.n)[0], 5), np.float64)
        self.tk.line_moments_kernel[_grid(self.n)](self.average, self.variance, self.mask, float(c0), float(c1),
                                                   float(limit) if model is not None else 0.0, float(ref[0]),
                                                   float(ref[1]), partials)
        return partials.copy_to_host().sum(axis=0)

    # -- the blur estimate's median -----------------------------------------------------------
    def ratio_median(self) -> float:
        """``np.median(B_1 / B_3)`` over the mask's pixels with ``B_3 > 0`` (float32 ratios; NaN
        when none, or when a ratio is NaN), as :func:`fringe3d.decode._ratio_median.ratio_median`."""
        cuda = self.cuda
        blocks = _grid(self.n)[0]
        ratios = cuda.device_array(self.n, np.float32)
        counts = cuda.device_array((blocks, 2), np.int32)
        self.tk.ratio_kernel[_grid(self.n)](self.modulation, self.modulation3, self.mask, ratios, counts)
        n, nans = (int(t) for t in counts.copy_to_host().sum(axis=0, dtype=np.int64))
        if n == 0 or nans:
            return math.nan
        keys = ratios.view(np.uint32)  # ratios >= 0: their bits sort as they do; NaN above all
        ranks = [n // 2] if n % 2 else [n // 2 - 1, n // 2]
        values = np.array(self._select(keys, ranks), np.uint32).view(np.float32)
        if len(values) == 1:
            return float(values[0])
        return float((values[0] + values[1]) / np.float32(2))

    def _select(self, keys, ranks: list[int]) -> list[int]:
        """The ``ranks``-th smallest (0-based) of the uint32 ``keys``: three radix passes of
        11-bit digits, one histogram per distinct prefix (two neighbouring ranks share most)."""
        from fringe3d.gpu.temporal_kernels import RADIX_BINS

        state = [(0, 0, r) for r in ranks]  # (prefix, high bits fixed, rank among the keys of that prefix)
        for shift, width in ((21, 11), (10, 11), (0, 10)):
            hists: dict[int, np.ndarray] = {}
            nxt = []
            for prefix, high, rank in state:
                if prefix not in hists:
                    hist = self.cuda.to_device(np.zeros(RADIX_BINS, np.int32))
                    self.tk.radix_histogram_kernel[_grid(self.n)](keys, np.uint32(prefix), np.uint32(high), shift,
                                                                  hist)
                    hists[prefix] = np.cumsum(hist.copy_to_host())
                upto = hists[prefix]
                b = int(np.searchsorted(upto, rank, side="right"))
                nxt.append((prefix | (b << shift), high | (((1 << width) - 1) << shift),
                            rank - (int(upto[b - 1]) if b else 0)))
            state = nxt
        return [prefix for prefix, _, _ in state]

    # -- the quality map, the phase sigma and the texture --------------------------------------
    def quality_map(self, rules: TemporalQuality) -> None:
        """The quality map of the valid pixels (:mod:`fringe3d.gpu.quality_kernels`), then
        INVALID, SATURATED, INCONSISTENT and, with the edge tests, the mask and phase less the
        flagged pixels (:func:`fringe3d.gpu.temporal_kernels.finish_kernel`)."""
        from fringe3d.gpu import quality_kernels as qk

        cuda, tk, st = self.cuda, self.tk, rules.tests
        H, W = self.shape
        P = self.n
        f32 = np.float32
        w = cuda.device_array(P, f32)
        tk.w_kernel[_grid(P)](self.phase, f32(rules.w_scale), w)
        w2 = w.reshape(1, P)
        jump, contrast, scratch = (cuda.device_array((1, P), f32) for _ in range(3))
        t = cuda.device_array((1, P), np.bool_)
        blocks, threads = (_grid(P)[0], 1), (THREADS, 1)
        q2 = self.quality.reshape(1, P)
        if st.edge_tests:
            qk.jump_contrast_kernel[blocks, threads](w2, w2, self.average.reshape(1, P),
                                                     self.modulation.reshape(1, P), H, W, jump, contrast)
            qk.gradient_test_kernel[blocks, threads](w2, jump, H, W, f32(st.gradient_ratio), f32(st.gradient_floor), t)
        qk.quality_bits_kernel[blocks, threads](w2, w2, t, contrast, H, W, f32(st.lo), f32(st.hi),
                                                f32(st.modulation_ratio), int(st.rim), bool(st.edge_tests), q2,
                                                scratch)
        has_res = bool(st.edge_tests) and math.isfinite(rules.max_disagreement)
        broken = self.broken if self.broken is not None else self.mask
        tk.finish_kernel[_grid(P)](self.quality, self.mask, self.phase, broken, self.broken is not None,
                                   self.residual, f32(rules.max_disagreement), has_res, bool(st.edge_tests))

    def finish(self, model: tuple[float, float], steps: int, full_scale: float) -> TemporalMaps:
        """``sigma_phi`` of the noise ``model`` ``(c0, c1)`` (NaN everywhere where ``c0`` is not
        finite) for a group of ``steps`` steps and the texture as a fraction of ``full_scale``,
        then every map copied back (:class:`TemporalMaps`)."""
        cuda = self.cuda
        f32 = np.float32
        P = self.n
        k, v0, v1 = f32(math.sqrt(2.0 / steps)), f32(model[0]), f32(model[1])
        with np.errstate(invalid="ignore", over="ignore"):
            ks = k * np.sqrt(v0) if v1 == 0 and 0 < v0 < np.inf else f32(0.0)
        sigma, fraction = cuda.device_array(P, f32), cuda.device_array(P, f32)
        self.tk.phase_sigma_kernel[_grid(P)](self.average, self.modulation, self.texture_raw, v0, v1, k, f32(ks),
                                             math.isfinite(model[0]), f32(full_scale), sigma, fraction)
        maps = (self.phase, self.mask, self.quality, sigma, fraction, self.wrapped, self.modulation, self.average)
        return TemporalMaps(*(m.copy_to_host().reshape(self.shape) for m in maps))
