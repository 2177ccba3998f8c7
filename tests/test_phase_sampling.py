"""The one bilinear sampler and the one frame-stack check (fringe3d.phase.sampling / .frames)."""
import numpy as np
import pytest

from fringe3d.phase import as_frame_stack, sample_bilinear


def test_bilinear_is_exact_on_planes_nan_outside_and_near_invalid():
    v, u = np.mgrid[0:20, 0:30].astype(float)
    img = 3.0 * u - 2.0 * v + 7.0
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(0, 29, 200), rng.uniform(0, 19, 200)])
    for combine in ("corners", "rows"):
        got = sample_bilinear(img, pts, combine=combine)
        np.testing.assert_allclose(got, 3.0 * pts[:, 0] - 2.0 * pts[:, 1] + 7.0, atol=1e-10)
    outside = sample_bilinear(img, [[-0.1, 3.0], [29.01, 3.0], [np.nan, 1.0], [29.0, 19.0]])
    assert np.isnan(outside[:3]).all() and outside[3] == img[19, 29]
    img[5, 5] = np.nan
    assert np.isnan(sample_bilinear(img, [[5.5, 4.5]])[0])
    img[5, 5] = np.inf
    assert (np.isinf(sample_bilinear(img, [[5.5, 4.5]])[0])
            and np.isnan(sample_bilinear(img, [[5.5, 4.5]], nonfinite="nan")[0]))


def test_bilinear_clamps_and_samples_channels():
    img = np.arange(12.0).reshape(3, 4)
    np.testing.assert_array_equal(sample_bilinear(img, [[-5.0, 1.0], [9.0, 9.0], [np.nan, 0.0]], outside="clamp",
                                                  combine="rows"), [4.0, 11.0, 0.0])
    rgb = np.stack([img, 2 * img], -1)
    np.testing.assert_allclose(sample_bilinear(rgb, [[1.5, 0.5]]), [[3.5, 7.0]])


def test_frame_stack_check():
    assert as_frame_stack([np.zeros((2, 3))] * 3).shape == (3, 2, 3)
    with pytest.raises(ValueError, match="different shapes"):
        as_frame_stack([np.zeros((2, 3)), np.zeros((3, 3))])
    with pytest.raises(ValueError, match="colour"):
        as_frame_stack(np.zeros((2, 4, 4, 3)))
    with pytest.raises(ValueError, match=r"\(N, H, W\) stack"):
        as_frame_stack(np.zeros((4, 4)), layout="(N, H, W)")
    with pytest.raises(ValueError, match="integer or float"):
        as_frame_stack(np.zeros((2, 4, 4), bool))
    with pytest.raises(ValueError, match="no frames"):
        as_frame_stack([])
