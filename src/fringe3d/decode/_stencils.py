"""The neighbourhood filters of the quality map in numba (private; see :mod:`fringe3d.decode.edges`).

Each gives exactly what the ``scipy.ndimage`` call named in its docstring gives (the tests
compare them), at a fraction of the time on a 1280 x 1024 map, so the per-frame quality map
keeps up with the fused 3-step kernel of long sequences:

* :func:`median5` - ``median_filter(g, size=5, mode="nearest")`` (scipy: about half a second):
  comparator networks written out as straight-line code (:mod:`fringe3d.decode._median_network`)
  so the pixel loops vectorise, sharing work between neighbouring windows: each column of five
  is sorted once (:data:`SORT5`), each pair of adjacent sorted columns merged once
  (:data:`MERGE`), and per pixel the ranks 7 .. 12 of its first four columns (:data:`CORE`)
  meet the fifth column in a min/max formula (about 50 comparisons a pixel instead of the
  113 of a 25-input selection network);
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


#: The 25-input selection network of the median (Batcher's odd-even merge sort of 32 inputs cut
#: to 25, the missing ones +inf, pruned to what the 13th output depends on): 113 comparators for
#: a kernel that takes each pixel's window alone (the CUDA quality kernels'); the CPU kernel shares
#: sorted columns between windows instead (:func:`median5`).
PAIRS = selection_pairs(SIZE * SIZE, SIZE * SIZE // 2)


#: An optimal 9-comparator sorting network of 5 values (Knuth, TAOCP 5.3.4): each column of the
#: window sorted.
SORT5 = ((0, 1), (3, 4), (2, 4), (2, 3), (0, 3), (0, 2), (1, 4), (1, 3), (1, 2))


def odd_even_merge(a: list[int], b: list[int]) -> tuple[list[tuple[int, int]], list[int]]:
    """Batcher's odd-even merge of two sorted lists of wires ``a``, ``b`` (any lengths):
    ``(comparators, wires in sorted order)``; a comparator ``(x, y)`` leaves the smaller value
    on wire ``x``, the larger on ``y``."""
    if not a or not b:
        return [], list(a) + list(b)
    if len(a) == 1 and len(b) == 1:
        return [(a[0], b[0])], [a[0], b[0]]
    pairs_even, v = odd_even_merge(a[0::2], b[0::2])
    pairs_odd, w = odd_even_merge(a[1::2], b[1::2])
    pairs, out = pairs_even + pairs_odd, [v[0]]
    k = 0
    while k < len(w) and k + 1 < len(v):
        pairs.append((w[k], v[k + 1]))
        out += [w[k], v[k + 1]]
        k += 1
    return pairs, out + w[k:] + v[k + 1:]


def pruned(pairs: list[tuple[int, int]], outputs: list[int]) -> list[tuple[int, int]]:
    """The comparators of ``pairs`` that the wires ``outputs`` depend on, in order."""
    needed, kept = set(outputs), []
    for a, b in reversed(pairs):
        if a in needed or b in needed:
            kept.append((a, b))
            needed.update((a, b))
    return kept[::-1]


#: Two adjacent sorted columns (wires 0-4, 5-9) merged: the comparators and the sorted order.
MERGE, MERGE_OUT = odd_even_merge(list(range(5)), list(range(5, 10)))
_CORE_ALL, _CORE_ORDER = odd_even_merge(list(range(10)), list(range(10, 20)))
#: Ranks 7 .. 12 (in order) of four sorted columns given as two merged pairs (wires 0-9, 10-19):
#: with a fifth column, the only ones of the 20 that can be the median of 25 (see :func:`median5`).
CORE_OUT = [_CORE_ORDER[r] for r in range(7, 13)]
CORE = pruned(_CORE_ALL, CORE_OUT)


def median5(g: np.ndarray) -> np.ndarray:
    """(H, W) 5 x 5 median of the (H, W) float map ``g`` (no NaN), border replicated: equal to
    ``scipy.ndimage.median_filter(g, size=5, mode="nearest")``.

    Each column of a window sorted, the 20 values of its first four columns hold 7 below their
    ranks 7 .. 12 and 7 above, so with the fifth column (sorted ``x_0 .. x_4``) the median of the
    25 is the 6th smallest of those six ``k_0 .. k_5`` and the five ``x``:
    ``min(max(k_0, x_4), max(k_1, x_3), max(k_2, x_2), max(k_3, x_1), max(k_4, x_0), k_5)``.
    The columns are sorted, and adjacent pairs merged, once for all the windows that share them
    (:mod:`fringe3d.decode._median_network`)."""
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


#: Output columns per call of the generated ``median_row``; its flat buffers hold rows of
#: ``_STRIDE`` values (constant offsets, so the loops vectorise).
_CHUNK = 256
_STRIDE = _CHUNK + 8

_MEDIAN_HEADER = '''"""The 5 x 5 median as straight-line code (generated by python -m fringe3d.decode._stencils;
private: see the median5 docstring in fringe3d.decode._stencils, which explains the networks).

