"""The numba neighbourhood filters of the quality map (and the masked Laplacian noise estimate)
equal their scipy.ndimage counterparts."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from fringe3d.decode import _median_network, _stencils
from fringe3d.decode._stencils import dilate3, erode_cross, max5, median5, neighbour_jump

SHAPES = [(1, 1), (2, 7), (6, 5), (37, 53)]


def _maps(shape, seed=0):
    rng = np.random.default_rng(seed)
    g = rng.random(shape).astype(np.float32)
    g[rng.random(shape) < 0.3] = 0.0  # ties, as the jump maps have (zeros off the valid region)
    return g


@pytest.mark.parametrize("shape", SHAPES)
def test_median5_equals_scipy_median_filter_with_replicated_border(shape):
    g = _maps(shape)
    np.testing.assert_array_equal(median5(g), ndimage.median_filter(g, size=5, mode="nearest"))


def _network(x, pairs):
    """``x`` (M, n) after the comparators ``pairs`` (smaller value to the first wire)."""
    x = x.copy()
    for a, b in pairs:
        x[:, a], x[:, b] = np.minimum(x[:, a], x[:, b]), np.maximum(x[:, a], x[:, b])
    return x


def _sorted_01(n):
    """Every sorted 0/1 column of ``n`` values, (n + 1, n)."""
    return (np.arange(n)[None, :] >= np.arange(n, -1, -1)[:, None]).astype(np.int8)


def test_the_selection_network_sorts_and_selects_the_middle_value():
    rng = np.random.default_rng(1)
    x = rng.random((500, 32))
    for a, b in _stencils.batcher_pairs(32):  # a full sorting network ...
        x[:, a], x[:, b] = np.minimum(x[:, a], x[:, b]), np.maximum(x[:, a], x[:, b])
    assert (np.diff(x, axis=1) >= 0).all()
    y = rng.random((500, 25))
    ref = np.sort(y, axis=1)[:, 12]
    for a, b in _stencils.PAIRS:  # ... and its pruned 25-input cut gives the median
        y[:, a], y[:, b] = np.minimum(y[:, a], y[:, b]), np.maximum(y[:, a], y[:, b])
    np.testing.assert_array_equal(y[:, 12], ref)


def test_sort5_sorts_every_0_1_column():
    x = ((np.arange(32)[:, None] >> np.arange(5)) & 1).astype(np.int8)
    assert (np.diff(_network(x, _stencils.SORT5), axis=1) >= 0).all()


@pytest.mark.parametrize("m, n", [(1, 1), (2, 3), (5, 5), (4, 7), (10, 10)])
def test_odd_even_merge_merges_sorted_lists_of_any_length(m, n):
    pairs, order = _stencils.odd_even_merge(list(range(m)), list(range(m, m + n)))
    a, b = _sorted_01(m), _sorted_01(n)
    x = np.concatenate([np.repeat(a, len(b), 0), np.tile(b, (len(a), 1))], axis=1)
    y = _network(x, pairs)[:, order]
    assert (np.diff(y, axis=1) >= 0).all()
    np.testing.assert_array_equal(y.sum(axis=1), x.sum(axis=1))


def test_the_networks_select_the_median_of_every_column_sorted_0_1_window():
    """By the 0-1 principle (min and max commute with any monotone threshold) the median network
    is right for all inputs when it is for all 0/1 ones; after SORT5 a 0/1 window is five
    sorted columns, 6 ** 5 of them."""
    cols = _sorted_01(5)
    idx = np.stack(np.meshgrid(*[np.arange(6)] * 5, indexing="ij"), -1).reshape(-1, 5)
    win = np.concatenate([cols[idx[:, c]] for c in range(5)], axis=1)  # columns 0..4, each sorted
    merged = [_network(win[:, 10 * p:10 * p + 10], _stencils.MERGE)[:, _stencils.MERGE_OUT] for p in (0, 1)]
    core = _network(np.concatenate(merged, axis=1), _stencils.CORE)[:, _stencils.CORE_OUT]
    k, x = core.T, win[:, 20:25].T
    med = np.minimum.reduce([np.maximum(k[0], x[4]), np.maximum(k[1], x[3]), np.maximum(k[2], x[2]),
                             np.maximum(k[3], x[1]), np.maximum(k[4], x[0]), k[5]])
    np.testing.assert_array_equal(med, np.sort(win, axis=1)[:, 12])


def test_the_median_module_is_the_generators_output():
    import inspect
    assert inspect.getsource(_median_network) == _stencils._generate_median_network()


def test_median5_of_a_wide_map_crosses_the_column_chunks():
    g = _maps((7, 3 * _median_network.CHUNK + 5), 6)
    np.testing.assert_array_equal(median5(g), ndimage.median_filter(g, size=5, mode="nearest"))


@pytest.mark.parametrize("shape", SHAPES)
def test_max5_equals_scipy_grey_dilation(shape):
    c = _maps(shape, 2)
    np.testing.assert_array_equal(max5(c), ndimage.grey_dilation(c, size=(5, 5), mode="nearest"))


@pytest.mark.parametrize("shape", SHAPES)
def test_dilate3_equals_scipy_binary_dilation(shape):
    m = np.random.default_rng(3).random(shape) > 0.7
    np.testing.assert_array_equal(dilate3(m), ndimage.binary_dilation(m, np.ones((3, 3), bool)))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("iterations", [1, 2, 3])
def test_erode_cross_equals_scipy_binary_erosion_with_a_set_border(shape, iterations):
    m = np.random.default_rng(4).random(shape) > 0.15
    np.testing.assert_array_equal(erode_cross(m, iterations),
                                  ndimage.binary_erosion(m, iterations=iterations, border_value=1))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_neighbour_jump_is_the_largest_jump_to_a_valid_4_neighbour(dtype):
    rng = np.random.default_rng(5)
    w = (rng.random((9, 11)) * 100).astype(dtype)
    valid = rng.random((9, 11)) > 0.3
    wz = np.where(valid, w, 0).astype(np.float32)
    expect = np.zeros((9, 11), np.float32)
    for i in range(9):
        for j in range(11):
            for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)):
                if valid[i, j] and 0 <= a < 9 and 0 <= b < 11 and valid[a, b]:
                    expect[i, j] = max(expect[i, j], abs(wz[i, j] - wz[a, b]))
    np.testing.assert_array_equal(neighbour_jump(w, valid), expect)


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_laplacian_noise_over_a_mask_is_the_mean_response_over_the_eroded_mask(dtype):
    import math

    from fringe3d.phase.noise import laplacian_noise
    rng = np.random.default_rng(6)
    image = (rng.random((40, 57)) * 200).astype(dtype)
    mask = rng.random((40, 57)) > 0.2
    kern = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    resp = np.abs(ndimage.convolve(image.astype(np.float64), kern, mode="nearest"))  # Immerkaer's estimate
    keep = ndimage.binary_erosion(mask, iterations=1)
    assert laplacian_noise(image, mask) == pytest.approx(math.sqrt(math.pi / 2) * resp[keep].mean() / 6, rel=1e-12)
