"""Plain-NumPy reference implementations of the fused numba kernels, used only by the tests
(each states the equation it implements; the tests compare the fast paths against them), and
the previous compiled form of a kernel where a faster one must equal it bit for bit."""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit

from fringe3d.decode._fused_quality import EDGE, GRADIENT, INCONSISTENT, INVALID, MOD_DROP, ORDER, RIM, SATURATED
from fringe3d.decode._median_network import _median_kernel
from fringe3d.decode._stencils import erode_cross
from fringe3d.phase import _kernels
from fringe3d.phase._kernels import COL_CHUNK, FASTMATH, accumulate_chunk, fast_atan2_f32
from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.psp import PhaseResult, default_shifts


def wrapped_phase_reference(frames, shifts=None) -> PhaseResult:
    """Plain-NumPy reference of :func:`wrapped_phase` (float64 math, float32 output).

    Equal shifts use the literal sums of Eq. (2.4); other shifts solve the least-squares
    system with ``numpy.linalg.lstsq``.
    """
    f = as_frame_stack(frames, layout="(N, H, W)").astype(np.float64)
    n = f.shape[0]
    d = default_shifts(n) if shifts is None else np.asarray(shifts, dtype=np.float64)
    if d.size != n:
        raise ValueError(f"got {d.size} phase shifts for {n} frames; expected one shift per frame")
    if n < 3:
        raise ValueError(f"phase shifting needs at least 3 frames, got {n}")
    rel = np.sort(np.mod(d - d[0] + 1e-12, 2 * np.pi) - 1e-12)
    if np.allclose(rel, default_shifts(n), atol=1e-9):  # N equally spaced shifts, any order
        num = -np.tensordot(np.sin(d), f, axes=1)
        den = np.tensordot(np.cos(d), f, axes=1)
        phase = np.arctan2(num, den)
        average = f.mean(axis=0)
        modulation = (2.0 / n) * np.abs(np.tensordot(np.exp(-1j * d), f, axes=1))
    else:
        design = np.stack([np.ones(n), np.cos(d), np.sin(d)], axis=1)
        sol, *_ = np.linalg.lstsq(design, f.reshape(n, -1), rcond=None)
        a, b, c = (s.reshape(f.shape[1:]) for s in sol)
        phase, average, modulation = np.arctan2(-c, b), a, np.hypot(b, c)
    return PhaseResult(phase.astype(np.float32), average.astype(np.float32), modulation.astype(np.float32))


def disagreement_reference(phase, period, wrapped, periods):
    """Plain-NumPy reference of :func:`fringe3d.decode.edges.disagreement`:
    ``max_g |angle(exp(i (phi_g - Phi T_0 / T_g)))|`` in complex128, NaN ignored (``fmax``)."""
    out = np.zeros(np.shape(phase), np.float32)
    for phi_g, t_g in zip(wrapped, periods):
        r = np.angle(np.exp(1j * (np.asarray(phi_g, np.float64) - np.asarray(phase, np.float64) * (period / t_g))))
        out = np.fmax(out, np.abs(r).astype(np.float32))
    return out


def fit_residual_variance_reference(frames, index, shifts):
    """Plain-NumPy reference of :func:`fringe3d.phase.noise.fit_residual_variance`:
    ``|(I - D P) I|^2 / (N - 3)`` by ``tensordot`` and ``einsum`` in float32."""
    from fringe3d.phase.psp import lsq_coefficients
    d = np.asarray(shifts, np.float64)
    design = np.stack([np.ones_like(d), np.cos(d), np.sin(d)], axis=1)
    proj = (np.eye(d.size) - design @ lsq_coefficients(d)).astype(np.float32)
    stack = np.asarray(frames)[list(index)].astype(np.float32)
    res = np.tensordot(proj, stack, axes=1)
    return np.einsum("khw,khw->hw", res, res) / np.float32(d.size - 3)


