"""Immerkaer's Laplacian response summed over a mask's interior, in numba (private; see
:func:`fringe3d.phase.noise.laplacian_noise`).

One pass instead of scipy's float64 convolution of the whole image plus a binary erosion of the
mask (each a full-image temporary; together about 10x slower on a 1280 x 1024 frame).
"""
from __future__ import annotations

import math

import numba
import numpy as np


#: Rows per parallel work item of :func:`_interior_laplacian` (each item computes the
#: horizontal second difference of its rows and of the two rows around them).
_LAPLACIAN_ROWS = 16


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def second_difference_row(x, d):  # pragma: no cover - compiled
    """``d[j] = (x[j - 1] + x[j + 1]) - 2 x[j]`` in float64 for ``j = 1 .. W - 2`` (the horizontal
    factor of the separable Laplacian; ``d[0]`` and ``d[W - 1]`` are not written)."""
    for j in range(1, x.shape[0] - 1):
        d[j] = (np.float64(x[j - 1]) + np.float64(x[j + 1])) - 2.0 * np.float64(x[j])


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def laplacian_row(du, dc, dd, mu, mc, md, inside):  # pragma: no cover - compiled
    """``(sum |L|, count)`` of one row over its pixels in the eroded mask: ``du``, ``dc``, ``dd``
    the :func:`second_difference_row` of the rows above, at and below, ``mu``, ``mc``, ``md``
    their masks as uint8 (0/1), ``inside`` a (W,) uint8 scratch row. One code for
    :func:`_interior_laplacian` and the PSP pass that makes the same sums
    (:func:`fringe3d.phase._kernels.psp_kernel`, whose fast-math flags a callee may be compiled
    under: the results do not depend on them, ``2 x`` being exact a contracted multiply-add
    rounds as the subtraction does, and only the order of a row's float64 sum is free, as here)."""
    W = dc.shape[0]
    # three loops, each vectorised at its own width (bytes, then float64): the mask, the
    # count and the select in the float64 loop took a third longer
    for j in range(1, W - 1):
        inside[j] = mc[j] & mu[j] & md[j] & mc[j - 1] & mc[j + 1]
    n = 0
    for j in range(1, W - 1):
        n += np.int32(inside[j])
    acc = 0.0
    for j in range(1, W - 1):  # branch-free (a pixel outside the eroded mask adds 0)
        v = abs((du[j] + dd[j]) - 2.0 * dc[j])
        acc += v if inside[j] else 0.0
    return acc, n


@numba.njit(cache=True, nogil=True)
def laplacian_ring_step(image, mask, d, inside, r, first, sums, counts):  # pragma: no cover - compiled
    """Row ``r`` of a pass going down rows ``first, first + 1, ...`` of ``image`` (H, W) and
    ``mask`` (bool): its :func:`second_difference_row` into the ring ``d`` (3, W) float64 and,
    once three rows are in the ring (``r >= first + 2``), ``sums[r - 1], counts[r - 1]`` of
    :func:`laplacian_row` (``inside`` (W,) uint8 scratch)."""
    second_difference_row(image[r], d[r % 3])
    if r >= first + 2:
        i = r - 1  # rows i - 1, i, i + 1 have their d
        sums[i], counts[i] = laplacian_row(d[(i - 1) % 3], d[i % 3], d[r % 3], mask[i - 1].view(np.uint8),
                                           mask[i].view(np.uint8), mask[r].view(np.uint8), inside)


@numba.njit(cache=True, nogil=True)
def laplacian_rows_between(image, mask, rows, sums, counts):  # pragma: no cover - compiled
    """``sums[i], counts[i]`` of :func:`laplacian_row` for the first and last row ``i`` of each
    ``rows``-row item of the (H, W) ``image`` (float32) and ``mask`` (bool), the image's first and
    last rows excepted: the rows a row-blocked pass could not sum before its neighbours were
    written (one code for every frame dtype of :func:`fringe3d.phase._kernels.psp_kernel`)."""
    h, w = image.shape
    d = np.empty((3, w))
    inside = np.empty(w, np.uint8)
    for r0 in range(0, h, rows):
        for i in (r0, min(h, r0 + rows) - 1):
            if 1 <= i <= h - 2:
                for r in range(i - 1, i + 2):
                    laplacian_ring_step(image, mask, d, inside, r, i - 1, sums, counts)