The comparators of SORT5, MERGE and CORE (fringe3d.decode._stencils) are written out, one
statement each, so the values stay in registers and every pixel loop vectorises.
tests/test_stencils.py checks that this file is the generator's output and that the networks
select the median.
"""
import numba
import numpy as np

#: Output columns per call of median_row.
CHUNK = {chunk}


@numba.njit(cache=True, inline="always")
def median_row(gp, i, j0, n, sb, mb, out):  # pragma: no cover - compiled; generated, see test_stencils
    """out[j] = the median of gp[i:i + 5, j0 + j:j0 + j + 5] for j < n (n <= CHUNK; gp the map
    padded by two pixels); sb, mb flat buffers of 5 * {stride} and 10 * {stride} values: the sorted
    columns, then the merged pairs of adjacent columns."""
'''

_MEDIAN_KERNEL = '''

@numba.njit(parallel=True, cache=True)
def _median_kernel(gp, out):  # pragma: no cover - compiled
    """(H, W) out: the 5 x 5 medians of gp (H + 4, W + 4), row by row."""
    H, W = out.shape
    for i in numba.prange(H):
        sb = np.empty(5 * {stride}, gp.dtype)
        mb = np.empty(10 * {stride}, gp.dtype)
        for j0 in range(0, W, CHUNK):
            median_row(gp, i, j0, min(CHUNK, W - j0), sb, mb, out[i, j0:])
'''


def _at(offset: int, j: str) -> str:
    return f"{j} + {offset}" if offset else j


def _ce(a: int, b: int) -> str:
    return f"        c{a}, c{b} = min(c{a}, c{b}), max(c{a}, c{b})"


def _generate_median_network() -> str:
    """Source of :mod:`fringe3d.decode._median_network` from :data:`SORT5`, :data:`MERGE` and :data:`CORE`."""
    st = _STRIDE
    lines = [f"    g{r} = gp[i + {r}, j0:j0 + n + 4]" for r in range(SIZE)]
    lines += ["    for j in range(n + 4):  # each column sorted"]
    lines += [f"        c{r} = g{r}[j]" for r in range(SIZE)] + [_ce(a, b) for a, b in SORT5]
    lines += [f"        sb[{_at(r * st, 'j')}] = c{r}" for r in range(SIZE)]
    lines += ["    for j in range(n + 2):  # columns j and j + 1 merged"]
    lines += [f"        c{r} = sb[{_at(r * st, 'j')}]" for r in range(SIZE)]
    lines += [f"        c{r + SIZE} = sb[{_at(r * st + 1, 'j')}]" for r in range(SIZE)] + [_ce(a, b) for a, b in MERGE]
    lines += [f"        mb[{_at(k * st, 'j')}] = c{w}" for k, w in enumerate(MERGE_OUT)]
    lines += ["    for j in range(n):  # ranks 7 .. 12 of columns j .. j + 3, then the median with column j + 4"]
    lines += [f"        c{r} = mb[{_at(r * st, 'j')}]" for r in range(10)]
    lines += [f"        c{r + 10} = mb[{_at(r * st + 2, 'j')}]" for r in range(10)] + [_ce(a, b) for a, b in CORE]
    k = [f"c{w}" for w in CORE_OUT]
    x = [f"sb[{_at(r * st + 4, 'j')}]" for r in range(SIZE)]
    lines += [f"        out[j] = min(min(min(max({k[0]}, {x[4]}), max({k[1]}, {x[3]})),",
              f"                         min(max({k[2]}, {x[2]}), max({k[3]}, {x[1]}))),",
              f"                     min(max({k[4]}, {x[0]}), {k[5]}))"]
    return (_MEDIAN_HEADER.format(chunk=_CHUNK, stride=st) + "\n".join(lines) + "\n"
            + _MEDIAN_KERNEL.format(stride=st))


if __name__ == "__main__":
    print(_generate_median_network(), end="")
