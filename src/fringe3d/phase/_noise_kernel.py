"""Immerkaer's Laplacian response summed over a mask's interior, in numba (private; see
:func:`fringe3d.phase.noise.laplacian_noise`).

One pass instead of scipy's float64 convolution of the whole image plus a binary erosion of the
mask (each a full-image temporary; together about 10x slower on a 1280 x 1024 frame).
"""
from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(parallel=True, cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def _interior_laplacian(image, mask, sums, counts):  # pragma: no cover - compiled
    H, W = image.shape
    for i in numba.prange(1, H - 1):
        acc = 0.0
        n = 0
        for j in range(1, W - 1):  # branch-free (a pixel outside the eroded mask adds 0): the loop vectorises
            inside = (mask[i, j] & mask[i - 1, j] & mask[i + 1, j] & mask[i, j - 1] & mask[i, j + 1])
            r = (4.0 * np.float64(image[i, j])
                 - 2.0 * (np.float64(image[i - 1, j]) + np.float64(image[i + 1, j])
                          + np.float64(image[i, j - 1]) + np.float64(image[i, j + 1]))
                 + (np.float64(image[i - 1, j - 1]) + np.float64(image[i - 1, j + 1])
                    + np.float64(image[i + 1, j - 1]) + np.float64(image[i + 1, j + 1])))
            acc += abs(r) if inside else 0.0
            n += 1 if inside else 0
        sums[i] = acc
        counts[i] = n


def interior_laplacian(image: np.ndarray, mask: np.ndarray) -> tuple[float, int]:
    """``(sum |I * L|, count)`` over the pixels of ``mask`` whose four neighbours are in ``mask``
    and inside the image (``mask`` eroded once, the outside unset), ``L = [[1, -2, 1], [-2, 4,
    -2], [1, -2, 1]]``, in float64 (each row's sum in any order: the last bits may differ from
    a sequential sum)."""
    H = image.shape[0]
    sums = np.zeros(H, np.float64)
    counts = np.zeros(H, np.int64)
    _interior_laplacian(np.ascontiguousarray(image), np.ascontiguousarray(mask, bool), sums, counts)
    return float(sums.sum()), int(counts.sum())


@numba.njit(parallel=True, cache=True, fastmath={"reassoc", "nsz"})
def _residual_sumsq(frames, index, design, coef, out, scale):  # pragma: no cover - compiled
    F, H, W = frames.shape
    N = index.size
    for i in numba.prange(H):
        # row-wise, frame by frame: the pixel loops are contiguous and vectorise
        a = np.zeros(W, np.float64)
        b = np.zeros(W, np.float64)
        c = np.zeros(W, np.float64)
        for k in range(N):
            p0, p1, p2 = coef[0, k], coef[1, k], coef[2, k]
            row = frames[index[k], i]
            for j in range(W):
                x = np.float64(row[j])
                a[j] += p0 * x
                b[j] += p1 * x
                c[j] += p2 * x
        s = np.zeros(W, np.float64)
        for k in range(N):
            d0, d1, d2 = design[k, 0], design[k, 1], design[k, 2]
            row = frames[index[k], i]
            for j in range(W):
                r = np.float64(row[j]) - (d0 * a[j] + d1 * b[j] + d2 * c[j])
                s[j] += r * r
        for j in range(W):
            out[i, j] = np.float32(s[j] * scale)


def residual_sum_of_squares(frames: np.ndarray, index: np.ndarray, design: np.ndarray, coef: np.ndarray,
                            scale: float) -> np.ndarray:
    """(H, W) float32 ``scale * sum_k (I_k - D_k . (P I))^2`` over the frames ``index`` of the
    (F, H, W) stack ``frames``, one pass in float64 (``D`` (N, 3) design, ``P`` (3, N) its
    pseudo-inverse): the least-squares fit residual of Eq. (2.4) with no (N, H, W) temporary."""
    f = np.ascontiguousarray(frames) if frames.ndim == 3 and not frames.flags.c_contiguous else frames
    out = np.empty(f.shape[1:], np.float32)
    _residual_sumsq(f, np.ascontiguousarray(index, np.int64), np.ascontiguousarray(design, np.float64),
                    np.ascontiguousarray(coef, np.float64), out, float(scale))
    return out


@numba.njit(parallel=True, cache=True, fastmath={"reassoc", "nsz"})
def _line_moments(x, y, m, c0, c1, limit, ref_x, ref_y, rows):  # pragma: no cover - compiled
    H, W = x.shape
    for i in numba.prange(H):
        n = 0.0
        sx = 0.0
        sy = 0.0
        sxx = 0.0
        sxy = 0.0
        inf = np.inf
        robust = limit > 0
        for j in range(W):  # branch-free ('&', no short-circuit): the loop vectorises
            xv = np.float64(x[i, j])
            yv = np.float64(y[i, j])
            ok = m[i, j] & (abs(xv) < inf) & (abs(yv) < inf)  # finite: NaN compares False
            # the robust step: keep y < limit * max(c0 + c1 x, 1e-12)
            ok = ok & ((not robust) | (yv < limit * max(c0 + c1 * xv, 1e-12)))
            dx = xv - ref_x
            dy = yv - ref_y
            w = 1.0 if ok else 0.0
            n += w
            sx += dx * w if ok else 0.0
            sy += dy * w if ok else 0.0
            sxx += dx * dx * w if ok else 0.0
            sxy += dx * dy * w if ok else 0.0
        rows[i, 0] = n
        rows[i, 1] = sx
        rows[i, 2] = sy
        rows[i, 3] = sxx
        rows[i, 4] = sxy


def line_moments(x: np.ndarray, y: np.ndarray, mask: np.ndarray, model: tuple[float, float] | None,
                 limit: float, ref: tuple[float, float]) -> np.ndarray:
    """``(n, sum dx, sum dy, sum dx^2, sum dx dy)`` float64 (5,) with ``dx = x - ref[0]``,
    ``dy = y - ref[1]`` over the pixels of ``mask`` where x and y are finite and (with ``model =
    (c0, c1)``) ``y < limit * max(c0 + c1 x, 1e-12)``; one pass over (H, W) x, y (any order of
    the rows' sums: the last bits may differ from a sequential sum)."""
    c0, c1 = model if model is not None else (0.0, 0.0)
    rows = np.zeros((x.shape[0], 5), np.float64)
    _line_moments(np.ascontiguousarray(x), np.ascontiguousarray(y), np.ascontiguousarray(mask, bool),
                  float(c0), float(c1), float(limit) if model is not None else 0.0,
                  float(ref[0]), float(ref[1]), rows)
    return rows.sum(axis=0)


@numba.njit(parallel=True, cache=True)
def _model_phase_sigma(average, modulation, c0, c1, k, out):  # pragma: no cover - compiled
    H, W = average.shape
    inf = np.float32(np.inf)
    zero = np.float32(0.0)
    for i in numba.prange(H):
        for j in range(W):
            v = c1 * average[i, j] + c0  # float32, as numpy with Python-float scalars
            s = np.sqrt(zero if v < zero else v)  # NaN stays NaN (np.maximum)
            b = modulation[i, j]
            out[i, j] = k * s / b if b > zero else inf


def model_phase_sigma(c0: float, c1: float, average: np.ndarray, modulation: np.ndarray, steps: int) -> np.ndarray:
    """(H, W) float32 ``sqrt(2/N) sqrt(max(c0 + c1 A, 0)) / B`` (inf where ``B <= 0``) in one
    pass, each operation in float32 as :func:`fringe3d.phase.noise.noise_sigma` and
    :func:`~fringe3d.phase.noise.phase_sigma` make it (equal bit for bit)."""
    a = np.ascontiguousarray(average, np.float32)
    out = np.empty(a.shape, np.float32)
    f32 = np.float32
    _model_phase_sigma(a, np.ascontiguousarray(modulation, np.float32), f32(c0), f32(c1),
                       f32(math.sqrt(2.0 / steps)), out)
    return out