@numba.njit(parallel=True, cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def _interior_laplacian(image, mask, sums, counts):  # pragma: no cover - compiled
    # L = [1, -2, 1]^T [1, -2, 1]: the response is the vertical second difference of the rows'
    # horizontal second differences d (float64, three rows in a ring): 2 sums a pixel, not 8.
    # Exact (so equal to the 3 x 3 sum) whenever the float64 sums are, as for float32 and
    # integer images; the row sums then equal the direct form's, in any lane order.
    H, W = image.shape
    nblk = (H - 2 + _LAPLACIAN_ROWS - 1) // _LAPLACIAN_ROWS
    for blk in numba.prange(nblk):
        i0 = 1 + blk * _LAPLACIAN_ROWS
        i1 = min(H - 1, i0 + _LAPLACIAN_ROWS)  # output rows i0 .. i1 - 1
        d = np.zeros((3, W), np.float64)
        inside = np.zeros(W, np.uint8)  # the eroded mask of one row
        for r in range(i0 - 1, i1 + 1):
            laplacian_ring_step(image, mask, d, inside, r, i0 - 1, sums, counts)


def interior_laplacian(image: np.ndarray, mask: np.ndarray) -> tuple[float, int]:
    """``(sum |I * L|, count)`` over the pixels of ``mask`` whose four neighbours are in ``mask``
    and inside the image (``mask`` eroded once, the outside unset), ``L = [[1, -2, 1], [-2, 4,
    -2], [1, -2, 1]]``, in float64 (each row's sum in any order: the last bits may differ from
    a sequential sum); one pass, the stencil as its two separable second differences (equal
    to the 3 x 3 sum wherever the float64 sums are exact: float32 and integer images)."""
    H, W = image.shape
    sums = np.zeros(H, np.float64)
    counts = np.zeros(H, np.int64)
    if W < 3:  # no interior pixel
        return 0.0, 0
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
    # branch-free loops ('&', no short-circuit; a select, no multiply by a 0/1 weight; an integer
    # count): they vectorise, half the work of the weighted form per pixel; the robust test in a
    # loop of its own, so the plain pass does not make it
    H, W = x.shape
    inf = np.inf
    robust = limit > 0
    for i in numba.prange(H):
        n = 0
        sx = 0.0
        sy = 0.0
        sxx = 0.0
        sxy = 0.0
        xr = x[i]
        yr = y[i]
        mr = m[i].view(np.uint8)
        if robust:  # keep y < limit * max(c0 + c1 x, 1e-12)
            for j in range(W):
                xv = np.float64(xr[j])
                yv = np.float64(yr[j])
                ok = (mr[j] != 0) & (abs(xv) < inf) & (abs(yv) < inf) & (yv < limit * max(c0 + c1 * xv, 1e-12))
                dx = xv - ref_x if ok else 0.0
                dy = yv - ref_y if ok else 0.0
                n += np.int32(ok)
                sx += dx
                sy += dy
                sxx += dx * dx
                sxy += dx * dy
        else:
            for j in range(W):
                xv = np.float64(xr[j])
                yv = np.float64(yr[j])
                ok = (mr[j] != 0) & (abs(xv) < inf) & (abs(yv) < inf)  # finite: NaN compares False
                dx = xv - ref_x if ok else 0.0
                dy = yv - ref_y if ok else 0.0
                n += np.int32(ok)
                sx += dx
                sy += dy
                sxx += dx * dx
                sxy += dx * dy
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
def _model_phase_sigma(average, modulation, c0, c1, k, ks, scale, out, fraction):  # pragma: no cover - compiled
    # ks > 0: the constant model (c1 = 0, c0 > 0), ks = k sqrt(c0); a (H, W) ``fraction``: also
    # the fraction of full scale ``scale``, from the same rows while they are in the cache
    H, W = average.shape
    inf = np.float32(np.inf)
    nan = np.float32(np.nan)
    zero = np.float32(0.0)
    one = np.float32(1.0)
    with_fraction = fraction.shape == average.shape
    for i in numba.prange(H):
        if ks > zero:
            for j in range(W):
                s = ks if abs(average[i, j]) < inf else nan  # c0 + 0 A: c0, or NaN for a non-finite A
                b = modulation[i, j]
                out[i, j] = s / b if b > zero else inf
        else:
            for j in range(W):
                v = c1 * average[i, j] + c0  # float32, as numpy with Python-float scalars
                s = np.sqrt(zero if v < zero else v)  # NaN stays NaN (np.maximum)
                b = modulation[i, j]
                out[i, j] = k * s / b if b > zero else inf
        if with_fraction:
            for j in range(W):  # clip(nan_to_num((A + B) / scale), 0, 1) in float32
                t = (average[i, j] + modulation[i, j]) / scale
                fraction[i, j] = zero if t != t else min(max(t, zero), one)


def model_phase_sigma(c0: float, c1: float, average: np.ndarray, modulation: np.ndarray, steps: int) -> np.ndarray:
    """(H, W) float32 ``sqrt(2/N) sqrt(max(c0 + c1 A, 0)) / B`` (inf where ``B <= 0``) in one
    pass, each operation in float32 as :func:`fringe3d.phase.noise.noise_sigma` and
    :func:`~fringe3d.phase.noise.phase_sigma` make it (equal bit for bit). With ``c1 = 0`` and
    ``c0 > 0`` (the Laplacian model) ``c0 + 0 A`` is ``c0`` wherever ``A`` is finite: the
    square root is taken once."""
    return _phase_sigma(c0, c1, average, modulation, steps, None)[0]


def model_phase_sigma_and_fraction(c0: float, c1: float, average: np.ndarray, modulation: np.ndarray, steps: int,
                                   full_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`model_phase_sigma` and, from the same pass, (H, W) float32 ``clip(nan_to_num((A +
    B) / full_scale), 0, 1)`` (each operation in float32: the texture of
    :func:`fringe3d.decode.texture.as_fraction` of ``np.add(A, B, dtype=float32)``)."""
    sigma, fraction = _phase_sigma(c0, c1, average, modulation, steps, float(full_scale))
    assert fraction is not None
    return sigma, fraction


def _phase_sigma(c0: float, c1: float, average: np.ndarray, modulation: np.ndarray, steps: int,
                 full_scale: float | None) -> tuple[np.ndarray, np.ndarray | None]:
    a = np.ascontiguousarray(average, np.float32)
    b = np.ascontiguousarray(modulation, np.float32)
    out = np.empty(a.shape, np.float32)
    f32 = np.float32
    k, v0, v1 = f32(math.sqrt(2.0 / steps)), f32(c0), f32(c1)
    ks = k * np.sqrt(v0) if v1 == 0 and 0 < v0 < np.inf else f32(0.0)
    fraction = np.empty(a.shape if full_scale is not None else (0, 0), np.float32)
    _model_phase_sigma(a, b, v0, v1, k, ks, f32(full_scale if full_scale is not None else 1.0), out, fraction)
    return out, (fraction if full_scale is not None else None)