def fit_noise_model_reference(variance, average, mask):
    """Plain-NumPy reference of :func:`fringe3d.phase.noise.fit_noise_model`: ordinary least
    squares of ``v = c0 + c1 A`` by ``numpy.linalg.lstsq`` over the mask's finite pixels, then
    again on ``v < 5 max(c0 + c1 A, 1e-12)``; ``c1 < 0``: ``(mean v, 0)``."""
    m = np.asarray(mask, bool) & np.isfinite(variance) & np.isfinite(average)
    if m.sum() < 10:
        return float("nan"), float("nan")
    v = np.asarray(variance, np.float64)[m]
    a = np.asarray(average, np.float64)[m]
    keep = np.ones(v.size, bool)
    c0 = c1 = 0.0
    for _ in range(2):
        design = np.stack([np.ones(int(keep.sum())), a[keep]], axis=1)
        c0, c1 = (float(c) for c in np.linalg.lstsq(design, v[keep], rcond=None)[0])
        if c1 < 0:
            c0, c1 = float(v[keep].mean()), 0.0
        keep = v < 5.0 * np.maximum(c0 + c1 * a, 1e-12)
    return c0, c1


def quality_map_reference(mask, w=None, extent=None, margin=2.0, modulation=None, average=None, residual=None,
                          max_disagreement=np.inf, gradient_ratio=4.0, gradient_floor=1.0, modulation_ratio=0.5,
                          rim=1, order=None, saturated=None):
    """Plain-NumPy reference of :func:`fringe3d.decode.edges.quality_map`: one whole-image pass
    per bit with the stencils of :mod:`fringe3d.decode.edges` (the bits of its docstring)."""
    from fringe3d.decode import edges

    def bits(flag, bit):
        return flag.astype(np.uint8) * np.uint8(bit)

    valid = np.asarray(mask, bool)
    q = bits(~valid, edges.INVALID)
    if saturated is not None:
        q |= bits(~valid & saturated, edges.SATURATED)
    if order is not None:
        bad = valid & np.asarray(order, bool)
        valid = valid & ~bad
        q |= bits(bad, edges.ORDER)
    if w is not None and extent is not None:
        q |= bits(valid & edges.edge_band(w, extent, margin), edges.EDGE)
    if residual is not None and np.isfinite(max_disagreement):
        with np.errstate(invalid="ignore"):
            q |= bits(valid & (residual > max_disagreement), edges.INCONSISTENT)
    if w is not None:
        q |= bits(edges.gradient_jump(w, valid, gradient_ratio, gradient_floor), edges.GRADIENT)
    if modulation is not None and average is not None:
        q |= bits(edges.modulation_drop(modulation, average, valid, modulation_ratio), edges.MOD_DROP)
    if rim > 0:
        q |= bits(edges.rim_of_invalid(valid, rim), edges.RIM)
    return q


def estimate_blur_reference(mod_fine, mod_coarse, period_fine, period_coarse, mask):
    """Plain-NumPy reference of :func:`fringe3d.decode.edges.estimate_blur`:
    ``r = np.median(B_fine / B_coarse)`` over ``mask & B_coarse > 0``, then
    ``sigma_b = sqrt(-ln r / (2 pi^2 (1/T_fine^2 - 1/T_coarse^2)))`` (0 unless 0 < r < 1)."""
    import math
    m = np.asarray(mask, bool) & (mod_coarse > 0)
    if not m.any() or not period_coarse > period_fine:
        return 0.0
    r = float(np.median(mod_fine[m] / mod_coarse[m]))
    if not 0 < r < 1:
        return 0.0
    den = 2 * math.pi ** 2 * (1 / period_fine ** 2 - 1 / period_coarse ** 2)
    return float(min(math.sqrt(-math.log(r) / den), period_fine))


def harmonic_bins_reference(frames: np.ndarray) -> np.ndarray:
    """DFT bins 1 and 2, ``(1/N) sum_k I_k exp(-i m delta_k)``, (2, H, W) complex (real products only)."""
    n = frames.shape[0]
    ang = 2.0 * np.pi * np.outer([1, 2], np.arange(n)) / n
    flat = frames.reshape(n, -1)
    re = (np.cos(ang) @ flat) / n
    im = (-np.sin(ang) @ flat) / n
    return (re + 1j * im).reshape((2,) + frames.shape[1:])


