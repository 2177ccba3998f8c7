"""Dithering and binary codes against their definitions."""
import math

import numpy as np
import pytest

from fringe3d.patterns import codes, render_frame, sets
from fringe3d.patterns.dither import bayer_dither, bayer_matrix, floyd_steinberg


def test_bayer_matrix_matches_classic_2x2_and_4x4():
    np.testing.assert_array_equal(bayer_matrix(2), [[0, 2], [3, 1]])
    np.testing.assert_array_equal(bayer_matrix(4), [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]])


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 16])
def test_bayer_matrix_of_any_size_is_a_permutation_of_ranks(n):
    assert sorted(bayer_matrix(n).ravel()) == list(range(n * n))


@pytest.mark.parametrize("n", [2, 4, 6, 8])
def test_bayer_dither_reproduces_constant_grey_levels_within_half_a_level(n):
    for g in np.linspace(0, 1, 23):
        out = bayer_dither(np.full((n * 5, n * 7), g), n)
        assert abs(out.mean() - g) <= 0.5 / (n * n) + 1e-12


def test_floyd_steinberg_keeps_the_mean_and_is_binary():
    rng = np.random.default_rng(1)
    for g in (0.1, 0.37, 0.5, 0.93):
        out = floyd_steinberg(np.full((60, 80), g))
        assert set(np.unique(out)) <= {0.0, 1.0}
        # error is only lost at the right and bottom borders: bounded by (H+W)/(H*W)
        assert abs(out.mean() - g) < (60 + 80) / (60 * 80)
    img = rng.random((40, 50))
    out = floyd_steinberg(img)
    assert abs(out.mean() - img.mean()) < 90 / 2000


@pytest.mark.parametrize("serpentine", [False, True])
def test_floyd_steinberg_matches_a_plain_python_reference(serpentine):
    rng = np.random.default_rng(2)
    img = rng.random((9, 11))
    ref = img.copy()
    out = np.zeros_like(ref)
    h, w = ref.shape
    for i in range(h):
        s = -1 if serpentine and i % 2 else 1
        for j in (range(w - 1, -1, -1) if s < 0 else range(w)):
            new = 1.0 if ref[i, j] >= 0.5 else 0.0
            e = ref[i, j] - new
            out[i, j] = new
            for di, dj, k in ((0, s, 7), (1, -s, 3), (1, 0, 5), (1, s, 1)):
                if 0 <= i + di < h and 0 <= j + dj < w:
                    ref[i + di, j + dj] += e * k / 16
    np.testing.assert_array_equal(floyd_steinberg(img, serpentine=serpentine), out)


def test_gray_code_neighbouring_stripes_differ_in_exactly_one_bit():
    c = np.arange(1000)
    g = codes.gray_encode(c)
    diff = g[1:] ^ g[:-1]
    assert np.all((diff & (diff - 1)) == 0) and np.all(diff > 0)
    np.testing.assert_array_equal(codes.gray_decode(g), c)


@pytest.mark.parametrize("code", ["gray", "binary"])
def test_rendered_code_frames_decode_to_the_stripe_index(code):
    width, height, period = 200, 30, 18.0
    ps = sets.gray_code(period, "v", width=width, height=height, code=code)
    plan = ps.plan("v")
    bits = plan.options["bits"]
    assert bits == math.ceil(math.log2(math.ceil(width / period)))
    assert len(ps) == 2 * bits and ps.bit_depth == 1
    imgs = [render_frame(f, width, height) for f in ps.frames]
    normal = np.stack([im for im, f in zip(imgs, ps.frames) if not f.inverse])
    inverse = np.stack([im for im, f in zip(imgs, ps.frames) if f.inverse])
    np.testing.assert_array_equal(inverse, 1 - normal)
    word = codes.decode_bits((normal > inverse).astype(np.uint8), gray=code == "gray")
    u = np.arange(width)
    np.testing.assert_array_equal(word[0] + plan.options["order_offset"], np.floor(u / period))


def test_code_order_offset_covers_negative_fringe_coordinates():
    # angle > pi/2: w = v cos(a) + u sin(a) is negative at the bottom-left; k must still be floor(w/T)
    width, height, period, a = 64, 48, 10.0, 2.4
    ps = sets.gray_code(period, "a", angle=a, width=width, height=height)
    plan = ps.plan("a")
    assert plan.options["order_offset"] < 0
    normal = np.stack([render_frame(f, width, height) for f in ps.frames if not f.inverse]).astype(np.uint8)
    k = codes.decode_bits(normal, gray=True) + plan.options["order_offset"]
    v, u = np.mgrid[0:height, 0:width]
    np.testing.assert_array_equal(k, np.floor((v * math.cos(a) + u * math.sin(a)) / period))
