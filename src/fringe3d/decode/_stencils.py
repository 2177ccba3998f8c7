"""The neighbourhood filters of the quality map in numba (private; see :mod:`fringe3d.decode.edges`).

Each gives exactly what the ``scipy.ndimage`` call named in its docstring gives (the tests
compare them), at a fraction of the time on a 1280 x 1024 map, so the per-frame quality map
keeps up with the fused 3-step kernel of long sequences:

* :func:`median5` - ``median_filter(g, size=5, mode="nearest")`` (scipy: about half a second):
  a selection network written out as straight-line code (:mod:`fringe3d.decode._median_network`)
  so the pixel loop vectorises. The network
  is Batcher's odd-even merge sort of 32 inputs, cut to 25 inputs (the 7 missing ones are +inf,
  so every comparator that touches them is a no-op) and pruned to the comparators the 13th
  output depends on;
* :func:`max5` - ``grey_dilation(c, size=(5, 5), mode="nearest")``;
* :func:`dilate3` - ``binary_dilation(m, np.ones((3, 3), bool))``;
* :func:`erode_cross` - ``binary_erosion(m, iterations=n, border_value=1)``;
* :func:`neighbour_jump` - the largest jump of ``w`` to a valid 4-neighbour.
"""
from __future__ import annotations

import numba
import numpy as np

from fringe3d.decode._median_network import _median_kernel

SIZE = 5
_N = SIZE * SIZE
_MID = _N // 2


def batcher_pairs(n: int) -> list[tuple[int, int]]:
    """Comparators ``(lo, hi)`` of Batcher's odd-even merge sort of ``n`` (a power of 2) inputs."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def selection_pairs(n: int, rank: int) -> np.ndarray:
    """(M, 2) int64 comparators that put the ``rank``-th smallest of ``n`` inputs at index ``rank``."""
    size = 1 << (n - 1).bit_length()
    net = [(a, b) for a, b in batcher_pairs(size) if b < n]  # b >= n compares with +inf: a no-op
    needed, kept = {rank}, []
    for a, b in reversed(net):
        if a in needed or b in needed:
            kept.append((a, b))
            needed.update((a, b))
    return np.array(kept[::-1], np.int64)


PAIRS = selection_pairs(_N, _MID)


def median5(g: np.ndarray) -> np.ndarray:
    """(H, W) 5 x 5 median of the (H, W) float map ``g`` (no NaN), border replicated: equal to
    ``scipy.ndimage.median_filter(g, size=5, mode="nearest")``."""
    g = np.asarray(g)
    out = np.empty_like(g)
    _median_kernel(np.pad(g, SIZE // 2, mode="edge"), out)
    return out


@numba.njit(parallel=True, cache=True)
def _max5_kernel(cp, out):  # pragma: no cover - compiled
    H, W = out.shape
    rows = np.empty((H + 4, W), cp.dtype)
    for i in numba.prange(H + 4):
        for j in range(W):
            rows[i, j] = max(max(max(cp[i, j], cp[i, j + 1]), max(cp[i, j + 2], cp[i, j + 3])), cp[i, j + 4])
    for i in numba.prange(H):
        for j in range(W):
            out[i, j] = max(max(max(rows[i, j], rows[i + 1, j]), max(rows[i + 2, j], rows[i + 3, j])), rows[i + 4, j])


def max5(c: np.ndarray) -> np.ndarray:
    """(H, W) largest value of each 5 x 5 neighbourhood of ``c`` (no NaN), border replicated:
    ``scipy.ndimage.grey_dilation(c, size=(5, 5), mode="nearest")``."""
    c = np.asarray(c)
    out = np.empty_like(c)
    _max5_kernel(np.pad(c, 2, mode="edge"), out)
    return out


@numba.njit(parallel=True, cache=True)
def _dilate3_kernel(m, out):  # pragma: no cover - compiled
    H, W = m.shape
    rows = np.empty(m.shape, np.uint8)
    for i in numba.prange(H):
        for j in range(W):
            rows[i, j] = m[i, max(j - 1, 0)] | m[i, j] | m[i, min(j + 1, W - 1)]
    for i in numba.prange(H):
        for j in range(W):
            out[i, j] = (rows[max(i - 1, 0), j] | rows[i, j] | rows[min(i + 1, H - 1), j]) != 0


def dilate3(m: np.ndarray) -> np.ndarray:
    """(H, W) bool: ``m`` grown by one pixel (8-connected), nothing beyond the border:
    ``scipy.ndimage.binary_dilation(m, np.ones((3, 3), bool))``."""
    m = np.ascontiguousarray(m, bool)
    out = np.empty_like(m)
    _dilate3_kernel(m, out)
    return out


@numba.njit(parallel=True, cache=True)
def _erode_cross_kernel(m, out):  # pragma: no cover - compiled
    H, W = m.shape
    for i in numba.prange(H):
        for j in range(W):
            out[i, j] = (m[i, j] and (i == 0 or m[i - 1, j]) and (i == H - 1 or m[i + 1, j])
                         and (j == 0 or m[i, j - 1]) and (j == W - 1 or m[i, j + 1]))


def erode_cross(m: np.ndarray, iterations: int = 1) -> np.ndarray:
    """(H, W) bool: ``m`` shrunk ``iterations`` times by its 4-neighbours, the outside counting
    as set: ``scipy.ndimage.binary_erosion(m, iterations=iterations, border_value=1)``."""
    m = np.ascontiguousarray(m, bool)
    for _ in range(int(iterations)):
        out = np.empty_like(m)
        _erode_cross_kernel(m, out)
        m = out
    return m


@numba.njit(parallel=True, cache=True)
def _jump_kernel(w, valid, out):  # pragma: no cover - compiled
    H, W = w.shape
    zero = np.float32(0.0)
    for i in numba.prange(H):
        for j in range(W):
            g = zero
            if valid[i, j]:
                a = np.float32(w[i, j])
                if i > 0 and valid[i - 1, j]:
                    g = max(g, abs(a - np.float32(w[i - 1, j])))
                if i < H - 1 and valid[i + 1, j]:
                    g = max(g, abs(a - np.float32(w[i + 1, j])))
                if j > 0 and valid[i, j - 1]:
                    g = max(g, abs(a - np.float32(w[i, j - 1])))
                if j < W - 1 and valid[i, j + 1]:
                    g = max(g, abs(a - np.float32(w[i, j + 1])))
            out[i, j] = g


def neighbour_jump(w: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(H, W) float32 largest ``|w - w_neighbour|`` (in float32) over the valid 4-neighbours of
    each valid pixel (0 without any)."""
    out = np.empty(np.shape(w), np.float32)
    _jump_kernel(np.ascontiguousarray(w), np.ascontiguousarray(valid, bool), out)
    return out


def _generate_median_network() -> str:
    """Source of :mod:`fringe3d.decode._median_network`'s kernel from :data:`PAIRS`."""
    loads = [f"            v{di * SIZE + dj} = gp[i + {di}, j + {dj}]" for di in range(SIZE) for dj in range(SIZE)]
    ces = [f"            v{a}, v{b} = min(v{a}, v{b}), max(v{a}, v{b})" for a, b in PAIRS]
    head = ("@numba.njit(parallel=True, cache=True)\n"
            "def _median_kernel(gp, out):  # pragma: no cover - compiled; generated from PAIRS, see test_stencils\n"
            "    H, W = out.shape\n    for i in numba.prange(H):\n        for j in range(W):\n")
    return head + "\n".join(loads + ces) + f"\n            out[i, j] = v{_MID}\n"


if __name__ == "__main__":
    print(_generate_median_network(), end="")
