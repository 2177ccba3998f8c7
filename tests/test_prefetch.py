"""The prefetch hint of the compiled sampled passes (:mod:`fringe3d.utils._prefetch`) reads
and writes no value: a pass that asks for every row's lines before copying it copies the
array exactly, whatever the dtype, the layout (a transposed view, a strided one) and the row
length (empty, shorter than a cache line)."""
from __future__ import annotations

import numba
import numpy as np
import pytest

from fringe3d.utils._prefetch import prefetch_lines


@numba.njit(cache=False)
def _copy_prefetching(a, ahead):
    """``a`` (H, W) copied row by row, the row ``ahead`` rows on prefetched before each."""
    out = np.empty(a.shape, a.dtype)
    for i in range(a.shape[0]):
        if i + ahead < a.shape[0]:
            prefetch_lines(a[i + ahead])
        prefetch_lines(a[i])
        for j in range(a.shape[1]):
            out[i, j] = a[i, j]
    return out


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.float64, np.bool_])
@pytest.mark.parametrize("shape", [(5, 0), (3, 1), (7, 13), (9, 200)])
def test_prefetching_rows_changes_no_value(dtype, shape):
    a = (np.random.default_rng(1).random(shape) * 200).astype(dtype)
    before = a.copy()
    views = [a, a.T, a[::2, ::3]] if a.size else [a]
    for v in views:
        np.testing.assert_array_equal(_copy_prefetching(v, 4), v)
    np.testing.assert_array_equal(a, before)