def harmonic_ratio_reference(s: np.ndarray, ok: np.ndarray, n: int) -> tuple[float, float]:
    """Least-squares ``c_2 / c_1`` over pixels ``ok`` of an ``n``-step set from its DFT bins 1 and 2
    ``s`` (2, H, W) (:func:`harmonic_bins_reference`), and its standard error."""
    s1 = s[0][ok]
    amp = np.abs(s1)
    rot = (np.conj(s1) / amp) ** 2                  # e^{-2 i phi}
    if n == 4:                                      # Nyquist bin: S_2 = c_2 cos(2 phi), real
        y = s[1][ok].real.astype(complex)
        model = (2.0 * amp * np.real(1.0 / rot)).astype(complex)  # c_1 cos(2 phi)
    else:                                           # S_2 e^{-2 i phi} = c_2 / 2, |S_1| = c_1 / 2
        y = s[1][ok] * rot
        model = amp.astype(complex)
    den = float(np.sum(np.abs(model) ** 2))
    ratio = float(np.sum(np.real(np.conj(model) * y)) / den)
    resid = y - ratio * model
    sigma = float(np.sqrt(np.sum(np.abs(resid) ** 2) / max(1, amp.size - 1) / den))
    return ratio, sigma


# ---- previous compiled forms, kept to pin the faster kernels bit for bit ------------------------
# (numba, serial: the per-pixel arithmetic is the same in a prange loop; the test compares them)

@njit(cache=True, fastmath=FASTMATH)
def psp_kernel_previous(frames, index, coef, sat_level, phase, average, modulation, saturated):
    """:func:`fringe3d.phase._kernels.psp_kernel` as it was before its last loop was split in two
    (one loop mixing the float64 sums and the float32 atan2 and sqrt, run 4 lanes wide)."""
    h, w = frames.shape[1], frames.shape[2]
    acc = np.empty((4, COL_CHUNK))
    a, b, c, peak = acc[0], acc[1], acc[2], acc[3]
    for i in range(h):
        for j0 in range(0, w, COL_CHUNK):
            n = min(COL_CHUNK, w - j0)
            accumulate_chunk(frames, index, coef, i, j0, n, a, b, c, peak, True, True, True)
            for j in range(n):
                bj = np.float32(b[j])
                cj = np.float32(c[j])
                phase[i, j0 + j] = fast_atan2_f32(-cj, bj)
                average[i, j0 + j] = a[j]
                modulation[i, j0 + j] = math.sqrt(bj * bj + cj * cj)
                saturated[i, j0 + j] = saturated[i, j0 + j] | (peak[j] >= sat_level)


def run_psp_kernel(frames, index, coef, sat_level, *outputs):
    """:func:`fringe3d.phase._kernels.psp_kernel` called as :func:`fringe3d.phase.psp.wrapped_phase`
    calls it (the saturation test of :func:`~fringe3d.phase._kernels.saturation_test`, the atan2
    constants), with the outputs in the kernel's order after ``sat_level``."""
    mode, threshold = _kernels.saturation_test(frames.dtype, sat_level)
    _kernels.psp_kernel(frames, index, coef, sat_level, mode, threshold, *outputs, _kernels.ATAN_CONSTANTS)


def interior_laplacian_reference(image, mask):
    """Plain-NumPy ``(per-row sum |I * L|, per-row count)`` (H,) float64 and int64 over the pixels
    of ``mask`` eroded once (the image's outside unset), the 3 x 3 stencil ``L = [[1, -2, 1],
    [-2, 4, -2], [1, -2, 1]]`` summed directly in float64 (the form of
    :func:`fringe3d.phase._noise_kernel.interior_laplacian` before it became separable)."""
    x = np.asarray(image, np.float64)
    m = np.asarray(mask, bool)
    h = x.shape[0]
    sums, counts = np.zeros(h), np.zeros(h, np.int64)
    if h < 3 or x.shape[1] < 3:
        return sums, counts
    c = (slice(1, -1), slice(1, -1))
    r = (4.0 * x[c] - 2.0 * (x[:-2, 1:-1] + x[2:, 1:-1] + x[1:-1, :-2] + x[1:-1, 2:])
         + (x[:-2, :-2] + x[:-2, 2:] + x[2:, :-2] + x[2:, 2:]))
    inside = m[c] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
    sums[1:-1] = np.where(inside, np.abs(r), 0.0).sum(axis=1)
    counts[1:-1] = inside.sum(axis=1)
    return sums, counts


def sense_reference(image, settings, index):
    """Plain-NumPy reference of :func:`fringe3d.sim.noise.sense` without blur (the steps before the
    compiled pass): shot noise (``shot_noise``), read noise ``read_noise * N(0, 1)`` in float32,
    then ``quantize``."""
    from fringe3d.sim.noise import frame_rng, quantize, shot_noise

    rng = frame_rng(settings.seed, index)
    img = shot_noise(np.asarray(image, np.float64), settings.full_well, rng)
    if settings.read_noise > 0:
        img = img + settings.read_noise * rng.standard_normal(img.shape, dtype=np.float32)
    return quantize(img, settings.bit_depth)


def undistort_reference(xy_d, dist, iterations: int = 30, tol: float = 1e-14):
    """Plain-NumPy reference of :func:`fringe3d.optics.distortion.undistort` (five coefficients):
    Newton steps on Eq. (2.12)-(2.16) for all points together until the largest step is below
    ``tol``."""
    k1, k2, p1, p2, k3 = np.asarray(dist, float)
    xy_d = np.asarray(xy_d, float)
    xy = xy_d.copy()
    for _ in range(iterations):
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2)
        fx = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xy_d[..., 0]
        fy = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - xy_d[..., 1]
        jxx = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x
        jxy = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
        jyx = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
        jyy = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x
        det = jxx * jyy - jxy * jyx
        dx = (jyy * fx - jxy * fy) / det
        dy = (-jyx * fx + jxx * fy) / det
        xy = np.stack([x - dx, y - dy], axis=-1)
        if np.nanmax(np.abs(dx) + np.abs(dy), initial=0.0) < tol:
            break
    return xy


# The quality map of fringe3d.decode._fused_quality as it was before its passes were fused
# (issue 29): the new kernels must equal these bit for bit (tests/test_fused_quality.py).
@numba.njit(parallel=True, cache=True, nogil=True)
def jump_contrast_kernel_previous(w, valid, modulation, average, gp, hmax):  # pragma: no cover - compiled
    H, W = w.shape
    zero = np.float32(0.0)
    for i in numba.prange(H):
        # a missing neighbour (outside the image) is the pixel itself: its jump 0 leaves the max
        # alone; the row padded by its end pixels, so the pixel loop is branch-free and vectorises
        u, d = max(i - 1, 0), min(i + 1, H - 1)
        wr = np.empty(W + 2, np.float32)
        vr = np.empty(W + 2, np.bool_)
        for j in range(W):
            wr[j + 1] = w[i, j]
            vr[j + 1] = valid[i, j]
        wr[0], vr[0], wr[W + 1], vr[W + 1] = wr[1], vr[1], wr[W], vr[W]
        c = np.empty(W + 4, np.float32)
        for j in range(W):
            a = wr[j + 1]
            v = vr[j + 1]
            g1 = abs(a - w[u, j]) if (v & valid[u, j]) else zero
            g2 = abs(a - w[d, j]) if (v & valid[d, j]) else zero
            g3 = abs(a - wr[j]) if (v & vr[j]) else zero
            g4 = abs(a - wr[j + 2]) if (v & vr[j + 2]) else zero
            gp[i + 2, j + 2] = max(max(g1, g2), max(g3, g4))
            A = average[i, j]
            c[j + 2] = np.float32(modulation[i, j] / A) if (v & (A > 0)) else zero
        c[0] = c[1] = c[W + 2] = c[W + 3] = zero  # contrast >= 0: a zero pad leaves the maxima alone
        for j in range(W):  # the contrast's largest value over columns j-2..j+2
            hmax[i, j] = max(max(max(c[j], c[j + 1]), max(c[j + 2], c[j + 3])), c[j + 4])
            hmax[i + H, j] = c[j + 2]  # the contrast itself, below
        gp[i + 2, 0] = gp[i + 2, 2]
        gp[i + 2, 1] = gp[i + 2, 2]
        gp[i + 2, W + 2] = gp[i + 2, W + 1]
        gp[i + 2, W + 3] = gp[i + 2, W + 1]
    for j in range(W + 4):  # the replicated top and bottom rows
        gp[0, j] = gp[2, j]
        gp[1, j] = gp[2, j]
        gp[H + 2, j] = gp[H + 1, j]
        gp[H + 3, j] = gp[H + 1, j]


@numba.njit(parallel=True, cache=True, nogil=True)
def jump_test_kernel_previous(valid, gp, ref, g_ratio, g_floor, t):  # pragma: no cover - compiled
    """GRADIENT's test per pixel, once: ``t[i, j + 1] = valid & jump > max(ratio * median, floor)``
    (``t`` (H, W + 2) uint8, its first and last columns 0; ``ref`` the 5 x 5 median)."""
    H, W = valid.shape
    for i in numba.prange(H):
        t[i, 0] = 0
        t[i, W + 1] = 0
        for j in range(W):
            t[i, j + 1] = valid[i, j] & (gp[i + 2, j + 2] > max(g_ratio * ref[i, j], g_floor))


@numba.njit(parallel=True, cache=True, nogil=True)
def jump_count_kernel_previous(valid, gp, g_ratio, g_floor, t):  # pragma: no cover - compiled
    """:func:`jump_test_kernel_previous` without the median: ``jump > ratio * median`` of the 25 jumps
    ``v`` around the pixel exactly when ``ratio * v < jump`` for at least 13 of them (``ratio``
    finite). Per row: each of the five rows of ``v`` scaled once, then its five comparisons
    counted for the whole row (branch-free, contiguous: the loops vectorise)."""
    H, W = valid.shape
    for i in numba.prange(H):
        t[i, 0] = 0
        t[i, W + 1] = 0
        n = np.zeros(W, np.int32)  # 32-bit counts, the float32 lanes' width (uint8 counts were 1.5x slower)
        s = np.empty(W + 4, np.float32)
        c = gp[i + 2, 2:W + 2]
        for a in range(5):
            row = gp[i + a]
            for j in range(W + 4):
                s[j] = g_ratio * row[j]
            for j in range(W):
                cj = c[j]
                n[j] += (np.int32(s[j] < cj) + np.int32(s[j + 1] < cj) + np.int32(s[j + 2] < cj)
                         + np.int32(s[j + 3] < cj) + np.int32(s[j + 4] < cj))
        for j in range(W):
            t[i, j + 1] = valid[i, j] & (c[j] > g_floor) & (n[j] >= 13)


@numba.njit(parallel=True, cache=True, nogil=True)
def bits_kernel_previous(w, valid, t, hmax, lo, hi, m_ratio, rim1, q):  # pragma: no cover - compiled
    """Every bit of row ``i`` from row-clamped neighbours (a repeated row leaves an OR or a max
    alone); each condition is made a 0/1 integer times its bit, so the pixel loops
    are branch-free and vectorise."""
    H, W = w.shape
    for i in numba.prange(H):
        u1, d1 = max(i - 1, 0), min(i + 1, H - 1)
        u2, d2 = max(i - 2, 0), min(i + 2, H - 1)
        vo = np.empty(W + 2, np.uint8)  # GRADIENT: the jump test OR-ed over rows i-1..i+1 ...
        for j in range(W + 2):
            vo[j] = t[u1, j] | t[i, j] | t[d1, j]
        b = np.empty(W, np.uint8)
        for j in range(W):  # ... and columns j-1..j+1; EDGE; MOD_DROP: the contrast's largest
            # value over rows i-2..i+2 of the five-column maxima
            top = max(max(max(hmax[u2, j], hmax[u1, j]), max(hmax[i, j], hmax[d1, j])), hmax[d2, j])
            x = w[i, j]
            b[j] = ((np.uint8((x < lo) | (x > hi)) * np.uint8(EDGE))
                    | ((vo[j] | vo[j + 1] | vo[j + 2]) * np.uint8(GRADIENT))
                    | (np.uint8(hmax[i + H, j] < m_ratio * top) * np.uint8(MOD_DROP)))
        if rim1:  # RIM: a 4-neighbour invalid; the row padded by its own end pixels (the outside counts as valid)
            vp = np.empty(W + 2, np.uint8)
            for j in range(W):
                vp[j + 1] = valid[i, j]
            vp[0] = valid[i, 0]
            vp[W + 1] = valid[i, W - 1]
            for j in range(W):
                inside = vp[j] & vp[j + 1] & vp[j + 2] & np.uint8(valid[u1, j]) & np.uint8(valid[d1, j])
                b[j] |= (inside ^ np.uint8(1)) * np.uint8(RIM)
        for j in range(W):  # the bits where valid (v = 1: a mask of ones), else INVALID alone
            v = np.uint8(valid[i, j])
            q[i, j] = (b[j] & (np.uint8(0) - v)) | ((v ^ np.uint8(1)) * np.uint8(INVALID))


def fused_quality_map_previous(mask: np.ndarray, w: np.ndarray, extent: tuple[float, float], margin: float,
                      modulation: np.ndarray, average: np.ndarray, gradient_ratio: float = 4.0,
                      gradient_floor: float = 1.0, modulation_ratio: float = 0.5, rim: int = 1) -> np.ndarray:
    """(H, W) uint8: ``fringe3d.decode.edges.quality_map(mask, w, extent, margin, modulation,
    average, None, gradient_ratio=..., gradient_floor=..., modulation_ratio=..., rim=...)``
    (one direction, no multi-frequency residual); ``w``, ``modulation``, ``average`` (H, W)
    float32 (px, grey levels), ``mask`` (H, W) bool."""
    valid = np.ascontiguousarray(mask, bool)
    w = np.ascontiguousarray(w, np.float32)
    modulation = np.ascontiguousarray(modulation, np.float32)
    average = np.ascontiguousarray(average, np.float32)
    H, W = valid.shape
    gp = np.empty((H + 4, W + 4), np.float32)
    hmax = np.empty((2 * H, W), np.float32)  # the contrast's row-wise 5-max, then the contrast
    jump_contrast_kernel_previous(w, valid, modulation, average, gp, hmax)
    lo, hi = extent
    f32 = np.float32
    t = np.empty((H, W + 2), np.uint8)
    if math.isfinite(f32(gradient_ratio)):
        jump_count_kernel_previous(valid, gp, f32(gradient_ratio), f32(gradient_floor), t)
    else:  # inf * 0 is NaN: the median itself
        ref = np.empty((H, W), np.float32)
        _median_kernel(gp, ref)
        jump_test_kernel_previous(valid, gp, ref, f32(gradient_ratio), f32(gradient_floor), t)
    q = np.empty((H, W), np.uint8)
    bits_kernel_previous(w, valid, t, hmax, f32(lo + margin), f32(hi - margin), f32(modulation_ratio), rim == 1, q)
    if rim > 1:  # wider rims: the iterated erosion of edges.rim_of_invalid
        q |= (valid & ~erode_cross(valid, int(rim))).astype(np.uint8) * np.uint8(RIM)
    return q


@numba.njit(parallel=True, cache=True)
def finish_kernel_previous(q, mask, order, saturated, residual, thr, has_order, has_sat, has_res):  # pragma: no cover
    """The bits ``fused_quality_map_previous`` does not set, in place: ``q`` was made from ``mask & ~order``."""
    H, W = q.shape
    for i in numba.prange(H):
        for j in range(W):
            if not mask[i, j]:
                q[i, j] = np.uint8(INVALID | SATURATED) if (has_sat and saturated[i, j]) else np.uint8(INVALID)
            elif has_order and order[i, j]:
                q[i, j] = np.uint8(ORDER)
            elif has_res and residual[i, j] > thr:
                q[i, j] |= np.uint8(INCONSISTENT)


def finish_quality_map_previous(q: np.ndarray, mask: np.ndarray, order: np.ndarray | None, saturated: np.ndarray | None,
                       residual: np.ndarray | None, max_disagreement: float) -> None:
    """Add ORDER, SATURATED and INCONSISTENT to ``q`` (H, W) uint8 in place, ``q`` the
    :func:`fused_quality_map_previous` of ``mask & ~order``: the pixels of ``order`` (in ``mask``) become
    ORDER alone, the pixels outside ``mask`` INVALID (with SATURATED where ``saturated``), the
    valid ones get INCONSISTENT where ``residual > max_disagreement`` (compared in the
    residual's dtype, as numpy does); one pass."""
    m = np.ascontiguousarray(mask, bool)
    has_order, has_sat = order is not None, saturated is not None
    has_res = residual is not None and math.isfinite(max_disagreement)
    o = np.ascontiguousarray(order, bool) if order is not None else m
    s = np.ascontiguousarray(saturated, bool) if saturated is not None else m
    r = (np.ascontiguousarray(residual) if residual is not None and has_res else np.zeros((1, 1), np.float32))
    if r.dtype not in (np.float32, np.float64):
        r = r.astype(np.float64)
    finish_kernel_previous(q, m, o, s, r, r.dtype.type(max_disagreement), has_order, has_sat, has_res)
